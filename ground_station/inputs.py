"""Bus payload -> validated telemetry record, or ValueError (pure; the subscriber counts drops).

The codecs of `comms_sim.bus`, `fleet_agent.telemetry` and `comms_sim.link_event` check shape;
this layer also checks values (finite numbers, integer task ids, the sender named by the key)
because one NaN or a string where a number belongs must cost one dropped sample, never a
crashed dashboard.
"""

from __future__ import annotations

import math
from typing import Any, Union

from comms_sim import bus
from comms_sim.link_event import LinkEvent
from fleet_agent.telemetry import Event, Status

Record = Union[bus.Truth, Status, Event, LinkEvent]
KINDS = ("truth", "status", "event", "link")


def kind_of(key: str) -> str:
    """``fleet/<kind>/...`` -> kind, or ValueError for keys the ground station does not read."""
    parts = key.split("/")
    if len(parts) < 3 or parts[0] != bus.PREFIX or parts[1] not in KINDS:
        raise ValueError(f"not a telemetry key: {key!r}")
    if parts[1] == "link" and len(parts) != 4:
        raise ValueError(f"link keys are fleet/link/<src>/<dst>: {key!r}")
    return parts[1]


def _num(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{what}: expected a number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"{what}: must be finite, got {value!r}")
    return number


def _ids(value: Any, what: str) -> list[int]:
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"{what}: expected a list of task ids")
    for v in value:
        if isinstance(v, bool) or not isinstance(v, int):
            raise ValueError(f"{what}: task ids are integers, got {v!r}")
    return list(value)


def _pos(value: Any, what: str) -> tuple[float, float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ValueError(f"{what}: expected [x, y, z]")
    return (_num(value[0], what), _num(value[1], what), _num(value[2], what))


def _str_map(value: Any, what: str, value_type: type) -> dict:
    if not isinstance(value, dict) or not all(
        isinstance(k, str) and isinstance(v, value_type) and not isinstance(v, bool)
        for k, v in value.items()
    ):
        raise ValueError(f"{what}: expected a map of str -> {value_type.__name__}")
    return dict(value)


def _same_sender(key_vid: str, claimed: str) -> None:
    if claimed != key_vid:
        raise ValueError(f"payload says it is from {claimed!r}, the key says {key_vid!r}")


def check_status(s: Status, key_vid: str) -> Status:
    _same_sender(key_vid, s.id)
    if not isinstance(s.state, str):
        raise ValueError("status.state must be a string")
    return Status(
        t_s=_num(s.t_s, "status.t_s"), id=s.id, state=s.state, pos=_pos(s.pos, "status.pos"),
        battery_s=_num(s.battery_s, "status.battery_s"),
        t_diff_s=_num(s.t_diff_s, "status.t_diff_s"),
        route=_ids(s.route, "status.route"), treated=_ids(s.treated, "status.treated"),
        cleared_known=int(_num(s.cleared_known, "status.cleared_known")),
        priority_collected=_num(s.priority_collected, "status.priority_collected"),
        distance_m=_num(s.distance_m, "status.distance_m"),
        peers=_str_map(s.peers, "status.peers", str), claims=_ids(s.claims, "status.claims"),
        counters=_str_map(s.counters, "status.counters", int),
    )


def check_event(e: Event, key_vid: str) -> Event:
    _same_sender(key_vid, e.id)
    if not all(isinstance(v, str) for v in (e.kind, e.peer, e.detail)):
        raise ValueError("event kind, peer and detail are strings")
    return Event(_num(e.t_s, "event.t_s"), e.id, e.kind, _ids(e.tasks, "event.tasks"),
                 e.peer, e.detail)


def check_truth(t: bus.Truth) -> bus.Truth:
    return bus.Truth(_num(t.t_s, "truth.t_s"), _pos(t.pos, "truth.pos"),
                     _num(t.yaw_deg, "truth.yaw_deg"), _num(t.pitch_deg, "truth.pitch_deg"),
                     t.state)


def check_link(e: LinkEvent, key: str) -> LinkEvent:
    src, dst = key.split("/")[2:4]
    if (e.src, e.dst) != (src, dst):
        raise ValueError(f"link event {e.src}->{e.dst} published on {key!r}")
    _num(e.t_s, "link.t_s")
    _num(e.t_sent_s, "link.t_sent_s")
    if e.nbytes < 0:
        raise ValueError("link.nbytes must be >= 0")
    return e


def decode(key: str, payload: bytes) -> tuple[str, Record]:
    """``(vehicle id or link src, record)`` for one sample; raises ValueError if malformed."""
    kind = kind_of(key)
    vid = key.split("/")[2]
    if kind == "truth":
        return vid, check_truth(bus.Truth.decode(payload))
    if kind == "status":
        return vid, check_status(Status.decode(payload), vid)
    if kind == "event":
        return vid, check_event(Event.decode(payload), vid)
    return vid, check_link(LinkEvent.decode(payload), key)
