"""The insider of the insider attacks: a vehicle whose credentials leaked (its frame-chain seed,
the fleet MAC key of its ``agent.toml``, its bus login), in the hands of someone who uses them
against the fleet while the vehicle itself keeps working.

Its frames pass the fleet MAC, so they reach every agent; what stops them is what comes after
(docs/security.md, "Insiders"):

- ``all-cleared``: CLEARED segments with every spot's bit set, in its own name, under its own
  chain (`fleet_agent.provenance` proves them its): the peers' plausibility check refuses
  spots nobody saw it clear (`fleet_agent.policies.plausible`).
- ``claim-own``: claims of every spot in its own name: refused beyond what its battery could
  do (the same check).
- ``claim-all``, ``abort-as``: claims of every spot, and an abort, in the name of the next
  vehicle of the roster (the *victim*): tagged under the insider's chain, not the victim's,
  they fail their tag when the victim discloses its key, and are dropped; ``abort-as`` also
  tells the victim's abort as news in its own name, which one witness does not make true.
- ``phantom``: finds of a high priority where there is nothing, in its own name: a finder's
  find must lie near its own track, and a relayed one waits for a second word.
- ``busy-hold`` (`cotsfleet run` only: a simulation has no paced clock to hold): the busy
  announcements of its bus login, which the launcher's clock honours only for
  `ClockControl`'s hold limit, then cools down.

One `Insider` serves both backends: the frames are the same bytes in process and across
processes; only how they enter the water differs (the backend sends them from the insider's
position).
"""

from __future__ import annotations

import numpy as np

from cotsfleet.mission.faults import INSIDER_ATTACKS
from fleet_agent.config import AgentConfig
from fleet_agent.provenance import Provenance
from fleet_agent.wire import Abort, Claim, ClearedSegment, Codec, Digest, Found, Message
from fleet_bus.tesla import FleetChains
from hfc_core.model.problem import Problem

FRAME_ATTACKS = tuple(k for k in INSIDER_ATTACKS if k != "busy-hold")
PHANTOM_PRIORITY = 500.0  # "24 phantom finds of priority 500" (issue 31)
PHANTOM_SERVICE_S = 60.0


def insider_rng(seed: int, index: int) -> np.random.Generator:
    """The insider's stream in a mission seeded ``seed`` (its phantoms, its made-up keys)."""
    return np.random.default_rng([seed, 31, index])


def victim_of(insider: int, n_vehicles: int) -> int:
    """The vehicle an insider speaks for (``claim-all``, ``abort-as``): the next one."""
    return (insider + 1) % n_vehicles


class Insider:
    """Hostile frames of one vehicle's leaked credentials (see the module docstring)."""

    def __init__(self, scenario: Problem, codec: Codec, chains: FleetChains,
                 config: AgentConfig, index: int, seed: bytes,
                 rng: np.random.Generator) -> None:
        """``codec``: the fleet's (`Fleet.wire_of`); ``seed``: the insider's chain seed."""
        self.index, self.rng, self.codec = index, rng, codec
        # Sealed as the insider's own agent seals: its chain's key of the frame's cycle.
        self.provenance = Provenance(codec, chains, index, seed, config.slot_s)
        self.spots = scenario.xyz[: scenario.n_tasks]  # where phantoms are put
        self.victim = victim_of(index, codec.n_vehicles)
        self.find_slots = config.find_slots
        self.phantoms = 0

    def frames(self, kind: str, now_s: float) -> list[bytes]:
        """The frames of one step of attack ``kind`` at mission time ``now_s``."""
        seq = int(now_s)
        c = self.codec
        if kind == "all-cleared":
            return self._own([ClearedSegment(self.index, seq, Digest(c.n_tasks % 128, 0), s,
                                             b"\xff" * c._segment_bytes(s))
                              for s in range(c.n_segments)])
        if kind == "claim-own":
            return self._own([Claim(self.index, seq, seq, chunk) for chunk in self._chunks()])
        if kind == "claim-all":
            return [self._as_victim(Claim(self.victim, seq, seq, chunk))
                    for chunk in self._chunks()]
        if kind == "abort-as":
            return [self._as_victim(Abort(self.victim, seq, seq)),
                    *self._own([Abort(self.index, seq, seq, subject=self.victim)])]
        if kind == "phantom":
            return self._own([self._phantom(seq)]) if self._phantom_slots() else []
        raise ValueError(f"not a frame attack: {kind!r} (one of {FRAME_ATTACKS})")

    def _own(self, msgs: list[Message]) -> list[bytes]:
        return [f for f in (self.provenance.seal(m) for m in msgs) if f is not None]

    def _as_victim(self, msg: Message) -> bytes:
        """``msg`` in the victim's name: the fleet MAC holds (the insider has the fleet key),
        the tag is under the insider's own chain key and the disclosed key is made up (the
        victim's keys of this cycle are not out yet)."""
        cycle = self.provenance.slots[self.index].cycle_of(msg.seq) + 1
        return self.codec.encode(msg, self.provenance.chain.key(cycle), self.rng.bytes(8))

    def _chunks(self) -> list[tuple[int, ...]]:
        n, step = self.codec.n_tasks, max(1, self.codec.max_ids)
        return [tuple(range(a, min(n, a + step))) for a in range(0, n, step)]

    def _phantom_slots(self) -> bool:
        found_from, n = self.codec.found_from, self.codec.n_tasks
        return found_from < n and self.phantoms < self.find_slots

    def _phantom(self, seq: int) -> Found:
        """A find of `PHANTOM_PRIORITY` at a random place over the reef, in the insider's own
        slots from the top (its real finds take them from the bottom)."""
        self.phantoms += 1
        slot = self.codec.found_from + self.index * self.find_slots + self.find_slots - \
            self.phantoms
        lo, hi = self.spots[:, :2].min(axis=0), self.spots[:, :2].max(axis=0)
        x, y = (float(v) for v in self.rng.uniform(lo, hi))
        depth = float(np.median(self.spots[:, 2]))
        return Found(self.index, seq, Digest(0, 0), slot, (x, y, depth), PHANTOM_PRIORITY,
                     PHANTOM_SERVICE_S)
