"""Bus payload -> validated telemetry record, or ValueError (pure; the station counts drops).

The topics of `fleet_bus.topics` check shape and values (finite numbers, integer task ids,
short strings) and that a link record matches its link's key; this layer adds the sender: the
vehicle named in a status or event is the one whose key it came on.
"""

from __future__ import annotations

from typing import Union

from fleet_bus import keys, topics
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
    """``(vehicle id or link src, record)`` for one sample; raises ValueError if malformed
    (a `fleet_bus.topics.TopicError`, or a sender that is not its key's)."""
    kind = kind_of(key)
    if kind == "truth":
        return topics.TRUTH.decode_at(key, payload)
    if kind == "status":
        vid, status = topics.STATUS.decode_at(key, payload)
        _same_sender(vid, status.id)
        return vid, status
    if kind == "event":
        vid, event = topics.EVENT.decode_at(key, payload)
        _same_sender(vid, event.id)
        return vid, event
    record = topics.LINK.decode_at(key, payload)
    return record.src, record
