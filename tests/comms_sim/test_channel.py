"""The channel model: delay, airtime, loss curve, half-duplex, collisions, refusals, faults.

Mechanics shared by both models are tested on the empirical model with a curve so flat that
nothing is lost to it (`LOSSLESS`); the physics of the default model is in
test_channel_physics.py."""

from __future__ import annotations

import math
from dataclasses import replace

import msgpack
import numpy as np
import pytest

from comms_sim.channel import Channel, ChannelConfig, LinkEvent, Partition, TdmaConfig
from comms_sim.stats import totals, totals_by_sender

# Range curve so flat that nothing within a few km is lost to it: isolates other effects.
LOSSLESS = ChannelConfig(model="empirical", range_d50_m=1e7, max_range_m=5000.0)
EMPIRICAL = ChannelConfig(model="empirical")  # the project's earlier default channel


def channel(config: ChannelConfig = LOSSLESS, seed: int = 7, **positions) -> Channel:
    ch = Channel(config, np.random.default_rng(seed))
    for node, x in positions.items():
        ch.set_position(node, (x, 0.0, 0.0), 0.0)
    return ch


def run(ch: Channel, until_s: float = 1e9) -> list[LinkEvent]:
    events = []
    while (due := ch.next_due_s()) is not None and due <= until_s:
        events += ch.advance(due)
    return events


def outcome(events: list[LinkEvent], src: str, dst: str) -> list[str | None]:
    return [e.reason for e in events if e.src == src and e.dst == dst]


def test_delivery_time_is_propagation_delay_plus_airtime() -> None:
    ch = channel(a=0.0, b=1200.0)
    ch.submit("a", b"x" * 40, 5.0)
    [event] = run(ch)
    airtime = 0.3 + 40 * 8 / 1000.0
    assert event.delivered and event.reason is None
    assert event.t_sent_s == 5.0
    assert event.t_s == pytest.approx(5.0 + 1200.0 / 1500.0 + airtime, abs=1e-12)
    assert event.frame == b"x" * 40 and event.nbytes == 40


def test_airtime_of_presets() -> None:
    from comms_sim.config import PRESETS

    assert PRESETS["micromodem_rate0"].airtime_s(32) == pytest.approx(0.5 + 3.2)
    assert PRESETS["micromodem_rate0"].max_frame_bytes == 32
    assert PRESETS["psk_1k"].airtime_s(64) == pytest.approx(0.3 + 0.512)


def test_frames_queue_behind_the_transmitter() -> None:
    ch = channel(a=0.0, b=150.0)
    ch.submit("a", b"1" * 20, 0.0)
    ch.submit("a", b"2" * 20, 0.1)  # the modem is still busy with the first frame
    events = run(ch)
    airtime = 0.3 + 0.16
    assert [e.frame[:1] for e in events] == [b"1", b"2"]
    assert events[1].t_sent_s == pytest.approx(airtime)
    assert events[1].t_s == pytest.approx(2 * airtime + 0.1)
    assert all(e.delivered for e in events)


@pytest.mark.parametrize("model", ["empirical", "physical"])
@pytest.mark.parametrize("range_m", [0.0, 800.0, 1500.0, 2000.0, 2600.0])
def test_loss_curve_matches_model(range_m: float, model: str) -> None:
    """4000 frames at one range; delivered fraction within 4 binomial sigmas (<= 0.032)."""
    config = ChannelConfig(model=model)
    ch = channel(config, seed=11, a=0.0, b=range_m)
    n = 4000
    for i in range(n):
        ch.submit("a", b"p" * 16, i * 10.0)  # far apart: no queueing, no collisions
    delivered = sum(e.delivered for e in run(ch))
    p = config.delivery_probability(range_m, 16)
    tolerance = 4 * math.sqrt(p * (1 - p) / n) + 1e-9
    assert abs(delivered / n - p) <= tolerance
    assert EMPIRICAL.delivery_probability(1500.0) == pytest.approx(0.80, abs=0.01)


def test_dune_preset_is_dunes_gaussian() -> None:
    from comms_sim.config import PRESETS

    dune = PRESETS["dune_sim"]
    for d in (0.0, 500.0, 750.0, 1500.0, 2999.0):
        assert dune.delivery_probability(d) == pytest.approx(math.exp(-d**2 / (2 * 750.0**2)))
    assert dune.delivery_probability(3001.0) == 0.0


def test_nothing_is_heard_beyond_max_range() -> None:
    ch = channel(ChannelConfig(range_d50_m=1e7, max_range_m=3000.0), a=0.0, b=3000.5)
    for i in range(50):
        ch.submit("a", b"z", i * 10.0)
    assert set(outcome(run(ch), "a", "b")) == {"range"}


def test_unknown_position_counts_as_out_of_range() -> None:
    ch = channel(a=0.0)
    ch.add_node("ghost")
    ch.submit("a", b"z", 0.0)
    assert outcome(run(ch), "a", "ghost") == ["range"]


def test_extra_loss_rate_and_reason() -> None:
    """p = 0.25 over 4000 frames: observed within 4 sigmas (0.027)."""
    ch = channel(replace(LOSSLESS, extra_loss=0.25), seed=3, a=0.0, b=100.0)
    for i in range(4000):
        ch.submit("a", b"q", i * 5.0)
    reasons = outcome(run(ch), "a", "b")
    assert set(reasons) == {None, "random"}
    assert abs(reasons.count("random") / 4000 - 0.25) <= 4 * math.sqrt(0.25 * 0.75 / 4000)


def test_set_extra_loss_applies_to_frames_transmitted_afterwards() -> None:
    ch = channel(a=0.0, b=100.0)
    ch.submit("a", b"1", 0.0)
    events = ch.advance(5.0)  # the first frame went on the air (and arrived) at no loss
    ch.set_extra_loss(1.0)
    ch.submit("a", b"2", 10.0)
    events += run(ch)
    assert outcome(events, "a", "b") == [None, "random"]
    with pytest.raises(ValueError):
        ch.set_extra_loss(1.5)


def test_half_duplex_receiver_transmitting_loses_the_frame() -> None:
    ch = channel(a=0.0, b=1500.0)  # 1 s propagation
    ch.submit("a", b"a" * 30, 0.0)  # reaches b during [1.0, 1.54)
    ch.submit("b", b"b" * 30, 1.2)  # b transmits during [1.2, 1.74): deaf meanwhile
    events = run(ch)
    assert outcome(events, "a", "b") == ["half_duplex"]
    assert outcome(events, "b", "a") == [None]  # a is silent when b's frame arrives


def test_half_duplex_only_while_overlapping() -> None:
    ch = channel(a=0.0, b=1500.0)
    ch.submit("a", b"a" * 30, 0.0)  # at b during [1.0, 1.54)
    ch.submit("b", b"b" * 30, 1.54)  # starts exactly when the reception ends
    assert outcome(run(ch), "a", "b") == [None]


def test_half_duplex_can_be_disabled() -> None:
    ch = channel(replace(LOSSLESS, half_duplex=False), a=0.0, b=1500.0)
    ch.submit("a", b"a" * 30, 0.0)
    ch.submit("b", b"b" * 30, 1.2)
    assert outcome(run(ch), "a", "b") == [None]


def test_overlapping_receptions_collide_and_both_are_lost() -> None:
    ch = channel(a=0.0, b=1000.0, c=2000.0)  # b in the middle, 1000 m from each
    ch.submit("a", b"a" * 30, 0.0)  # at b during [0.667, 1.207)
    ch.submit("c", b"c" * 30, 0.3)  # at b during [0.967, 1.507)
    events = run(ch)
    assert outcome(events, "a", "b") == ["collision"]
    assert outcome(events, "c", "b") == ["collision"]
    # a and c are 2000 m apart: c's frame arrives at a after a finished sending
    assert outcome(events, "c", "a") == [None]


def test_separated_receptions_do_not_collide() -> None:
    ch = channel(a=0.0, b=1000.0, c=2000.0)
    ch.submit("a", b"a" * 30, 0.0)  # at b during [0.667, 1.207)
    ch.submit("c", b"c" * 30, 0.6)  # at b from 1.267
    events = run(ch)
    assert outcome(events, "a", "b") == [None] and outcome(events, "c", "b") == [None]


def test_an_inaudible_frame_does_not_collide() -> None:
    config = replace(LOSSLESS, max_range_m=1500.0)
    ch = channel(config, a=0.0, b=1000.0, c=2600.0)  # c is 1600 m from b: not heard there
    ch.submit("a", b"a" * 30, 0.0)
    ch.submit("c", b"c" * 30, 0.0)
    events = run(ch)
    assert outcome(events, "a", "b") == [None]
    assert outcome(events, "c", "b") == ["range"]


def test_collisions_can_be_disabled() -> None:
    ch = channel(replace(LOSSLESS, collisions=False), a=0.0, b=1000.0, c=2000.0)
    ch.submit("a", b"a" * 30, 0.0)
    ch.submit("c", b"c" * 30, 0.3)
    events = run(ch)
    assert outcome(events, "a", "b") == [None] and outcome(events, "c", "b") == [None]


def test_oversize_frame_is_refused_whole_and_counted() -> None:
    ch = channel(a=0.0, b=100.0)
    refused = ch.submit("a", b"x" * 65, 2.0)
    assert [(e.dst, e.reason, e.nbytes, e.delivered) for e in refused] == [("*", "oversize", 65,
                                                                            False)]
    assert refused[0].frame == b"x" * 65  # reported whole, never truncated
    assert run(ch) == [] and ch.next_due_s() is None
    assert ch.stats()[("a", "*")]["oversize"] == 1
    assert ch.submit("a", b"x" * 64, 3.0) == []  # the limit itself is fine
    assert outcome(run(ch), "a", "b") == [None]


def test_partition_cuts_links_between_groups_during_its_window() -> None:
    cut = Partition(10.0, 20.0, (("a",),))  # a against the implicit rest
    ch = channel(replace(LOSSLESS, partitions=(cut,)), a=0.0, b=300.0, c=600.0)
    ch.submit("a", b"m", 0.0)
    ch.submit("a", b"m", 12.0)
    ch.submit("b", b"n", 14.0)
    ch.submit("a", b"m", 30.0)
    events = run(ch)
    assert outcome(events, "a", "b") == [None, "partition", None]
    assert outcome(events, "a", "c") == [None, "partition", None]
    assert outcome(events, "b", "c") == [None]  # same (implicit) group
    assert outcome(events, "b", "a") == ["partition"]


def test_partition_added_at_run_time_and_cleared() -> None:
    ch = channel(a=0.0, b=300.0, c=600.0)
    ch.add_partition(Partition(0.0, 100.0, (("a", "b"), ("c",))))
    ch.submit("a", b"m", 1.0)
    events = run(ch)
    assert outcome(events, "a", "b") == [None] and outcome(events, "a", "c") == ["partition"]
    ch.clear_partitions()
    ch.submit("a", b"m", 50.0)
    assert outcome(run(ch), "a", "c") == [None]


# Physical: denser traffic, since capture lets most overlaps of unequal frames through.
@pytest.mark.parametrize("model, loss_reason, every_s", [("empirical", "range", 1.5),
                                                         ("physical", "sinr", 0.8)])
def test_stats_add_up_per_link(model: str, loss_reason: str, every_s: float) -> None:
    ch = channel(ChannelConfig(model=model, extra_loss=0.1), seed=5, a=0.0, b=900.0, c=1700.0,
                 d=2500.0)
    rng = np.random.default_rng(0)
    for i in range(300):
        ch.submit(str(rng.choice(list("abcd"))), b"s" * int(rng.integers(1, 70)), i * every_s)
    events = run(ch)
    stats = ch.stats()
    for (src, dst), row in stats.items():
        if dst == "*":
            continue
        drops = sum(row[r] for r in ("partition", "range", "sinr", "half_duplex", "collision",
                                     "random"))
        assert row["sent"] == row["delivered"] + drops
        assert row["sent"] == len(outcome(events, src, dst))
    total = totals(stats)
    assert total["delivered"] == sum(e.delivered for e in events)
    assert total["collision"] > 0 and total[loss_reason] > 0 and total["oversize"] > 0
    per_sender = totals_by_sender(stats)
    assert set(per_sender) == {"a", "b", "c", "d"}
    for src, row in per_sender.items():
        assert row["delivered"] == sum(e.delivered for e in events if e.src == src)
    assert sum(row["sent"] for row in per_sender.values()) == total["sent"]


@pytest.mark.parametrize("model", ["empirical", "physical"])
def test_same_seed_same_events(model: str) -> None:
    def once(seed: int = 42) -> list[tuple]:
        ch = channel(ChannelConfig(model=model, extra_loss=0.2), seed=seed, a=0.0, b=1400.0,
                     c=2100.0)
        for i in range(200):
            ch.submit("abc"[i % 3], bytes([i % 256]), i * 0.7)
        return [(e.src, e.dst, e.t_s, e.reason, e.snr_db, e.sinr_db) for e in run(ch)]

    assert once() == once()
    assert once() != once(seed=43)


@pytest.mark.parametrize("model, loss_reason", [("empirical", "range"),
                                                ("physical", "sinr")])
def test_a_new_node_does_not_change_other_links_draws(model: str, loss_reason: str) -> None:
    """Link streams are keyed by names: a far, silent extra node (out of everyone's range,
    so it cannot interfere) leaves the a->b outcomes exactly as they were."""
    config = ChannelConfig(model=model, extra_loss=0.3)

    def a_to_b(extra: bool) -> list[str | None]:
        ch = Channel(config, np.random.default_rng(9))
        if extra:
            ch.set_position("zz", (0.0, 50_000.0, 0.0), 0.0)  # appears first
        ch.set_position("a", (0.0, 0.0, 0.0), 0.0)
        ch.set_position("b", (1600.0, 0.0, 0.0), 0.0)
        for i in range(300):
            ch.submit("a", b"k", i * 10.0)
        return outcome(run(ch), "a", "b")

    with_extra, without = a_to_b(True), a_to_b(False)
    assert with_extra == without
    assert {None, loss_reason, "random"} <= set(without)


def test_calls_without_advance_do_not_rewrite_the_past() -> None:
    """Submitting at t without advancing first still starts earlier frames on time."""
    ch = channel(a=0.0, b=150.0)
    ch.submit("a", b"1", 0.0)
    ch.submit("a", b"2", 40.0)
    assert ch.next_due_s() == pytest.approx(0.1 + 0.308)  # the first frame, already settled
    events = ch.advance(40.0)
    assert [(e.frame, e.t_sent_s) for e in events] == [(b"1", 0.0)]
    assert [(e.frame, e.t_sent_s) for e in run(ch)] == [(b"2", 40.0)]


def test_late_calls_are_clamped_to_channel_time() -> None:
    ch = channel(a=0.0, b=150.0)
    ch.advance(10.0)
    ch.submit("a", b"late", 9.0)
    [event] = run(ch)
    assert event.t_sent_s == 10.0


def test_a_frame_kept_at_its_time_is_placed_in_the_past() -> None:
    """`keep_time`: a frame an emulated host handed over late keeps its send time; receptions
    still pending meet it as ever, settled ones are history and stay as they were."""
    ch = channel(a=0.0, b=1000.0, c=2000.0)
    ch.submit("a", b"a" * 30, 0.0)  # at b during [0.667, 1.207), at c during [1.333, 1.873)
    events = ch.advance(1.5)  # a's frame at b has settled
    ch.submit("b", b"b" * 30, 0.5, keep_time=True)  # b sends over a frame it already got
    ch.submit("c", b"c" * 30, 1.0, keep_time=True)  # c sends while a's frame reaches it
    events += run(ch)
    sent = {(e.src, e.dst): e for e in events}
    assert outcome(events, "a", "b") == [None]  # history
    assert outcome(events, "a", "c") == ["half_duplex"]  # pending: c was transmitting
    assert sent[("b", "a")].t_sent_s == 0.5 and sent[("b", "a")].delivered
    assert sent[("c", "a")].t_sent_s == 1.0 and sent[("c", "a")].delivered


def test_tdma_frames_start_only_in_own_slot() -> None:
    tdma = TdmaConfig(slot_s=3.0, order=("a", "b"), guard_s=2.0)
    ch = channel(replace(LOSSLESS, tdma=tdma), a=0.0, b=1000.0)
    ch.submit("b", b"b" * 10, 0.0)  # b's slot opens at 3.0
    ch.submit("a", b"a" * 10, 0.5)  # a's slot [0, 3): a 0.38 s frame must end by 1.0: fits
    ch.submit("a", b"A" * 10, 0.9)  # would end at 1.26 (after the first): next cycle at 6.0
    events = run(ch)
    starts = {e.frame[:1]: e.t_sent_s for e in events}
    assert starts == {b"b": 3.0, b"a": 0.5, b"A": 6.0}
    assert all(e.delivered for e in events)


def test_tdma_unlisted_nodes_take_the_next_slots() -> None:
    tdma = TdmaConfig(slot_s=3.0, order=("a",), guard_s=2.0)
    ch = channel(replace(LOSSLESS, tdma=tdma), a=0.0, b=1000.0, c=2000.0)
    ch.submit("c", b"c", 0.0)  # c is the first unlisted node to transmit: slot 1
    ch.submit("b", b"b", 0.0)  # then b: slot 2
    starts = {e.frame: e.t_sent_s for e in run(ch)}
    assert starts == {b"c": 3.0, b"b": 6.0}


def test_tdma_queue_newest_pose_wins_but_claims_are_kept() -> None:
    tdma = TdmaConfig(slot_s=3.0, order=("a", "b"), guard_s=2.0)
    ch = channel(replace(LOSSLESS, tdma=tdma), a=0.0, b=1000.0)
    ch.advance(3.5)  # a's slot is over: everything waits for 6.0
    ch.submit("a", b"pose1", 3.5, kind="pose")
    ch.submit("a", b"claim", 3.6, kind="claim")
    ch.submit("a", b"pose2", 3.7, kind="pose")
    ch.submit("a", b"clear", 3.8, kind="cleared")
    ch.submit("a", b"pose3", 3.9, kind="pose")
    assert ch.queued("a") == 3
    sent = [e.frame for e in run(ch) if e.dst == "b"]
    assert sent == [b"claim", b"clear", b"pose3"]
    assert ch.stats()[("a", "*")]["superseded"] == 2


def test_tdma_slot_must_hold_the_largest_frame() -> None:
    with pytest.raises(ValueError, match="cannot hold"):
        ChannelConfig(tdma=TdmaConfig(slot_s=2.5, guard_s=2.0))  # 0.81 s frame + 2 s guard


def test_link_event_codec_round_trip_and_garbage() -> None:
    event = LinkEvent("auv0", "auv1", 1.5, 3.25, 3, False, "collision", b"\x00\xff\x10")
    assert LinkEvent.decode(event.encode()) == event
    heard = LinkEvent("auv0", "auv1", 1.5, 3.25, 3, False, "sinr", b"x", -3.5, -12.25)
    assert LinkEvent.decode(heard.encode()) == heard
    legacy = msgpack.packb({k: v for k, v in msgpack.unpackb(event.encode()).items()
                            if k not in ("snr_db", "sinr_db")})  # from a relay before snr_db
    assert LinkEvent.decode(legacy) == event
    bad_frame = msgpack.packb({**msgpack.unpackb(event.encode()), "frame": 5})
    for garbage in (b"", b"\xc1", b"\x93\x01\x02\x03", b"\x81\xa3src\xa1a", bad_frame):
        with pytest.raises(ValueError):
            LinkEvent.decode(garbage)
    with pytest.raises(ValueError):
        LinkEvent("a", "b", 0.0, 1.0, 1, False, "gremlins", b"x")


def test_a_reception_lost_from_the_start_asks_for_no_wake_up() -> None:
    """A frame cut off by a partition (or out of range, or too weak alone) is lost whatever
    happens next: it is settled in its place in time order when the channel next runs past
    it, and never wakes the simulation by itself (100 vehicles: most receptions are such)."""
    ch = channel(a=0.0, z=150.0, b=1500.0, far=9000.0)  # far: beyond max_range_m
    ch.add_partition(Partition(0.0, 100.0, (("a", "b", "far"), ("z",))))
    ch.submit("a", b"m", 1.0)
    ch.advance(1.0)  # the transmission starts
    airtime = ch.airtime_s(1)
    to_b = 1.0 + 1500.0 / ch.config.sound_speed_mps + airtime
    assert ch.next_due_s() == pytest.approx(to_b)  # not a->z's earlier end
    events = ch.advance(to_b)
    assert [(e.dst, e.reason) for e in events] == [("z", "partition"), ("b", None)]
    assert events[0].t_s < events[1].t_s  # in time order, settled together
    assert ch.next_due_s() is not None and ch.next_due_s() > to_b  # nothing else left: far
    assert [(e.dst, e.reason) for e in run(ch)] == [("far", "range")]
    assert totals(ch.stats())["sent"] == 3
