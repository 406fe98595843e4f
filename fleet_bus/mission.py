"""The mission record (``fleet/mission``) and the mission clock record (``fleet/clock``),
both served by the operator (the launcher) as queryables.

The mission record is what every process needs before it can do anything: the scenario
document, the mission seed and the run id. The agents plan from it (one place, one copy: no
scenario file or seed to keep in step). The clock record (epoch and warp of the shared
`WarpClock`) is served only once every agent is ready, so the mission starts when the
slowest planner is done. Neither ever carries a key.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Any, Callable, TypeVar

import msgpack
import zenoh

from fleet_bus import keys
from fleet_bus import values as v
from fleet_bus.auth import BusAuth, unseal
from fleet_bus.clock import WarpClock

T = TypeVar("T")


@dataclass(frozen=True)
class Mission:
    scenario: dict[str, Any]
    seed: int
    run_id: str

    def encode(self) -> bytes:
        return msgpack.packb({"scenario": self.scenario, "seed": self.seed,
                              "run_id": self.run_id})

    @staticmethod
    def decode(payload: bytes) -> "Mission":
        doc = v.unpack_map(payload, "mission record")
        scenario = doc.get("scenario")
        if not isinstance(scenario, dict):
            raise ValueError("mission record: scenario must be a map")
        return Mission(scenario, v.integer(doc.get("seed"), "mission.seed", 0, 2**63 - 1),
                       v.text(doc.get("run_id"), "mission.run_id", 64))

    def roster(self) -> tuple[str, ...]:
        """Vehicle ids of the scenario, in scenario order (empty if it lists none)."""
        vehicles = self.scenario.get("vehicles")
        if not isinstance(vehicles, list):
            return ()
        return tuple(str(x["id"]) for x in vehicles if isinstance(x, dict) and "id" in x)


@dataclass(frozen=True)
class ClockRecord:
    """The shared mission clock: simulation time ``(wall - epoch_unix) * warp``.

    The operator may slow the clock down during a mission (a process lagging behind it) and
    speed it up again: it then puts a record with a higher ``seq``, whose epoch is chosen so
    that mission time runs on without a jump (`WarpClock.at_warp`). Every process follows the
    newest record."""

    epoch_unix: float
    warp: float
    seq: int = 0

    def __post_init__(self) -> None:
        v.number(self.epoch_unix, "clock.epoch_unix")
        if not v.number(self.warp, "clock.warp") > 0:
            raise ValueError(f"clock.warp must be positive, got {self.warp}")
        v.integer(self.seq, "clock.seq", 0)

    def encode(self) -> bytes:
        return msgpack.packb({"epoch_unix": self.epoch_unix, "warp": self.warp, "seq": self.seq})

    @staticmethod
    def decode(payload: bytes) -> "ClockRecord":
        doc = v.unpack_map(payload, "clock record")
        return ClockRecord(v.number(doc.get("epoch_unix"), "clock.epoch_unix"),
                           v.number(doc.get("warp"), "clock.warp"),
                           v.integer(doc.get("seq", 0), "clock.seq", 0))


def fetch(session: zenoh.Session, key: str, decode: Callable[[bytes], T],
          stop: threading.Event, timeout_s: float, query_timeout_s: float = 2.0,
          retry_s: float = 0.2, auth: BusAuth | None = None) -> T | None:
    """Ask the queryable ``key`` until a well-formed answer comes (the operator may not be up
    yet, or not ready to answer); None if ``stop`` is set or ``timeout_s`` passes first.
    Malformed answers, and with ``auth`` answers not signed by the operator, are skipped
    (and counted by ``auth``): the first reply no longer wins, the first genuine one does."""
    deadline = time.monotonic() + timeout_s
    while not stop.is_set() and time.monotonic() < deadline:
        left = deadline - time.monotonic()
        for reply in session.get(key, timeout=max(0.1, min(query_timeout_s, left))):
            if reply.ok is None:
                continue
            payload = unseal(auth, key, reply.ok.payload.to_bytes())
            if payload is None:
                continue
            try:
                return decode(payload)
            except ValueError:
                if auth is not None:
                    auth.verifier.refuse("invalid")
                continue
        stop.wait(retry_s)
    return None


def fetch_mission(session: zenoh.Session, stop: threading.Event,
                  timeout_s: float, auth: BusAuth | None = None) -> Mission | None:
    """The operator's mission record; with ``auth``, only one of this run (its run id)."""
    def decode(payload: bytes) -> Mission:
        mission = Mission.decode(payload)
        if auth is not None and mission.run_id != auth.run_id:
            raise ValueError(f"mission record of run {mission.run_id!r}, not {auth.run_id!r}")
        return mission

    return fetch(session, keys.MISSION, decode, stop, timeout_s, auth=auth)


def fetch_clock(session: zenoh.Session, stop: threading.Event,
                timeout_s: float, auth: BusAuth | None = None) -> ClockRecord | None:
    return fetch(session, keys.CLOCK, ClockRecord.decode, stop, timeout_s, auth=auth)


def clock_of(session: zenoh.Session, record: ClockRecord,
             auth: BusAuth | None = None) -> tuple[WarpClock, Any]:
    """The mission clock from ``record``, following the operator's later records (a
    slowdown); returns it and the subscriber, to be kept alive."""
    clock = WarpClock(record.epoch_unix, record.warp, seq=record.seq)
    return clock, follow_clock(session, clock, auth)


def follow_clock(session: zenoh.Session, clock: WarpClock,
                 auth: BusAuth | None = None) -> Any:
    """Keep ``clock`` on the newest clock record the operator puts (a slowdown); returns the
    subscriber, to be kept alive. Records not signed by the operator, malformed ones and
    older ones change nothing."""
    def on_sample(sample: zenoh.Sample) -> None:
        payload = unseal(auth, keys.CLOCK, sample.payload.to_bytes())
        if payload is None:
            return
        try:
            record = ClockRecord.decode(payload)
            clock.follow(record.epoch_unix, record.warp, record.seq)
        except ValueError:
            return
    return session.declare_subscriber(keys.CLOCK, on_sample)
