"""The fleet/ctl/link payload: decoding, applying, refusing garbage."""

from __future__ import annotations

import msgpack
import numpy as np
import pytest

from comms_sim.channel import Channel, ChannelConfig, Partition
from comms_sim.control import LinkControl


def test_round_trip_and_apply() -> None:
    cmd = LinkControl(extra_loss=0.4, partition=Partition(1.0, 9.0, (("a",),)),
                      clear_partitions=True)
    assert LinkControl.decode(cmd.encode(), now_s=0.0) == cmd
    ch = Channel(ChannelConfig(partitions=(Partition(0.0, 5.0, (("z",),)),)),
                 np.random.default_rng(0))
    cmd.apply(ch)
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
