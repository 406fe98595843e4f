"""The camera on the hidden reef (`reef_sim.camera`), and looks through the vehicle port."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fleet_agent.motion import Activity, Cleared, Inspected
from hfc_core.model.problem import Problem, Task, Vehicle as VehicleSpec
from reef_sim.camera import ReefCamera, pass_seen, segment_distance_m
from reef_sim.truth import Reef, TruthSpot
from vehicle_loop import Loop, conduct


def reef(spots, p_detect=1.0, radius=25.0, inspect_s=20.0) -> Reef:
    return Reef(radius, p_detect, inspect_s, tuple(spots))


def spot(x, y, task=None, priority=50.0, service=70.0) -> TruthSpot:
    return TruthSpot((x, y, 0.0), priority, service, task)


def test_a_spot_exactly_at_the_detect_radius_is_seen_and_one_beyond_is_not():
    w = ReefCamera(reef([spot(100.0, 25.0), spot(200.0, 25.01)]), seed=1, vehicle=0)
    w.sweep((0.0, 0.0, 0.0))
    seen = w.sweep((300.0, 0.0, 0.0))
    assert [s.pos for s in seen] == [(100.0, 25.0, 0.0)]


@pytest.mark.parametrize("p, expected", [(0.0, 0), (1.0, 40)])
def test_p_detect_zero_never_sees_and_one_always_sees(p, expected):
    # 40 spots along the track, each passed once
    w = ReefCamera(reef([spot(20.0 * i, 5.0) for i in range(40)], p_detect=p), seed=3, vehicle=1)
    w.sweep((-50.0, 0.0, 0.0))
    assert len(w.sweep((900.0, 0.0, 0.0))) == expected


def test_each_pass_draws_once_and_the_draws_do_not_depend_on_step_times():
    spots = [spot(float(x), float(y)) for x, y in
             np.random.default_rng(0).uniform(0, 400, size=(30, 2))]
    track = [(0.0, 0.0, 0.0), (400.0, 400.0, 0.0), (0.0, 400.0, 0.0), (400.0, 0.0, 0.0)]
    coarse = ReefCamera(reef(spots, p_detect=0.5), seed=7, vehicle=2)
    fine = ReefCamera(reef(spots, p_detect=0.5), seed=7, vehicle=2)
    got_coarse, got_fine = [], []
    for a, b in zip(track[:-1], track[1:]):
        got_coarse += coarse.sweep(a) + coarse.sweep(b)
        for f in np.linspace(0.0, 1.0, 97):  # the same track in many small steps
            got_fine += fine.sweep(tuple(a[i] + (b[i] - a[i]) * f for i in range(3)))
    key = lambda s: s.pos  # noqa: E731 - within one step, order is by spot, not by time
    coarse_seen, fine_seen = sorted(got_coarse, key=key), sorted(got_fine, key=key)
    assert got_coarse and [s[:5] for s in coarse_seen] == [s[:5] for s in fine_seen]
    # where each pass began: the same point of the track (to rounding), however it was cut
    for c, f in zip(coarse_seen, fine_seen):
        assert c.at == pytest.approx(f.at, abs=1e-9)
        assert math.dist(c.at, c.pos) == pytest.approx(coarse.reach_m, abs=1e-9) or c.at in track
    assert (coarse._passes == fine._passes).all()
    # a pass is one draw: p_detect 0.5 over many passes sees some and misses some
    assert 0 < len(got_coarse) < int(coarse._passes.sum())


def test_leaving_and_coming_back_is_a_new_pass_with_its_own_draw():
    w = ReefCamera(reef([spot(0.0, 0.0)], p_detect=0.5), seed=11, vehicle=0)
    results = []
    for k in range(40):
        w.sweep((100.0, 0.0, 0.0))
        results.append(bool(w.sweep((0.0, 0.0, 0.0))))
    assert int(w._passes[0]) == 40
    assert results == [pass_seen(11, 0, 0, k + 1, 0.5) for k in range(40)]
    assert 5 < sum(results) < 35


def test_inspection_says_what_the_truth_holds():
    w = ReefCamera(reef([spot(0.0, 0.0, task=1, priority=42.0, service=66.0)]), seed=0, vehicle=0)
    assert w.inspect(0).present is False
    found = w.inspect(1)
    assert found.present and found.priority == 42.0 and found.service_s == 66.0


def test_a_look_at_a_find_shows_the_aggregation_nearest_under_the_camera():
    """Tasks from ``n_predicted`` on are finds: the map names no aggregation for them, so a
    look shows what lies under the camera (the nearest within the footprint, the one an
    injection there treats), whatever the task; a predicted spot's look shows its own."""
    truth = [spot(0.0, 0.0, task=1, priority=42.0), spot(20.0, 0.0, priority=60.0),
             spot(8.0, 0.0, priority=2.5)]
    w = ReefCamera(reef(truth), seed=0, vehicle=0, n_predicted=5)
    assert w.is_find(5) and not w.is_find(4)
    assert w.look(7, (17.0, 0.0, 0.0)) == (True, 60.0, 70.0)  # 3 m from rho 60, 9 from 2.5
    assert w.seen_by_look(7, (17.0, 0.0, 0.0)) == w.treated(7, (17.0, 0.0, 0.0)) == 1
    assert w.look(7, (11.0, 0.0, 0.0)).priority == 2.5
    assert w.look(7, (60.0, 0.0, 0.0)).present is False  # nothing within 15 m
    assert w.look(1, (11.0, 0.0, 0.0)) == (True, 42.0, 70.0)  # predicted: its own, 11 m off
    assert w.look(1, (17.0, 0.0, 0.0)).present is False  # beyond the footprint
    # A helm without the true position of its look answers a predicted spot from the
    # truth's book; a find from where the camera is, nothing without it.
    assert w.inspect(1) == (True, 42.0, 70.0) and w.inspect(6).present is False
    assert w.inspect(6, (19.0, 1.0, 0.0)).priority == 60.0
    # Without n_predicted every task is a predicted spot: unnamed ones are empty.
    assert ReefCamera(reef(truth), seed=0, vehicle=0).look(7, (17.0, 0.0, 0.0)).present is False


def test_segment_distance():
    pts = np.array([[5.0, 3.0, 0.0], [-4.0, 3.0, 0.0], [14.0, 0.0, 0.0]])
    d = segment_distance_m((0.0, 0.0, 0.0), (10.0, 0.0, 0.0), pts)
    np.testing.assert_allclose(d, [3.0, 5.0, 4.0])


# -- looks through the vehicle port ----------------------------------------------------------


def line_problem() -> Problem:
    tasks = [Task(10, (100.0, 0.0, 0.0), 50.0, 80.0), Task(11, (200.0, 0.0, 0.0), 50.0, 80.0)]
    return Problem.build("line", [VehicleSpec("auv1", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                                              3600.0, 1.0)], tasks)


def looking(truth: list[TruthSpot]) -> Loop:
    """A vehicle that must look at every spot (its agent knows nothing), 20 s per look."""
    camera = ReefCamera(reef(truth, inspect_s=20.0), seed=0, vehicle=0)
    return Loop(line_problem(), rules=conduct(needs_look=lambda t: True, inspect_s=20.0),
                camera=camera)


def test_an_empty_spot_costs_the_look_and_nothing_more():
    loop = looking([])
    loop.set_route([0, 1])
    assert loop.run_until(100.0) == [] and loop.own.inspecting == 0
    assert loop.next_s() == 120.0
    assert loop.run_until(120.0) == [Inspected(0, 120.0, False, False)]
    assert loop.own.activity is Activity.TRANSIT and loop.own.route == [1]


def test_a_present_spot_is_injected_for_its_real_time():
    loop = looking([spot(100.0, 0.0, task=0, service=33.0)])  # the map said 80 s
    loop.set_route([0])
    loop.run_until(100.0)
    assert math.isclose(loop.own.time_to_finish_s(), 20.0 + (80.0 - 20.0) + 100.0)
    assert loop.run_until(140.0) == [Inspected(0, 120.0, True, True)]
    # the injection began when the look ended, whatever the map said it would take (a stop
    # mid-injection logs the time from here: `policies.route`)
    assert loop.own.injecting_since_s == 120.0
    assert loop.run_until(160.0) == [Cleared(0, 153.0, 33.0)]


def test_cots_beyond_the_battery_are_left_for_others():
    loop = looking([spot(100.0, 0.0, task=0, service=3500.0)])
    loop.set_route([0])
    assert loop.run_until(120.0) == [Inspected(0, 120.0, True, False)]
    assert loop.own.route == []


def test_a_known_spot_is_injected_at_once_as_before():
    loop = Loop(line_problem())
    loop.set_route([0])
    assert loop.run_until(200.0) == [Cleared(0, 180.0, 80.0)]


def test_the_books_keep_every_pass_and_the_first_sighting_of_each_aggregation():
    # An aggregation the map missed, 10 m off the line: passed on the way out and again on
    # the way home, seen both times (p_detect 1); the book keeps the first time.
    truth = [spot(50.0, 10.0)]
    camera = ReefCamera(reef(truth), seed=0, vehicle=0)
    loop = Loop(line_problem(), camera=camera)
    loop.set_route([0, 1])
    loop.run_home()
    assert camera.passes().tolist() == [2]
    assert list(loop.sim.sighted) == [0] and loop.sim.sighted[0] <= 100.0
    camera.passes()[0] = 99  # a copy: the camera's own count is not the caller's to change
    assert camera.passes().tolist() == [2]
