"""The spatial TDMA schedule (`fleet_bus.tdma.SpatialSchedule`): plain TDMA as its degenerate
case, slots shared only by vehicles the plan keeps apart, parked vehicles taking turns, and
one vehicle's openings the same whichever way they are asked for (next, latest, counted, the
n-th)."""

from __future__ import annotations

import numpy as np
import pytest

from fleet_bus.tdma import SpatialSchedule, TdmaSchedule, Track

SLOT_S = 2.5


def still(x: float, y: float, done_s: float = 1e9) -> Track:
    return Track(np.array([0.0]), np.array([[x, y]]), done_s)


def moving(a: tuple[float, float], b: tuple[float, float], t_s: float) -> Track:
    return Track(np.array([0.0, t_s]), np.array([a, b]), t_s)


def openings(s: SpatialSchedule, v: int, until_s: float, lead: float = 0.0) -> list[float]:
    out, t = [], 0.0
    while True:
        t = s.opening(v, t, lead)
        if t > until_s:
            return out
        out.append(t)
        t += 1e-6


def test_without_reuse_it_is_the_plain_schedule() -> None:
    plain = TdmaSchedule(5, SLOT_S)
    s = SpatialSchedule.plain(5, SLOT_S)
    for v in range(5):
        assert openings(s, v, 2000.0, 0.05) == pytest.approx(
            [plain.opens(v, n, 0.05) for n in range(plain.first_cycle(v, 2000.0 + 1e-6, 0.05))
             if plain.opens(v, n, 0.05) <= 2000.0])
    assert s.cycle_s(1234.0) == s.turn_s(3, 1234.0) == 12.5


def test_vehicles_far_apart_share_slots_near_ones_do_not() -> None:
    # Two trios 10 km apart; within a trio 1 km apart.
    tracks = [still(x0 + dx, 0) for x0 in (0, 10_000) for dx in (0, 1000, 2000)]
    s = SpatialSchedule(tracks, SLOT_S, reuse_m=3500.0, margin_m=500.0)
    e = s.epoch(0.0)
    assert e.n_slots == 3
    assert len({e.slot[v] for v in (0, 1, 2)}) == 3 and len({e.slot[v] for v in (3, 4, 5)}) == 3
    assert s.cycle_s(0.0) == 3 * SLOT_S  # a turn every 7.5 s, not every 15 s


def test_a_cycle_has_at_least_three_slots() -> None:
    """However far apart, a cycle is 3 slots: a frame is heard before its sender's next turn
    discloses its key (`fleet_bus.tesla`)."""
    tracks = [still(0, 0), still(1000, 0), still(10_000, 0), still(11_000, 0)]
    s = SpatialSchedule(tracks, SLOT_S, reuse_m=3500.0, margin_m=500.0)
    assert s.epoch(0.0).n_slots == 3 and s.epoch(0.0).slot[0] != s.epoch(0.0).slot[1]
    assert SpatialSchedule([still(0, 0), still(9000, 0)], SLOT_S, 3500.0).cycle_s(0.0) \
        == 2 * SLOT_S  # never more slots than vehicles


def test_the_schedule_follows_the_plan_as_vehicles_move_apart() -> None:
    # Both start at one station; one stays, the other leaves at 1 m/s for a point 20 km off.
    tracks = [still(0, 0), moving((0, 0), (20_000, 0), 20_000.0)]
    s = SpatialSchedule(tracks, SLOT_S, reuse_m=3500.0, margin_m=500.0, epoch_s=600.0)
    assert s.epoch(0.0).n_slots == 2  # together: a slot each
    far = s.epoch(10_000.0)
    assert far.slot[0] == far.slot[1]  # 10 km apart: one slot shared (the cycle keeps its floor)
    # No instant at which both own a slot while the plan has them closer than reuse_m.
    for t in openings(s, 0, 20_000.0):
        e = s.epoch(t)
        if e.slot[0] == e.slot[1]:
            gap = abs(tracks[1].at(t)[0] - tracks[0].at(t)[0])
            assert gap >= 3500.0


def test_many_parked_at_one_place_take_turns() -> None:
    tracks = [still(0, 0, done_s=0.0) for _ in range(9)] + [still(50, 0)]
    s = SpatialSchedule(tracks, SLOT_S, reuse_m=3500.0, park_group=4)
    e = s.epoch(0.0)
    assert e.n_slots == 4  # 9 parked in 3 groups of 3, and the working vehicle
    assert sorted(e.group) == [1] + [3] * 9
    cycle = s.cycle_s(0.0)
    assert s.turn_s(0, 0.0) == 3 * cycle and s.turn_s(9, 0.0) == cycle
    # Within a group, never two in one cycle; every member in turn.
    by_time: dict[float, list[int]] = {}
    for v in range(10):
        for t in openings(s, v, 600.0):
            by_time.setdefault(round(t, 6), []).append(v)
    assert all(len(vs) == 1 for vs in by_time.values())
    # A few parked keep a slot each (a rotation would save a slot or two).
    few = SpatialSchedule([still(0, 0, done_s=0.0) for _ in range(3)], SLOT_S, 3500.0)
    assert few.epoch(0.0).group == (1, 1, 1)


@pytest.mark.parametrize("seed", range(4))
def test_next_latest_and_counts_agree_across_epochs(seed: int) -> None:
    rng = np.random.default_rng(seed)
    tracks = [moving(tuple(rng.uniform(0, 8000, 2)), tuple(rng.uniform(0, 8000, 2)),
                     float(rng.uniform(100, 5000))) for _ in range(12)]
    s = SpatialSchedule(tracks, SLOT_S, reuse_m=3500.0, epoch_s=300.0)
    for v in range(12):
        opens = openings(s, v, 4000.0, 0.05)
        assert opens == sorted(opens) and len(opens) > 10
        for i, t in enumerate(opens):
            assert s.turns_before(v, t - 0.05 * SLOT_S) == i
            assert s.nth_opening(v, i, 0.05) == pytest.approx(t)  # its inverse
            assert s.latest(v, t + 1.0, 0.05) == pytest.approx(t)
        assert s.latest(v, opens[0] - 1e-3, 0.05) is None
        # The water's MAC puts a frame inside the vehicle's slot.
        start = s.next_start(v, opens[3] - 0.1, 0.81, 1.0)
        assert opens[3] - 0.05 * SLOT_S <= start <= opens[3] - 0.05 * SLOT_S + SLOT_S - 1.81


def test_bad_schedules_are_refused() -> None:
    with pytest.raises(ValueError):
        SpatialSchedule([], SLOT_S, reuse_m=3500.0)
    with pytest.raises(ValueError):
        SpatialSchedule([still(0, 0)], 0.0)
    with pytest.raises(ValueError):
        Track(np.array([1.0, 0.0]), np.array([[0, 0], [1, 1]]), 0.0)
