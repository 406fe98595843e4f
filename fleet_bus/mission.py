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
    """The shared mission clock: simulation time ``(wall - epoch_unix) * warp``."""

    epoch_unix: float
    warp: float

    def __post_init__(self) -> None:
        v.number(self.epoch_unix, "clock.epoch_unix")
        if not v.number(self.warp, "clock.warp") > 0:
            raise ValueError(f"clock.warp must be positive, got {self.warp}")

    def encode(self) -> bytes:
        return msgpack.packb({"epoch_unix": self.epoch_unix, "warp": self.warp})

    @staticmethod
    def decode(payload: bytes) -> "ClockRecord":
        doc = v.unpack_map(payload, "clock record")
        return ClockRecord(v.number(doc.get("epoch_unix"), "clock.epoch_unix"),
                           v.number(doc.get("warp"), "clock.warp"))


def fetch(session: zenoh.Session, key: str, decode: Callable[[bytes], T],
          stop: threading.Event, timeout_s: float, query_timeout_s: float = 2.0,
          retry_s: float = 0.2) -> T | None:
    """Ask the queryable ``key`` until a well-formed answer comes (the operator may not be up
    yet, or not ready to answer); None if ``stop`` is set or ``timeout_s`` passes first.
    Malformed answers are skipped."""
    deadline = time.monotonic() + timeout_s
    while not stop.is_set() and time.monotonic() < deadline:
        left = deadline - time.monotonic()
        for reply in session.get(key, timeout=max(0.1, min(query_timeout_s, left))):
            if reply.ok is None:
                continue
            try:
                return decode(reply.ok.payload.to_bytes())
            except ValueError:
                continue
        stop.wait(retry_s)
    return None


def fetch_mission(session: zenoh.Session, stop: threading.Event,
                  timeout_s: float) -> Mission | None:
    return fetch(session, keys.MISSION, Mission.decode, stop, timeout_s)


def fetch_clock(session: zenoh.Session, stop: threading.Event,
                timeout_s: float) -> ClockRecord | None:
    return fetch(session, keys.CLOCK, ClockRecord.decode, stop, timeout_s)
