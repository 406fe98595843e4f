"""The link's bus messages: link control (decoding, applying, refusing garbage), link records
and link stats."""

from __future__ import annotations

import msgpack
import numpy as np
import pytest

from comms_sim.channel import Channel, ChannelConfig
from comms_sim.control import apply_control
from fleet_bus.link import (LinkControl, LinkRecord, Partition, TxTag, decode_stats,
                            encode_stats)


def test_round_trip_and_apply() -> None:
    cmd = LinkControl(extra_loss=0.4, partition=Partition(1.0, 9.0, (("a",),)),
                      clear_partitions=True)
    assert LinkControl.decode(cmd.encode(), now_s=0.0) == cmd
    ch = Channel(ChannelConfig(partitions=(Partition(0.0, 5.0, (("z",),)),)),
                 np.random.default_rng(0))
    apply_control(cmd, ch)
    assert ch.extra_loss == 0.4 and ch.partitions == (cmd.partition,)


def test_relative_partition_starts_now() -> None:
    payload = msgpack.packb({"partition": {"duration_s": 60, "groups": [["a", "b"], ["c"]]}})
    cmd = LinkControl.decode(payload, now_s=120.0)
    assert cmd.partition == Partition(120.0, 180.0, (("a", "b"), ("c",)))
    assert cmd.extra_loss is None and not cmd.clear_partitions


@pytest.mark.parametrize("payload", [
    b"", b"\xc1\xc1", msgpack.packb([1, 2]), msgpack.packb({}), msgpack.packb({"loss": 0.1}),
    msgpack.packb({"extra_loss": 2.0}), msgpack.packb({"extra_loss": "lots"}),
    msgpack.packb({"partition": {"groups": [["a"]]}}), msgpack.packb({"partition": 3}),
    msgpack.packb({"extra_loss": float("nan")}),
])
def test_garbage_is_refused(payload: bytes) -> None:
    with pytest.raises(ValueError):
        LinkControl.decode(payload, now_s=0.0)


def test_injected_frames_need_a_place_and_round_trip() -> None:
    cmd = LinkControl(inject=b"\x01\x02hostile", inject_at=(10.0, 20.0, 0.0))
    assert LinkControl.decode(cmd.encode(), now_s=0.0) == cmd
    with pytest.raises(ValueError):
        LinkControl(inject=b"x")
    with pytest.raises(ValueError):
        LinkControl.decode(msgpack.packb({"inject": "text", "inject_at": [0, 0, 0]}), 0.0)
    top = LinkControl(inject=b"order", inject_at=(1.0, 2.0, 0.0), inject_from="topside")
    assert LinkControl.decode(top.encode(), now_s=0.0) == top
    for source in ("auv1", 3):  # only the intruder's modem and the operator's transmit
        with pytest.raises(ValueError):
            LinkControl.decode(msgpack.packb({"inject": b"x", "inject_at": [0, 0, 0],
                                              "inject_from": source}), 0.0)


def test_link_records_carry_no_frame_and_validate_values() -> None:
    rec = LinkRecord("a", "b", 1.0, 1.5, 24, False, "range", snr_db=3.5)
    assert LinkRecord.decode(rec.encode()) == rec
    assert b"frame" not in rec.encode()
    for bad in ({"src": "a", "dst": "b", "t_sent_s": float("nan"), "t_s": 1.0, "nbytes": 1,
                 "delivered": True, "reason": None},
                {"src": "a", "dst": "b", "t_sent_s": 1.0, "t_s": 1.0, "nbytes": -1,
                 "delivered": True, "reason": None},
                {"src": "a", "dst": "b", "t_sent_s": 1.0, "t_s": 1.0, "nbytes": 1,
                 "delivered": True, "reason": "range"}):
        with pytest.raises(ValueError):
            LinkRecord.decode(msgpack.packb(bad))


def test_stats_round_trip_and_refuse_garbage() -> None:
    counts = {("a", "b"): {"sent": 3, "delivered": 2, "range": 1}}
    assert decode_stats(encode_stats(counts, {"t_s": 5.0})) == (counts, {"t_s": 5.0})
    for bad in (b"", msgpack.packb({"links": 3}), msgpack.packb({"links": [{"src": "a"}]}),
                msgpack.packb({"links": [{"src": "a", "dst": "b", "sent": -1}]})):
        with pytest.raises(ValueError):
            decode_stats(bad)


@pytest.mark.parametrize("tag", [TxTag(), TxTag("pose"), TxTag("data", 1234.5),
                                 TxTag("pose", 0.0)])
def test_tx_tag_round_trips(tag: TxTag) -> None:
    assert TxTag.decode(tag.encode()) == tag


@pytest.mark.parametrize("raw", [None, b"", b"\xff\xfe", b"pose@nan", b"pose@inf",
                                 b"pose@soon", b"@", b"x" * 500])
def test_a_malformed_tx_tag_is_a_frame_sent_now(raw: bytes | None) -> None:
    tag = TxTag.decode(raw)
    assert tag.sent_s is None and 0 < len(tag.kind) <= 16
