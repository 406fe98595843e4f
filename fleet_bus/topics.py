"""The fleet bus's topics: each key expression bound to the one record type that travels on it.

A `Topic[T]` is a key and the codec of ``T``: a sender can only put a ``T`` on it
(`Topic.encode`, `Topic.seal`, `Publisher.put`; mypy holds it), a receiver gets a ``T`` back
or a `TopicError` (`Topic.decode`), a `ValueError` naming the key and what was wrong, which
every receiver drops and counts where it counted a malformed payload before (the relay's
``malformed_<kind>``, the operator's ``invalid``, the agent's ``ctl_malformed``, the ground
station's ``malformed``). Per-vehicle keys (``fleet/<kind>/<id>``) come as `VehicleTopics`, a
family with one topic per vehicle, and the links' (``fleet/link/<src>/<dst>``) as
`LinkTopics`.

The bytes are the records' own encodings (`fleet_bus.telemetry`, `fleet_bus.link`,
`fleet_bus.commands`, `fleet_bus.mission`, `fleet_bus.orders`): a topic adds none of its
own (docs/architecture.md, "Topics"). Frames (``fleet/tx``, ``fleet/rx``) are opaque bytes
here: the wire codec of the agents (`fleet_agent.wire`) judges them and counts what it drops.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Generic, TypeVar

import zenoh

from fleet_bus import keys
from fleet_bus.auth import BusAuth, seal
from fleet_bus.commands import Command, decode_command, encode_command
from fleet_bus.link import LinkControl, LinkCounts, LinkRecord, decode_stats, encode_stats
from fleet_bus.mission import Mission
from fleet_bus.orders import Answer
from fleet_bus.telemetry import Event, Ready, Status, Truth, decode_busy, encode_busy

T = TypeVar("T")


class TopicError(ValueError):
    """A payload that is not its topic's record (or a key outside the topic's family)."""

    def __init__(self, key: str, what: str, reason: str) -> None:
        super().__init__(f"{key}: not a {what}: {reason}")
        self.key, self.what = key, what


@dataclass(frozen=True)
class Codec(Generic[T]):
    """How a ``T`` becomes bytes and back; ``decode`` raises ValueError on anything that is
    not a well-formed ``T``."""

    what: str  # the record's name, for errors
    encode: Callable[[T], bytes]
    decode: Callable[[bytes], T]


@dataclass(frozen=True)
class Topic(Generic[T]):
    """A key expression (one key, or a wildcard to subscribe with) and its record type."""

    key: str
    codec: Codec[T]

    def encode(self, record: T) -> bytes:
        return self.codec.encode(record)

    def decode(self, payload: bytes) -> T:
        """The record, or `TopicError`."""
        try:
            return self.codec.decode(payload)
        except ValueError as exc:
            raise TopicError(self.key, self.codec.what, str(exc)) from None

    def seal(self, auth: BusAuth | None, record: T) -> bytes:
        """``record`` encoded and sealed for this key (as is on an open bus)."""
        return seal(auth, self.key, self.encode(record))

    def put(self, session: zenoh.Session, auth: BusAuth | None, record: T) -> None:
        """One sealed put (a publisher is cheaper for a key put often: `Publisher`)."""
        session.put(self.key, self.seal(auth, record))


class Publisher(Generic[T]):
    """A declared Zenoh publisher that puts only its topic's records, sealed with ``auth``."""

    def __init__(self, session: zenoh.Session, topic: Topic[T], auth: BusAuth | None) -> None:
        self.topic, self._auth = topic, auth
        self._publisher = session.declare_publisher(topic.key)

    def put(self, record: T, attachment: bytes | None = None) -> None:
        self._publisher.put(self.topic.seal(self._auth, record), attachment=attachment)

    def undeclare(self) -> None:
        self._publisher.undeclare()


@dataclass(frozen=True)
class VehicleTopics(Generic[T]):
    """``fleet/<kind>/<vehicle id>``: one topic per vehicle, all of one record type."""

    kind: str
    codec: Codec[T]

    def of(self, vid: str) -> Topic[T]:
        return Topic(keys.vehicle_key(self.kind, vid), self.codec)

    @property
    def all(self) -> Topic[T]:
        """Every vehicle's topic of this kind (``fleet/<kind>/*``), to subscribe with."""
        return Topic(keys.all_vehicles(self.kind), self.codec)

    def vid_of(self, key: str) -> str:
        """The vehicle a key of this family names; `TopicError` for another key."""
        try:
            kind = keys.kind_of(key)
        except ValueError as exc:
            raise TopicError(key, self.codec.what, str(exc)) from None
        if kind != self.kind or len(key.split("/")) != 3:
            raise TopicError(key, self.codec.what, f"not a {keys.PREFIX}/{self.kind}/<id> key")
        return keys.vid_of(key)

    def decode_at(self, key: str, payload: bytes) -> tuple[str, T]:
        """(vehicle id, record) of a sample on ``key``; `TopicError` if either is wrong."""
        vid = self.vid_of(key)
        return vid, self.of(vid).decode(payload)


@dataclass(frozen=True)
class LinkTopics:
    """``fleet/link/<src>/<dst>``: the fate of each frame on each link (`LinkRecord`)."""

    codec: Codec[LinkRecord]

    def of(self, src: str, dst: str) -> Topic[LinkRecord]:
        return Topic(keys.link_event_key(src, dst), self.codec)

    @property
    def all(self) -> Topic[LinkRecord]:
        return Topic(keys.LINK_ALL, self.codec)

    def decode_at(self, key: str, payload: bytes) -> LinkRecord:
        """The record of a sample on ``key``; `TopicError` if it is malformed or is not the
        record of the key's link."""
        try:
            src, dst = keys.link_ends(key)
        except ValueError as exc:
            raise TopicError(key, self.codec.what, str(exc)) from None
        record = self.of(src, dst).decode(payload)
        if (record.src, record.dst) != (src, dst):
            raise TopicError(key, self.codec.what,
                             f"the record of link {record.src}->{record.dst}")
        return record


@dataclass(frozen=True)
class TimedTopic(Generic[T]):
    """A topic whose records may carry times relative to their arrival (a partition "for
    300 s from now"): the receiver decodes at its own time ``now_s``."""

    key: str
    what: str
    encoder: Callable[[T], bytes]
    decoder: Callable[[bytes, float], T]

    def encode(self, record: T) -> bytes:
        return self.encoder(record)

    def decode(self, payload: bytes, now_s: float) -> T:
        try:
            return self.decoder(payload, now_s)
        except ValueError as exc:
            raise TopicError(self.key, self.what, str(exc)) from None

    def seal(self, auth: BusAuth | None, record: T) -> bytes:
        return seal(auth, self.key, self.encode(record))

    def put(self, session: zenoh.Session, auth: BusAuth | None, record: T) -> None:
        session.put(self.key, self.seal(auth, record))


def _frame(payload: bytes) -> bytes:
    return bytes(payload)


LinkStats = tuple[LinkCounts, dict[str, Any]]  # the relay's counters, and its other figures

# -- radio traffic: frames only the relay (the water) moves ----------------------------------
FRAME = Codec[bytes]("frame", _frame, _frame)
TX = VehicleTopics("tx", FRAME)  # a vehicle's frames into the water
RX = VehicleTopics("rx", FRAME)  # what the water delivers to a vehicle (signed by the relay)

# -- telemetry: not a radio (`fleet_bus.telemetry`) --------------------------------------------
TRUTH = VehicleTopics("truth", Codec("truth", Truth.encode, Truth.decode))
STATUS = VehicleTopics("status", Codec("status", Status.encode, Status.decode))
EVENT = VehicleTopics("event", Codec("event", Event.encode, Event.decode))
ALIVE = VehicleTopics("alive", Codec("ready announcement", Ready.encode, Ready.decode))
BUSY = VehicleTopics("busy", Codec("busy flag", encode_busy, decode_busy))

# -- the operator's -----------------------------------------------------------------------------
CTL = VehicleTopics("ctl", Codec[Command]("command", encode_command, decode_command))
MISSION = Topic(keys.MISSION, Codec("mission record", Mission.encode, Mission.decode))
ORDER_ANSWER = Topic(keys.ORDER_ANSWER, Codec("order answer", Answer.encode, Answer.decode))
LINK_CTL = TimedTopic(keys.LINK_CTL, "link control", LinkControl.encode, LinkControl.decode)

# -- the water's --------------------------------------------------------------------------------
LINK = LinkTopics(Codec("link record", LinkRecord.encode, LinkRecord.decode))
LINK_STATS = Topic(keys.LINK_STATS, Codec[LinkStats](
    "link stats", lambda stats: encode_stats(*stats), decode_stats))
