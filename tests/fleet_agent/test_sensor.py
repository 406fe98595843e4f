"""The world's camera (`fleet_agent.sensor`) and the vehicle's inspecting phase."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fleet_agent.sensor import World, pass_seen, segment_distance_m
from fleet_agent.vehicle import INJECTING, INSPECTING, TRANSIT, Cleared, Inspected, Vehicle
from hfc_core.model.problem import Problem, Task, Vehicle as VehicleSpec
from reef_sim.truth import Reef, TruthSpot


def reef(spots, p_detect=1.0, radius=25.0, inspect_s=20.0) -> Reef:
    return Reef(radius, p_detect, inspect_s, tuple(spots))


def spot(x, y, task=None, priority=50.0, service=70.0) -> TruthSpot:
    return TruthSpot((x, y, 0.0), priority, service, task)


def test_a_spot_exactly_at_the_detect_radius_is_seen_and_one_beyond_is_not():
    w = World(reef([spot(100.0, 25.0), spot(200.0, 25.01)]), seed=1, vehicle=0)
    w.sweep((0.0, 0.0, 0.0))
    seen = w.sweep((300.0, 0.0, 0.0))
    assert [s.pos for s in seen] == [(100.0, 25.0, 0.0)]


@pytest.mark.parametrize("p, expected", [(0.0, 0), (1.0, 40)])
def test_p_detect_zero_never_sees_and_one_always_sees(p, expected):
    # 40 spots along the track, each passed once
    w = World(reef([spot(20.0 * i, 5.0) for i in range(40)], p_detect=p), seed=3, vehicle=1)
    w.sweep((-50.0, 0.0, 0.0))
    assert len(w.sweep((900.0, 0.0, 0.0))) == expected


def test_each_pass_draws_once_and_the_draws_do_not_depend_on_step_times():
    spots = [spot(float(x), float(y)) for x, y in
             np.random.default_rng(0).uniform(0, 400, size=(30, 2))]
    track = [(0.0, 0.0, 0.0), (400.0, 400.0, 0.0), (0.0, 400.0, 0.0), (400.0, 0.0, 0.0)]
    coarse = World(reef(spots, p_detect=0.5), seed=7, vehicle=2)
    fine = World(reef(spots, p_detect=0.5), seed=7, vehicle=2)
    got_coarse, got_fine = [], []
    for a, b in zip(track[:-1], track[1:]):
        got_coarse += coarse.sweep(a) + coarse.sweep(b)
        for f in np.linspace(0.0, 1.0, 97):  # the same track in many small steps
            got_fine += fine.sweep(tuple(a[i] + (b[i] - a[i]) * f for i in range(3)))
    key = lambda s: s.pos  # noqa: E731 - within one step, order is by spot, not by time
    assert got_coarse and sorted(got_coarse, key=key) == sorted(got_fine, key=key)
    assert (coarse._passes == fine._passes).all()
    # a pass is one draw: p_detect 0.5 over many passes sees some and misses some
    assert 0 < len(got_coarse) < int(coarse._passes.sum())


def test_leaving_and_coming_back_is_a_new_pass_with_its_own_draw():
    w = World(reef([spot(0.0, 0.0)], p_detect=0.5), seed=11, vehicle=0)
    results = []
    for k in range(40):
        w.sweep((100.0, 0.0, 0.0))
        results.append(bool(w.sweep((0.0, 0.0, 0.0))))
    assert int(w._passes[0]) == 40
    assert results == [pass_seen(11, 0, 0, k + 1, 0.5) for k in range(40)]
    assert 5 < sum(results) < 35


def test_inspection_says_what_the_truth_holds():
    w = World(reef([spot(0.0, 0.0, task=1, priority=42.0, service=66.0)]), seed=0, vehicle=0)
    assert w.inspect(0).present is False
    found = w.inspect(1)
    assert found.present and found.priority == 42.0 and found.service_s == 66.0


def test_segment_distance():
    pts = np.array([[5.0, 3.0, 0.0], [-4.0, 3.0, 0.0], [14.0, 0.0, 0.0]])
    d = segment_distance_m((0.0, 0.0, 0.0), (10.0, 0.0, 0.0), pts)
    np.testing.assert_allclose(d, [3.0, 5.0, 4.0])


# -- the vehicle's inspecting phase ---------------------------------------------------------


def line_problem() -> Problem:
    tasks = [Task(10, (100.0, 0.0, 0.0), 50.0, 80.0), Task(11, (200.0, 0.0, 0.0), 50.0, 80.0)]
    return Problem.build("line", [VehicleSpec("auv1", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                                              3600.0, 1.0)], tasks)


def run(v: Vehicle, until: float) -> list:
    events = []
    while True:
        due = v.next_event_s()
        if due is None or due > until:
            break
        events += v.advance(due)
    events += v.advance(until)
    return events


def test_an_empty_spot_costs_the_look_and_nothing_more():
    v = Vehicle(line_problem(), 0)
    v.needs_look, v.inspect_s = (lambda t: True), 20.0
    v.set_route([0, 1])
    assert v.advance(100.0) == [] and v.mode == INSPECTING and v.inspecting == 0
    assert v.next_event_s() == 120.0
    v.reveal(0, None)
    events = v.advance(120.0)
    assert events == [Inspected(0, 120.0, False, False)] and v.mode == TRANSIT
    assert v.route == [1]


def test_a_present_spot_is_injected_for_its_real_time():
    v = Vehicle(line_problem(), 0)
    v.needs_look, v.inspect_s = (lambda t: True), 20.0
    v.set_route([0])
    v.advance(100.0)
    v.reveal(0, 33.0)  # the camera: COTS, 33 s of injection (the map said 80)
    assert math.isclose(v.time_to_finish_s(), 20.0 + 33.0 + 100.0)
    events = run(v, 160.0)
    assert events == [Inspected(0, 120.0, True, True), Cleared(0, 153.0)]


def test_without_the_cameras_answer_the_vehicle_waits_at_the_spot():
    v = Vehicle(line_problem(), 0)
    v.needs_look, v.inspect_s = (lambda t: True), 20.0
    v.set_route([0])
    v.advance(100.0)
    assert v.advance(500.0) == [] and v.mode == INSPECTING and v.next_event_s() is None
    v.reveal(0, 10.0)
    assert v.advance(500.0) == [Inspected(0, 500.0, True, True)] and v.mode == INJECTING


def test_cots_beyond_the_battery_are_left_for_others():
    v = Vehicle(line_problem(), 0)
    v.needs_look, v.inspect_s = (lambda t: True), 20.0
    v.set_route([0])
    v.advance(100.0)
    v.reveal(0, 3500.0)
    assert v.advance(120.0) == [Inspected(0, 120.0, True, False)] and v.route == []


def test_a_known_spot_is_injected_at_once_as_before():
    v = Vehicle(line_problem(), 0)
    v.set_route([0])
    assert run(v, 200.0) == [Cleared(0, 180.0)]
