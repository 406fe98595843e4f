"""Bus payload -> validated telemetry record, or ValueError (pure; the station counts drops).

The decoders of `fleet_bus` check shape and values (finite numbers, integer task ids, short
strings); this layer adds what only the key can tell: the sender named in a status or event
is the one whose key it came on, and a link record matches its link's key.
"""

from __future__ import annotations

from typing import Union

from fleet_bus import keys
from fleet_bus.link import LinkRecord
from fleet_bus.telemetry import Event, Status, Truth

Record = Union[Truth, Status, Event, LinkRecord]
KINDS = ("truth", "status", "event", "link")


def kind_of(key: str) -> str:
    """``fleet/<kind>/...`` -> kind, or ValueError for keys the ground station does not read."""
    kind = keys.kind_of(key)
    if kind not in KINDS:
        raise ValueError(f"not a telemetry key: {key!r}")
    return kind


def _same_sender(key_vid: str, claimed: str) -> None:
    if claimed != key_vid:
        raise ValueError(f"payload says it is from {claimed!r}, the key says {key_vid!r}")


def decode(key: str, payload: bytes) -> tuple[str, Record]:
    """``(vehicle id or link src, record)`` for one sample; raises ValueError if malformed."""
    kind = kind_of(key)
    vid = key.split("/")[2]
    if kind == "truth":
        return vid, Truth.decode(payload)
    if kind == "status":
        status = Status.decode(payload)
        _same_sender(vid, status.id)
        return vid, status
    if kind == "event":
        event = Event.decode(payload)
        _same_sender(vid, event.id)
        return vid, event
    record = LinkRecord.decode(payload)
    if (record.src, record.dst) != keys.link_ends(key):
        raise ValueError(f"link record {record.src}->{record.dst} published on {key!r}")
    return vid, record
