"""Each topic of the bus: the same keys and bytes as the records' own encodings, a round trip,
and garbage refused with a `TopicError` naming the key."""

from __future__ import annotations

from typing import Any

import msgpack
import pytest

from fleet_bus import keys, topics
from fleet_bus.commands import ABORT, STOP, encode_command
from fleet_bus.link import LinkControl, LinkRecord, Partition, encode_stats
from fleet_bus.mission import Mission
from fleet_bus.orders import Answer
from fleet_bus.states import EventKind, VehicleState
from fleet_bus.telemetry import Event, Ready, Status, Truth, encode_busy
from fleet_bus.topics import Topic, TopicError

STATUS = Status(12.5, "auv1", VehicleState.TRANSIT, (1.0, 2.0, -3.0), 3000.0, 120.0, [4, 5],
                [3], 3, 55.0, 800.0, {"auv2": "alive"}, [5], {"sent": 4}, 0.5, {"auv3": 1})
EVENT = Event(30.0, "auv1", EventKind.CLAIM, [4, 5], "auv2", "takeover")
TRUTH = Truth(5.0, (1.0, 2.0, -3.0), 90.0, 0.0, VehicleState.INJECTING)
LINK = LinkRecord("auv1", "auv2", 1.0, 1.5, 32, False, "loss", 7.5)
ANSWER = Answer("ref1", 3, "abort auv1", ("auv1",), 40.0, {"auv1": 44.0}, {}, "")
MISSION = Mission({"name": "tiny", "vehicles": []}, 7, "run-1")
CONTROL = LinkControl(partition=Partition(10.0, 20.0, (frozenset({"auv1"}),)), extra_loss=0.5)

# (topic, a record, the bytes the record's own encoder puts on the wire today, the key)
CASES: list[tuple[Topic[Any], Any, bytes, str]] = [
    (topics.TRUTH.of("auv1"), TRUTH, TRUTH.encode(), keys.truth_key("auv1")),
    (topics.STATUS.of("auv1"), STATUS, STATUS.encode(), keys.status_key("auv1")),
    (topics.EVENT.of("auv1"), EVENT, EVENT.encode(), keys.event_key("auv1")),
    (topics.ALIVE.of("auv1"), Ready("auv1", "run-1"),
     msgpack.packb({"id": "auv1", "run_id": "run-1"}), keys.alive_key("auv1")),
    (topics.BUSY.of("auv1"), True, encode_busy(True), keys.busy_key("auv1")),
    (topics.CTL.of("auv1"), ABORT, encode_command(ABORT), keys.ctl_key("auv1")),
    (topics.CTL.of("auv1"), STOP, msgpack.packb({"cmd": "stop"}), keys.ctl_key("auv1")),
    (topics.TX.of("auv1"), b"\x01frame", b"\x01frame", keys.tx_key("auv1")),
    (topics.RX.of("auv2"), b"\x01frame", b"\x01frame", keys.rx_key("auv2")),
    (topics.LINK.of("auv1", "auv2"), LINK, LINK.encode(), keys.link_event_key("auv1", "auv2")),
    (topics.MISSION, MISSION, MISSION.encode(), keys.MISSION),
    (topics.ORDER_ANSWER, ANSWER, ANSWER.encode(), keys.ORDER_ANSWER),
    (topics.LINK_STATS, ({("auv1", "auv2"): {"delivered": 3}}, {"t_s": 5.0}),
     encode_stats({("auv1", "auv2"): {"delivered": 3}}, {"t_s": 5.0}), keys.LINK_STATS),
]
GARBAGE = [b"", b"\xc1", b"\x80", msgpack.packb([1, 2, 3]), b"\xff" * 40]


@pytest.mark.parametrize("topic, record, wire, key", CASES, ids=lambda c: getattr(c, "key", ""))
def test_a_topic_puts_the_records_own_bytes_under_its_old_key_and_reads_them_back(
        topic: Topic[Any], record: Any, wire: bytes, key: str) -> None:
    assert topic.key == key
    assert topic.encode(record) == wire
    assert topic.decode(wire) == record


@pytest.mark.parametrize("topic", [c[0] for c in CASES if c[0].codec is not topics.FRAME],
                         ids=lambda t: t.key)
@pytest.mark.parametrize("garbage", GARBAGE)
def test_garbage_is_a_topic_error_naming_the_key(topic: Topic[Any], garbage: bytes) -> None:
    with pytest.raises(TopicError, match=topic.key) as caught:
        topic.decode(garbage)
    assert isinstance(caught.value, ValueError)  # what every receiver already counts


def test_frames_are_opaque_here_the_wire_codec_judges_them() -> None:
    for garbage in GARBAGE:
        assert topics.RX.of("auv1").decode(garbage) == garbage


def test_the_link_control_topic_decodes_relative_times_at_the_receivers_time() -> None:
    assert topics.LINK_CTL.key == keys.LINK_CTL
    assert topics.LINK_CTL.encode(CONTROL) == CONTROL.encode()
    assert topics.LINK_CTL.decode(CONTROL.encode(), now_s=0.0) == CONTROL
    relative = msgpack.packb({"partition": {"duration_s": 30, "groups": [["auv1"]]}})
    control = topics.LINK_CTL.decode(relative, now_s=100.0)
    assert control.partition is not None
    assert (control.partition.start_s, control.partition.end_s) == (100.0, 130.0)
    with pytest.raises(TopicError, match=keys.LINK_CTL):
        topics.LINK_CTL.decode(b"\xc1", now_s=0.0)


def test_a_family_subscribes_with_its_wildcard_and_names_the_sender_of_a_sample() -> None:
    assert topics.STATUS.all.key == keys.STATUS_ALL
    assert topics.TX.all.key == keys.TX_ALL and topics.LINK.all.key == keys.LINK_ALL
    assert topics.STATUS.decode_at("fleet/status/auv1", STATUS.encode()) == ("auv1", STATUS)
    for key in ("fleet/event/auv1", "fleet/status", "other/status/auv1", "fleet/status/a/b"):
        with pytest.raises(TopicError):
            topics.STATUS.vid_of(key)


def test_a_link_record_must_be_its_keys() -> None:
    assert topics.LINK.decode_at("fleet/link/auv1/auv2", LINK.encode()) == LINK
    with pytest.raises(TopicError, match="auv1->auv2"):
        topics.LINK.decode_at("fleet/link/auv2/auv1", LINK.encode())
    with pytest.raises(TopicError):
        topics.LINK.decode_at("fleet/link/auv1", LINK.encode())
