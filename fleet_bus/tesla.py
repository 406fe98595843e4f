"""Which vehicle sent a frame: TESLA-style delayed key disclosure on the fleet's TDMA cycles.

Every vehicle holds the fleet key (it must check everyone's frames at once), so a frame's
fleet MAC says only "a vehicle of this fleet sent it": an insider with one vehicle's key
material could speak for any other. TESLA (Perrig, Canetti, Tygar and Song, "Efficient
Authentication and Signing of Multicast Streams over Lossy Channels", IEEE S&P 2000; the
sensor-network variant muTESLA, Perrig et al. 2002) makes the sender provable with symmetric
keys a frame can afford:

- each vehicle has a one-way chain of keys, one per cycle of its TDMA slots: ``K_N`` is drawn
  from its own seed (in its credentials only), ``K_{n-1} = F(K_n)``; every vehicle knows every
  chain's commitment ``K_0`` (the run's public key ring);
- a frame sent in the sender's cycle ``n`` carries a tag under ``K_n`` (a MAC key derived from
  it), and the frames of cycle ``n`` disclose ``K_{n-1}``: the key of the previous cycle, no
  longer secret, whose frames were sent a whole cycle ago;
- a receiver keeps a frame until its cycle's key is disclosed and checks the key by hashing it
  down to a key it already trusts (any later key verifies every earlier cycle, so a lost frame
  costs nothing but delay), then the tag. A frame that arrived after its key could have been
  disclosed proves nothing (anyone may know the key by then) and is refused: the security
  condition, with the receivers' clocks within `CLOCK_MARGIN_S` of the sender's.

Cost: 8 bytes of key on each frame that discloses one (a pose has no room in its 32 bytes and
discloses nothing; `outbox` sends a KEY frame when a disclosure is due), 4 of the 8 MAC bytes
(4 stay the fleet MAC, which keeps outsiders out at once); and one cycle of delay before a
frame counts as its sender's. Keys are 64 bits: to forge, an insider must invert F for a
key not yet disclosed within a cycle, 2^64 hashes.
"""

from __future__ import annotations

import hashlib
import hmac
import math
from collections import deque
from dataclasses import dataclass

KEY_BYTES = 8
TAG_BYTES = 4
CLOCK_MARGIN_S = 1.0  # how far a receiver's mission clock may be from a sender's
MAX_HELD = 64  # frames of one sender kept awaiting their key (beyond: the oldest dropped)
_CHAIN = b"cotsfleet tesla chain v1"
_MAC = b"cotsfleet tesla mac v1"


def _step(key: bytes) -> bytes:
    """F: the key of the cycle before."""
    return hashlib.sha256(_CHAIN + key).digest()[:KEY_BYTES]


def mac_key(key: bytes) -> bytes:
    """The MAC key of a cycle's chain key (TESLA keeps the two apart)."""
    return hmac.new(key, _MAC, hashlib.sha256).digest()


def tag(key: bytes, data: bytes) -> bytes:
    """A frame's TESLA tag under its cycle's chain key."""
    return hmac.new(mac_key(key), data, hashlib.sha256).digest()[:TAG_BYTES]


class KeyChain:
    """A sender's chain of ``length`` cycle keys from its ``seed`` (never disclosed)."""

    def __init__(self, seed: bytes, length: int) -> None:
        if len(seed) < 16:
            raise ValueError("a key chain's seed is at least 16 bytes")
        if length < 1:
            raise ValueError("a key chain has at least one key")
        keys = [hashlib.sha256(b"cotsfleet tesla seed v1" + seed).digest()[:KEY_BYTES]]
        for _ in range(length):
            keys.append(_step(keys[-1]))
        self._keys = keys[::-1]  # _keys[n] = K_n; _keys[0] the commitment
        self.length = length

    @property
    def commitment(self) -> bytes:
        return self._keys[0]

    def key(self, cycle: int) -> bytes:
        """``K_cycle`` (cycles beyond the chain have none: ValueError)."""
        if not 1 <= cycle <= self.length:
            raise ValueError(f"cycle {cycle} outside the key chain (1..{self.length})")
        return self._keys[cycle]


@dataclass
class Held:
    """A frame awaiting its cycle's key: its bytes, tag and cycle, and what to do with it."""

    cycle: int
    data: bytes  # the frame's authenticated bytes (up to the tag)
    tag: bytes
    payload: object  # what the caller hands back once the frame is verified


class Sender:
    """What a receiver knows of one sender's chain, and the frames it holds for it."""

    def __init__(self, commitment: bytes, length: int) -> None:
        self.length = length
        self.trusted_cycle, self.trusted_key = 0, commitment
        self.held: deque[Held] = deque()
        self.dropped = 0  # frames pushed out of `held` by newer ones (a flood, a long silence)

    def key(self, cycle: int) -> bytes | None:
        """``K_cycle`` if a key at or after it is trusted, else None."""
        if cycle > self.trusted_cycle or cycle < 1:
            return None
        k = self.trusted_key
        for _ in range(self.trusted_cycle - cycle):
            k = _step(k)
        return k

    def disclose(self, cycle: int, key: bytes) -> bool:
        """A disclosed ``K_cycle``: trusted if it hashes down to the trusted key (True); a key
        that does not is a forgery (False); an old one changes nothing (True)."""
        if cycle <= self.trusted_cycle:
            return self.key(cycle) == key
        if cycle > self.length:
            return False
        k = key
        for _ in range(cycle - self.trusted_cycle):
            k = _step(k)
        if not hmac.compare_digest(k, self.trusted_key):
            return False
        self.trusted_cycle, self.trusted_key = cycle, key
        return True

    def hold(self, frame: Held) -> None:
        if len(self.held) >= MAX_HELD:
            self.held.popleft()
            self.dropped += 1
        self.held.append(frame)

    def release(self) -> tuple[list[Held], list[Held]]:
        """The held frames whose cycle's key is now trusted: (verified, forged)."""
        good: list[Held] = []
        bad: list[Held] = []
        keep: deque[Held] = deque()
        for h in self.held:
            k = self.key(h.cycle)
            if k is None:
                keep.append(h)
            elif hmac.compare_digest(tag(k, h.data), h.tag):
                good.append(h)
            else:
                bad.append(h)
        self.held = keep
        return good, bad


def chain_length(horizon_s: float, cycle_s: float) -> int:
    """Keys a chain needs for a mission of ``horizon_s`` (with room for late frames)."""
    return int(math.ceil(horizon_s / cycle_s)) + 16


@dataclass(frozen=True)
class FleetChains:
    """What every vehicle knows of every chain: the commitments (``K_0``, in roster order) and
    the chains' length; and, where the chains are derived rather than issued (a simulation,
    or a bus without credentials), their seeds."""

    commitments: tuple[bytes, ...]
    length: int
    seeds: tuple[bytes, ...] | None = None
    # The operator's topside modem's chain (`fleet_bus.orders`): its commitment, and its seed
    # where derived. None: no live orders can be proven in this mission.
    topside: bytes | None = None
    topside_seed: bytes | None = None

    @staticmethod
    def derived(fleet_key: bytes, run_id: str, n_vehicles: int, length: int) -> "FleetChains":
        """Chains derived from the fleet key: every holder of the fleet key can derive every
        chain, so they prove nothing against an insider. For the in-process simulation (whose
        simulated insider is given only its own seed) and for experiments on an open bus;
        missions with credentials are issued random seeds (`fleet_bus.credentials`)."""
        seeds = tuple(hmac.new(fleet_key, b"cotsfleet tesla seed " + run_id.encode() +
                               bytes([v]), hashlib.sha256).digest()[:16]
                      for v in range(n_vehicles))
        top = hmac.new(fleet_key, b"cotsfleet tesla topside " + run_id.encode(),
                       hashlib.sha256).digest()[:16]
        return FleetChains(tuple(KeyChain(s, length).commitment for s in seeds), length, seeds,
                           KeyChain(top, length).commitment, top)
