"""Agent telemetry for the ground station: ``fleet/status/<id>`` and ``fleet/event/<id>``.

Not radio traffic (no size limit, never read by other agents): it is what an operator would
see over a tether or after recovery, and what the mission report is built from. Payloads are
msgpack maps; decoders ignore unknown fields so either side can grow first.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import msgpack

# Vehicle states shown on the dashboard and in reports.
STATES = ("transit", "injecting", "returning", "home", "aborted", "dead")
# Event kinds of the dashboard's event log.
EVENT_KINDS = (
    "cleared",  # this vehicle finished injecting a spot
    "claim",  # claimed spots (cooperation or takeover)
    "claim_lost",  # lost a conflicting claim and dropped the spots
    "abort",  # this vehicle aborted (announced)
    "lost",  # this vehicle declared a peer lost (missed heartbeats or abort heard)
    "revived",  # a peer declared lost was heard again
    "takeover",  # spots of a lost vehicle taken into this vehicle's route
    "replan",  # local route changed
    "restart",  # the agent process restarted from its log
)


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
    peers: dict[str, str] = field(default_factory=dict)  # id -> "alive" | "lost" | "aborted"
    claims: list[int] = field(default_factory=list)  # task ids this vehicle holds by claim
    counters: dict[str, int] = field(default_factory=dict)  # msgs sent/received/dropped[reason]

    def encode(self) -> bytes:
        return msgpack.packb(asdict(self))

    @staticmethod
    def decode(payload: bytes) -> "Status":
        doc = _unpack(payload)
        known = {k: doc[k] for k in Status.__dataclass_fields__ if k in doc}
        try:
            known["pos"] = tuple(known["pos"])
            return Status(**known)
        except (KeyError, TypeError) as exc:
            raise ValueError(f"malformed status: {exc}") from None


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
    def decode(payload: bytes) -> "Event":
        doc = _unpack(payload)
        known = {k: doc[k] for k in Event.__dataclass_fields__ if k in doc}
        try:
            return Event(**known)
        except TypeError as exc:
            raise ValueError(f"malformed event: {exc}") from None


def _unpack(payload: bytes) -> dict[str, Any]:
    try:
        doc = msgpack.unpackb(payload, strict_map_key=False)
    except Exception as exc:  # msgpack raises several unrelated types on garbage
        raise ValueError(f"not msgpack: {exc}") from None
    if not isinstance(doc, dict):
        raise ValueError("telemetry payload must be a map")
    return doc
