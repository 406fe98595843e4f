"""Zenoh key expressions of the fleet bus and the codecs of its simulation-side payloads.

Radio traffic: agents put wire frames on ``fleet/tx/<id>``; only the relay subscribes to them
and, through the channel model, puts what survives on ``fleet/rx/<dst>``. Agents never
subscribe to another vehicle's ``tx`` or ``truth`` keys: ``truth`` is simulation bookkeeping
(where the vehicle really is) for the relay and the ground station, not a radio.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import msgpack

PREFIX = "fleet"


def tx_key(vid: str) -> str:
    return f"{PREFIX}/tx/{vid}"


def rx_key(vid: str) -> str:
    return f"{PREFIX}/rx/{vid}"


def truth_key(vid: str) -> str:
    return f"{PREFIX}/truth/{vid}"


def status_key(vid: str) -> str:
    return f"{PREFIX}/status/{vid}"


def event_key(vid: str) -> str:
    return f"{PREFIX}/event/{vid}"


def ctl_key(vid: str) -> str:
    """Launcher -> agent fault-injection commands (abort); not a radio either."""
    return f"{PREFIX}/ctl/{vid}"


def link_event_key(src: str, dst: str) -> str:
    return f"{PREFIX}/link/{src}/{dst}"


TX_ALL = f"{PREFIX}/tx/*"
TRUTH_ALL = f"{PREFIX}/truth/*"
STATUS_ALL = f"{PREFIX}/status/*"
EVENT_ALL = f"{PREFIX}/event/*"
LINK_ALL = f"{PREFIX}/link/**"
LINK_CTL = f"{PREFIX}/ctl/link"  # launcher -> relay: extra loss, partitions
LINK_STATS = f"{PREFIX}/stats/link"  # relay queryable: drop/delivery counters
MISSION = f"{PREFIX}/mission"  # launcher queryable: scenario, epoch, warp, seed (late joiners)


def vid_of(key: str) -> str:
    """The vehicle id at the end of a per-vehicle key such as ``fleet/truth/auv2``."""
    return key.rsplit("/", 1)[-1]


@dataclass(frozen=True)
class Truth:
    """Where a vehicle really is at simulation time ``t_s`` (eq. 3-6 state, NED metres/deg)."""

    t_s: float
    pos: tuple[float, float, float]
    yaw_deg: float = 0.0
    pitch_deg: float = 0.0
    state: str = "transit"

    def encode(self) -> bytes:
        return msgpack.packb(
            {"t": self.t_s, "p": list(self.pos), "yaw": self.yaw_deg, "pitch": self.pitch_deg,
             "state": self.state}
        )

    @staticmethod
    def decode(payload: bytes) -> "Truth":
        """Raises ValueError on anything that is not a well-formed truth record."""
        try:
            doc: Any = msgpack.unpackb(payload)
            pos = tuple(float(c) for c in doc["p"])
            if len(pos) != 3:
                raise ValueError("position needs 3 coordinates")
            return Truth(float(doc["t"]), pos, float(doc.get("yaw", 0.0)),
                         float(doc.get("pitch", 0.0)), str(doc.get("state", "transit")))
        except (ValueError, TypeError, KeyError, msgpack.UnpackException) as exc:
            raise ValueError(f"malformed truth record: {exc}") from None


@dataclass(frozen=True)
class Mission:
    """What a late joiner needs (served by the launcher as a queryable on `MISSION`): the
    scenario document, the shared clock (`comms_sim.clock.WarpClock` epoch and warp), the
    seed and a run id. Never the fleet key: that stays with the agents."""

    scenario: dict[str, Any]
    epoch_unix: float
    warp: float
    seed: int
    run_id: str

    def encode(self) -> bytes:
        return msgpack.packb(
            {"scenario": self.scenario, "epoch_unix": self.epoch_unix, "warp": self.warp,
             "seed": self.seed, "run_id": self.run_id}
        )

    @staticmethod
    def decode(payload: bytes) -> "Mission":
        try:
            doc: Any = msgpack.unpackb(payload, strict_map_key=False)
            return Mission(dict(doc["scenario"]), float(doc["epoch_unix"]), float(doc["warp"]),
                           int(doc["seed"]), str(doc["run_id"]))
        except Exception as exc:  # msgpack raises several unrelated types on garbage
            raise ValueError(f"malformed mission record: {exc}") from None
