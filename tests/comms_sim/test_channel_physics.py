"""The physical channel model: SNR from the sonar equation, SINR, capture, drop reasons.

Expected levels are worked out here from the formulas: received level 185 - TL(r) with TL the
practical spreading plus Thorp at 25 kHz (6.104805 dB/km), the band noise of the channel."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from comms_sim.channel import Channel, ChannelConfig, LinkEvent

STEADY = ChannelConfig(rician_k=None)  # no fading: outcomes are certain far from the edge
FAST = replace(STEADY, bitrate_bps=5000.0)  # no processing gain: equal overlaps are fatal


def level_db(range_m: float) -> float:
    """Mean received level of the psk_1k modem (185 dB) at 25 kHz, by hand."""
    return 185.0 - 15.0 * math.log10(range_m) - 6.104805 * range_m / 1000.0


def channel(config: ChannelConfig, seed: int = 7, **xs: float) -> Channel:
    ch = Channel(config, np.random.default_rng(seed))
    for node, x in xs.items():
        ch.set_position(node, (x, 0.0, 0.0), 0.0)
    return ch


def run(ch: Channel) -> list[LinkEvent]:
    events = []
    while (due := ch.next_due_s()) is not None:
        events += ch.advance(due)
    return events


def one(events: list[LinkEvent], src: str, dst: str) -> LinkEvent:
    [event] = [e for e in events if e.src == src and e.dst == dst]
    return event


def test_snr_differences_between_ranges_are_tl_differences() -> None:
    ch = channel(STEADY, a=0.0, b=400.0, c=1700.0, d=-2500.0)
    ch.submit("a", b"x" * 20, 0.0)
    events = run(ch)
    noise = STEADY.budget.noise_db
    for dst, r in (("b", 400.0), ("c", 1700.0), ("d", 2500.0)):
        e = one(events, "a", dst)
        assert e.snr_db == pytest.approx(level_db(r) - noise, abs=1e-6)
        assert e.sinr_db == e.snr_db  # nothing overlapped
    snr = {e.dst: e.snr_db for e in events}
    tl = STEADY.budget.transmission_loss_db
    assert snr["b"] - snr["c"] == pytest.approx(tl(1700.0) - tl(400.0), abs=1e-9)
    assert snr["b"] - snr["c"] == pytest.approx(level_db(400.0) - level_db(1700.0), abs=1e-6)


def test_near_frame_survives_far_interferer_capture() -> None:
    """b hears a (200 m) and c (1500 m) at once: a is 21 dB louder. Alone both decode; together
    a survives (its SINR stays ~20 dB) and c is lost to the collision."""
    ch = channel(STEADY, b=0.0, a=200.0, c=-1500.0)
    assert STEADY.delivery_probability(1500.0, 30) > 0.999
    ch.submit("c", b"c" * 30, 0.0)  # at b during [1.0, 1.54)
    ch.submit("a", b"a" * 30, 0.9)  # at b during [1.033, 1.573)
    events = run(ch)
    near, far = one(events, "a", "b"), one(events, "c", "b")
    assert near.delivered and far.reason == "collision"
    noise = 10 ** (STEADY.budget.noise_db / 10)
    assert near.sinr_db == pytest.approx(
        level_db(200.0) - 10 * math.log10(noise + 10 ** (level_db(1500.0) / 10)), abs=1e-6)
    assert far.sinr_db == pytest.approx(
        level_db(1500.0) - 10 * math.log10(noise + 10 ** (level_db(200.0) / 10)), abs=1e-6)
    assert near.sinr_db > 15.0 > -15.0 > far.sinr_db


def test_capture_under_fading_is_statistical_but_clear() -> None:
    near_ok = far_lost = 0
    trials = 300
    for seed in range(trials):
        ch = channel(ChannelConfig(), seed=seed, b=0.0, a=200.0, c=-1000.0)
        ch.submit("c", b"c" * 30, 0.0)
        ch.submit("a", b"a" * 30, 0.6)
        events = run(ch)
        near_ok += one(events, "a", "b").delivered
        far_lost += one(events, "c", "b").reason in ("collision", "sinr")
    assert near_ok / trials > 0.95 and far_lost / trials > 0.95


def test_equal_frames_overlapping_both_lost() -> None:
    ch = channel(FAST, a=0.0, b=1000.0, c=2000.0)  # b in the middle, 1000 m from each
    assert FAST.delivery_probability(1000.0, 30) > 0.999
    ch.submit("a", b"a" * 30, 0.0)
    ch.submit("c", b"c" * 30, 0.1)
    events = run(ch)
    assert one(events, "a", "b").reason == "collision"
    assert one(events, "c", "b").reason == "collision"
    assert one(events, "a", "b").sinr_db == pytest.approx(
        level_db(1000.0) - 10 * math.log10(10 ** (FAST.budget.noise_db / 10)
                                           + 10 ** (level_db(1000.0) / 10)), abs=1e-6)


def test_worst_instant_decides_not_the_sum_of_interferers() -> None:
    """Two interferers hit different parts of a's reception at b: the SINR is against the
    louder one alone (they never overlap each other)."""
    ch = channel(STEADY, b=0.0, a=300.0, c=1000.0, d=-1200.0)
    ch.submit("a", b"a" * 64, 0.0)   # at b during [0.2, 1.012)
    ch.submit("c", b"c", 0.0)        # at b during [0.667, 0.975)
    ch.submit("d", b"d", 0.18)       # at b during [0.98, 1.288)
    e = one(run(ch), "a", "b")
    noise = 10 ** (STEADY.budget.noise_db / 10)
    loudest = 10 ** (level_db(1000.0) / 10)
    assert e.sinr_db == pytest.approx(level_db(300.0) - 10 * math.log10(noise + loudest),
                                      abs=1e-6)
    assert e.delivered


def test_too_weak_is_sinr_beyond_hearing_is_range() -> None:
    c = ChannelConfig()
    far, out = 3800.0, c.horizon_m + 100.0
    assert c.delivery_probability(far) < 1e-4
    ch = channel(c, a=0.0, b=far, z=out)
    for i in range(50):
        ch.submit("a", b"k" * 64, i * 10.0)
    events = run(ch)
    assert {e.reason for e in events if e.dst == "b"} == {"sinr"}
    assert all(e.snr_db is not None for e in events if e.dst == "b")
    assert {(e.reason, e.snr_db) for e in events if e.dst == "z"} == {("range", None)}
    assert ch.stats()[("a", "b")]["sinr"] == 50


def test_frames_beyond_hearing_do_not_interfere() -> None:
    ch = channel(STEADY, b=0.0, a=1500.0, z=-(STEADY.horizon_m + 50.0))
    ch.submit("a", b"a" * 30, 0.0)
    ch.submit("z", b"z" * 64, 0.0)  # would overlap a at b if it were heard
    events = run(ch)
    assert one(events, "a", "b").delivered and one(events, "a", "b").sinr_db == \
        one(events, "a", "b").snr_db


def test_collisions_off_ignores_interference() -> None:
    ch = channel(replace(FAST, collisions=False), a=0.0, b=1000.0, c=2000.0)
    ch.submit("a", b"a" * 30, 0.0)
    ch.submit("c", b"c" * 30, 0.1)
    events = run(ch)
    assert one(events, "a", "b").delivered and one(events, "c", "b").delivered


def test_half_duplex_wins_over_collision() -> None:
    ch = channel(FAST, a=0.0, b=1000.0, c=2000.0)
    ch.submit("a", b"a" * 30, 0.0)   # at b during [0.667, 0.715)
    ch.submit("c", b"c" * 30, 0.05)
    ch.submit("b", b"b" * 30, 0.6)   # b transmits meanwhile
    events = run(ch)
    assert one(events, "a", "b").reason == "half_duplex"


def test_delivery_falls_with_range_through_the_channel() -> None:
    """Delivered fraction over many frames, at increasing ranges: non-increasing."""
    fractions = []
    for r in (300.0, 1000.0, 1500.0, 2000.0, 2500.0, 3000.0):
        ch = channel(ChannelConfig(), seed=21, a=0.0, b=r)
        for i in range(600):
            ch.submit("a", b"p" * 64, i * 5.0)
        fractions.append(np.mean([e.delivered for e in run(ch)]))
    assert fractions[0] > 0.97 and fractions[-1] < 0.05
    assert all(b <= a + 0.03 for a, b in zip(fractions, fractions[1:]))
