"""Telemetry: where a vehicle really is (``fleet/truth/<id>``), what it reports about itself
(``fleet/status/<id>``) and what happened (``fleet/event/<id>``).

Not radio traffic (no size limit, never read by other agents): the truth is the simulated
world's bookkeeping for the relay and the ground station; statuses and events are what an
operator would see over a tether or after recovery, and what the mission report is built
from. Payloads are msgpack maps; decoders ignore unknown fields (either side can grow first)
and validate every value they keep.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import msgpack

from fleet_bus import values as v
from fleet_bus.states import EventKind, VehicleState

# Vehicle states (`fleet_bus.states.VehicleState`), under the names the callers know.
TRANSIT, INJECTING, RETURNING, HOME, ABORTED, DEAD = VehicleState
STATES = tuple(VehicleState)

# Event kinds of the dashboard's event log.
EVENT_KINDS = tuple(k.value for k in EventKind)  # every kind an agent may report


def position_detail(pos: tuple[float, ...]) -> str:
    """How a find's position opens an event's detail ("x,y,z", decimetres): the simulated
    world's bookkeeping names the real spot a find's treatment treated by where it is."""
    return ",".join(f"{c:.1f}" for c in pos)


def detail_position(detail: str) -> tuple[float, float, float] | None:
    """The position `position_detail` put at the start of ``detail`` (None: there is none)."""
    try:
        x, y, z = (float(c) for c in detail.split()[0].split(","))
    except (ValueError, IndexError):
        return None
    return (x, y, z) if all(c == c and abs(c) != float("inf") for c in (x, y, z)) else None


STOPPED_PREFIX = "stopped injecting after "
INJECTED_WORD = "injected"


def _seconds(s: float) -> str:
    """How an event's detail tells a duration ("33.0 s"; the timeline reads it back)."""
    return f"{max(0.0, s):.1f} s"


def _read_seconds(number: str, unit: str) -> float | None:
    """The duration `_seconds` wrote as ``number`` ``unit`` (None: not a sane one)."""
    if unit != "s":
        return None
    try:
        s = float(number)
    except ValueError:
        return None
    return s if 0.0 <= s < float("inf") else None


def stopped_detail(injected_s: float) -> str:
    """The detail of a claim-lost event (an injection left to a live peer's earlier claim)
    or a judged-treated one (left because a peer's clear of the spot was heard) when the
    vehicle stopped injecting: the timeline counts those seconds as injecting
    (`cotsfleet.reporting.timeline`)."""
    return f"{STOPPED_PREFIX}{_seconds(injected_s)}"


def cleared_detail(injected_s: float, pos: tuple[float, ...] | None = None) -> str:
    """The detail of a cleared event: the find's position first when it is one (the world's
    bookkeeping reads it: `detail_position`), then how long the injection lasted, which after
    a look is what the camera measured, not the map's time (the timeline reads it)."""
    told = f"{INJECTED_WORD} {_seconds(injected_s)}"
    return told if pos is None else f"{position_detail(pos)} {told}"


def detail_injected_s(detail: str) -> float | None:
    """The seconds `cleared_detail` put in ``detail`` (None: a log from before it did)."""
    words = detail.split()
    for a, b, c in zip(words, words[1:], words[2:]):
        if a == INJECTED_WORD and c == "s":
            return _read_seconds(b, c)
    return None


def detail_stopped_s(detail: str) -> float | None:
    """The seconds `stopped_detail` put in ``detail`` (None: it stopped no injection)."""
    words = detail[len(STOPPED_PREFIX):].split()
    if not detail.startswith(STOPPED_PREFIX) or not words:
        return None
    return _read_seconds(words[0], "s")  # the unit was never checked here: old logs read


@dataclass(frozen=True)
class Truth:
    """Where a vehicle really is at simulation time ``t_s`` (eq. 3-6 state, NED metres/deg)."""

    t_s: float
    pos: tuple[float, float, float]
    yaw_deg: float = 0.0
    pitch_deg: float = 0.0
    state: str = TRANSIT

    def encode(self) -> bytes:
        return msgpack.packb({"t": self.t_s, "p": list(self.pos), "yaw": self.yaw_deg,
                              "pitch": self.pitch_deg, "state": self.state})

    @staticmethod
    def decode(payload: bytes) -> Truth:
        """Raises ValueError on anything that is not a well-formed truth record."""
        doc = v.unpack_map(payload, "truth")
        try:
            return Truth(v.number(doc["t"], "truth.t"), v.point(doc["p"], "truth.p"),
                         v.number(doc.get("yaw", 0.0), "truth.yaw"),
                         v.number(doc.get("pitch", 0.0), "truth.pitch"),
                         v.text(doc.get("state", TRANSIT), "truth.state", 32))
        except KeyError as exc:
            raise ValueError(f"truth: missing {exc}") from None


@dataclass(frozen=True)
class Status:
    """One vehicle's periodic self-report."""

    t_s: float
    id: str
    state: str
    pos: tuple[float, float, float]
    battery_s: float  # battery time left
    t_diff_s: float  # eq. 12, projected: battery left minus time to finish the route
    route: list[int]  # scenario task ids still to treat, in order
    treated: list[int]  # task ids this vehicle injected
    cleared_known: int  # size of the vehicle's grow-only cleared set
    priority_collected: float
    distance_m: float
    peers: dict[str, str] = field(default_factory=dict)  # id -> a `PeerState`
    claims: list[int] = field(default_factory=list)  # task ids this vehicle holds by claim
    counters: dict[str, int] = field(default_factory=dict)  # msgs sent/received/dropped[reason]
    # How far behind the mission clock the vehicle's process ran since its last status (its
    # worst late tick, mission seconds): the operator slows the clock down when it grows.
    lag_s: float = 0.0
    # Peers that said what could not be, and how often (`fleet_agent.policies.plausible`):
    # an insider's lies are refused and show here.
    suspects: dict[str, int] = field(default_factory=dict)

    def encode(self) -> bytes:
        return msgpack.packb(asdict(self))

    @staticmethod
    def decode(payload: bytes) -> Status:
        doc = v.unpack_map(payload, "status")
        try:
            return Status(
                t_s=v.number(doc["t_s"], "status.t_s"),
                id=v.text(doc["id"], "status.id", 64),
                state=v.text(doc["state"], "status.state", 32),
                pos=v.point(doc["pos"], "status.pos"),
                battery_s=v.number(doc["battery_s"], "status.battery_s"),
                t_diff_s=v.number(doc["t_diff_s"], "status.t_diff_s"),
                route=v.ids(doc["route"], "status.route"),
                treated=v.ids(doc["treated"], "status.treated"),
                cleared_known=v.integer(doc["cleared_known"], "status.cleared_known", 0),
                priority_collected=v.number(doc["priority_collected"],
                                            "status.priority_collected"),
                distance_m=v.number(doc["distance_m"], "status.distance_m"),
                peers=v.str_map(doc.get("peers", {}), "status.peers", str),
                claims=v.ids(doc.get("claims", []), "status.claims"),
                counters=v.str_map(doc.get("counters", {}), "status.counters", int),
                lag_s=v.number(doc.get("lag_s", 0.0), "status.lag_s"),
                suspects=v.str_map(doc.get("suspects", {}), "status.suspects", int),
            )
        except KeyError as exc:
            raise ValueError(f"status: missing {exc}") from None


@dataclass(frozen=True)
class Event:
    """Something an operator wants in the log: see `EVENT_KINDS`."""

    t_s: float
    id: str
    kind: str
    tasks: list[int] = field(default_factory=list)
    peer: str = ""  # the other vehicle involved, if any
    detail: str = ""

    def encode(self) -> bytes:
        return msgpack.packb(asdict(self))

    @staticmethod
    def decode(payload: bytes) -> Event:
        doc = v.unpack_map(payload, "event")
        try:
            return Event(v.number(doc["t_s"], "event.t_s"), v.text(doc["id"], "event.id", 64),
                         v.text(doc["kind"], "event.kind", 32),
                         v.ids(doc.get("tasks", []), "event.tasks"),
                         v.text(doc.get("peer", ""), "event.peer", 64),
                         v.text(doc.get("detail", ""), "event.detail"))
        except KeyError as exc:
            raise ValueError(f"event: missing {exc}") from None

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def encode_busy(busy: bool) -> bytes:
    """The payload of ``fleet/busy/<id>``: one byte, 1 a planner run starts, 0 it ended."""
    return b"\x01" if busy else b"\x00"


def decode_busy(payload: bytes) -> bool:
    """ValueError unless ``payload`` is one of `encode_busy`'s."""
    if payload not in (b"\x00", b"\x01"):
        raise ValueError(f"busy: not a busy flag: {payload[:8]!r}")
    return payload == b"\x01"


@dataclass(frozen=True)
class Ready:
    """The payload of ``fleet/alive/<id>``: this vehicle's initial plan is computed, for run
    ``run_id`` (``""`` on an open bus, where no run is named)."""

    id: str
    run_id: str = ""

    def encode(self) -> bytes:
        return msgpack.packb({"id": self.id, "run_id": self.run_id})

    @staticmethod
    def decode(payload: bytes) -> Ready:
        """Raises ValueError on anything that is not a well-formed announcement."""
        doc = v.unpack_map(payload, "ready")
        try:
            return Ready(v.text(doc["id"], "ready.id", 64), v.text(doc["run_id"], "ready.run_id"))
        except KeyError as exc:
            raise ValueError(f"ready: missing {exc}") from None
