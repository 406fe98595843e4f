"""The water's TDMA MAC on the fleet's spatial schedule: a frame starts only inside its
sender's slot of the schedule the agents compute (`fleet_bus.tdma.SpatialSchedule`), so the
water and the agents agree on every slot; a node outside the roster is not held to it."""

from __future__ import annotations

import numpy as np
import pytest

from comms_sim.channel import Channel, ChannelConfig
from comms_sim.config import TdmaConfig
from fleet_bus.tdma import SpatialSchedule, Track

SLOT_S = 2.5


def schedule() -> SpatialSchedule:
    # Two pairs 10 km apart share slots: a 2-slot cycle for 4 vehicles.
    xy = [(0, 0), (800, 0), (10_000, 0), (10_800, 0)]
    return SpatialSchedule([Track(np.array([0.0]), np.array([p]), 1e9) for p in xy], SLOT_S,
                           reuse_m=3500.0)


def test_frames_start_in_their_senders_slots_of_the_spatial_schedule() -> None:
    s = schedule()
    names = ("a", "b", "c", "d")
    config = ChannelConfig(tdma=TdmaConfig(slot_s=SLOT_S, order=names, guard_s=1.0))
    ch = Channel(config, np.random.default_rng(1), s)
    for i, (name, pos) in enumerate(zip(names, [(0, 0, 0), (800, 0, 0), (10_000, 0, 0),
                                                (10_800, 0, 0)])):
        ch.set_position(name, pos, 0.0)
    rng = np.random.default_rng(2)
    for t in sorted(rng.uniform(0.0, 60.0, 24)):
        ch.submit(names[int(rng.integers(4))], bytes(40), float(t))
    events = ch.advance(200.0)
    starts = {(e.src, e.t_sent_s) for e in events}
    assert len(starts) == 24
    for src, t in starts:
        v = names.index(src)
        opened = s.latest(v, t + 1e-9)
        assert opened is not None and t + config.airtime_s(40) <= opened + SLOT_S - 1.0 + 1e-9
    # The shared slots really are shared: some frames of a and c (same slot) start together.
    assert s.epoch(0.0).slot[0] == s.epoch(0.0).slot[2]


def test_a_node_outside_the_roster_is_not_held_to_the_schedule() -> None:
    config = ChannelConfig(tdma=TdmaConfig(slot_s=SLOT_S, order=("a", "b", "c", "d"),
                                           guard_s=1.0))
    ch = Channel(config, np.random.default_rng(1), schedule())
    for name in ("a", "x"):
        ch.set_position(name, (0.0, 0.0, 0.0), 0.0)
    ch.submit("x", bytes(40), 1.234)
    assert {e.t_sent_s for e in ch.advance(10.0) if e.src == "x"} == {1.234}


def test_a_schedule_that_does_not_fit_the_mac_is_refused() -> None:
    with pytest.raises(ValueError):
        Channel(ChannelConfig(), np.random.default_rng(1), schedule())  # no TDMA MAC
    config = ChannelConfig(tdma=TdmaConfig(slot_s=3.0, order=("a", "b", "c", "d"),
                                           guard_s=1.0))
    with pytest.raises(ValueError):
        Channel(config, np.random.default_rng(1), schedule())  # another slot length
