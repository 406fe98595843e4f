"""The operator slows the clock for a host that stays behind it, not for one late step, and
speeds it up again once every host keeps up."""

from __future__ import annotations

import pytest

from cotsfleet.mission.pacing import (HOLD_LIMIT_WALL_S, HOLD_REFILL_SHARE, MAX_FACTOR,
                                      MIN_FACTOR, Holds, LagWatch, faster_warp, slower_warp)


def feed(watch: LagWatch, vid: str, lags: list[float], t0: float = 0.0) -> None:
    for i, lag in enumerate(lags):
        watch.see(vid, t0 + 5.0 * (i + 1), lag)


def test_a_burst_is_not_a_host_that_stays_behind():
    watch = LagWatch(bound_s=1.25)
    feed(watch, "auv1", [0.1, 40.0, 0.2, 0.1, 30.0, 0.0])  # two replans, each one status late
    assert watch.behind() == 0.0
    assert watch.max_lag_s == 40.0  # still reported


def test_late_statuses_in_a_row_are():
    watch = LagWatch(bound_s=1.25, sustained=3)
    feed(watch, "auv1", [2.0, 3.0])
    feed(watch, "auv2", [0.0, 0.0, 0.0])
    assert watch.behind() == 0.0
    feed(watch, "auv1", [2.5], t0=10.0)
    assert watch.behind() == 3.0  # the worst of the run
    assert LagWatch(bound_s=1.25).sustained == 3  # the default: 15 mission s of statuses


def test_the_same_status_seen_twice_counts_once():
    watch = LagWatch(bound_s=1.0)
    for _ in range(5):  # the launcher polls faster than statuses come
        watch.see("auv1", 5.0, 9.0)
    assert watch.behind() == 0.0
    watch.see("auv1", 4.0, 9.0)  # older: ignored
    watch.see("auv1", 10.0, 9.0)
    watch.see("auv1", 15.0, 9.0)
    assert watch.behind() == 9.0


def test_after_a_slowdown_the_new_pace_must_show_first():
    watch = LagWatch(bound_s=1.0, sustained=2)
    feed(watch, "auv3", [5.0, 5.0])
    assert watch.behind() == 5.0
    watch.restart()
    assert watch.behind() == 0.0
    feed(watch, "auv3", [0.5, 2.0, 2.0], t0=10.0)
    assert watch.behind() == 2.0


def test_one_slowdown_brings_the_host_to_half_the_bound():
    # 2.5 mission s behind at warp 100 is 25 ms of wall; at warp 25 those 25 ms are 0.625 s,
    # half of the 1.25 s bound.
    assert slower_warp(100.0, 2.5, 1.25) == pytest.approx(25.0)
    assert 2.5 / 100.0 * slower_warp(100.0, 2.5, 1.25) == pytest.approx(0.5 * 1.25)


def test_a_slowdown_is_bounded_both_ways():
    assert slower_warp(60.0, 0.8, 1.25) == pytest.approx(60.0 * MAX_FACTOR)  # barely late
    assert slower_warp(60.0, 500.0, 1.25) == pytest.approx(60.0 * MIN_FACTOR)  # frozen


def test_a_calm_minute_of_every_vehicle_brings_the_pace_back():
    watch = LagWatch(bound_s=1.0, recover=12)
    assert not watch.calm()  # nothing heard yet
    feed(watch, "auv1", [0.1] * 12)
    feed(watch, "auv2", [0.1] * 11)
    assert not watch.calm()  # auv2 not yet a minute
    feed(watch, "auv2", [0.25], t0=55.0)  # a quarter of the bound still counts as calm
    assert watch.calm()
    feed(watch, "auv1", [0.3], t0=60.0)  # over a quarter: a new minute must pass
    assert not watch.calm()
    watch.restart()  # after a change of pace too
    feed(watch, "auv1", [0.0] * 12, t0=100.0)
    feed(watch, "auv2", [0.0] * 12, t0=100.0)
    assert watch.calm() and watch.behind() == 0.0


def test_speeding_up_is_a_step_and_never_past_the_request():
    assert faster_warp(20.0, 100.0) == pytest.approx(20.0 / MAX_FACTOR)
    assert faster_warp(90.0, 100.0) == 100.0
    assert faster_warp(100.0, 100.0) == 100.0


def held_at(h: Holds, wall_s: float) -> bool:
    h.refresh(wall_s)
    return h.held


def test_the_clock_is_held_while_any_agent_plans():
    h = Holds()
    assert not held_at(h, 0.0)
    h.update("auv1", True, 1.0)
    h.update("auv2", True, 1.2)
    h.update("auv1", False, 1.5)
    assert h.held  # auv2 still plans
    h.update("auv2", False, 2.0)
    assert not h.held
    assert h.count == 2 and h.held_wall_s == pytest.approx(1.0)


def test_a_hold_never_released_expires():
    """A process that died mid-plan (or whose end was lost) slows the mission, never stops it."""
    h = Holds()
    h.update("auv1", True, 0.0)
    assert held_at(h, HOLD_LIMIT_WALL_S - 0.1)
    assert not held_at(h, HOLD_LIMIT_WALL_S + 0.1)
    assert h.held_wall_s == pytest.approx(HOLD_LIMIT_WALL_S + 0.1)
    h.update("auv1", False, HOLD_LIMIT_WALL_S + 1.0)  # a late end changes nothing
    assert not h.held and h.count == 1


def test_a_repeated_start_is_one_hold():
    h = Holds()
    h.update("auv1", True, 0.0)
    h.update("auv1", True, 0.5)
    assert h.count == 1 and held_at(h, 0.5)


def test_an_insider_renewing_its_busy_flag_gets_no_longer_hold():
    """Today's attack: ``busy=1`` every 5 s. A standing hold is not renewed: it ends after
    the limit, counted, and the same vehicle is refused while it cools down."""
    h = Holds()
    cooled = HOLD_LIMIT_WALL_S + HOLD_LIMIT_WALL_S / HOLD_REFILL_SHARE  # 50 s
    for t in range(0, int(cooled), 5):
        h.update("auv2", True, float(t))
    # held from 0 to the limit; then refused at 15, 20, ... 45 while cooling down
    assert h.count == 1 and h.expired == {"auv2": 1} and not h.held
    assert h.refused == {"auv2": 7}
    assert h.held_wall_s == pytest.approx(HOLD_LIMIT_WALL_S)
    h.update("auv2", True, cooled + 0.1)  # a full allowance again: a new hold
    assert h.held and h.count == 2


def test_a_toggling_insider_holds_the_clock_a_fifth_of_the_time_at_most():
    h = Holds()
    held, t, dt = 0.0, 0.0, 0.1
    while t < 600.0:  # busy for a second, free for a tick, again and again
        h.update("auv3", (t % 1.1) < 1.0, t)
        held += dt if h.held else 0.0
        t = round(t + dt, 6)
    share = HOLD_REFILL_SHARE / (1 + HOLD_REFILL_SHARE)
    assert held / 600.0 <= share + HOLD_LIMIT_WALL_S / 600.0 + 0.02


def test_a_planner_bursts_never_run_out_of_allowance():
    """An honest agent's replans: a few hundred milliseconds now and then."""
    h = Holds()
    for i in range(200):
        h.update("auv1", True, i * 3.0)
        h.update("auv1", False, i * 3.0 + 0.4)
    assert h.count == 200 and not h.expired and not h.refused


def test_a_dead_planner_does_not_hold_others_up():
    h = Holds()
    h.update("auv1", True, 0.0)
    h.update("auv2", True, 1.0)
    h.update("auv2", False, 1.5)
    assert held_at(h, 5.0) and not held_at(h, HOLD_LIMIT_WALL_S + 0.1)
    assert h.expired == {"auv1": 1} and h.holders == ()
