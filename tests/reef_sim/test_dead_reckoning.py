"""The simulated vehicle's navigation error (`reef_sim.navigation`) and what the vehicle does
with it: estimates that drift as a percent of the distance run, fixes, steering in the
estimate's frame, sightings and looks at the true position."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fleet_bus.vehicle_port import (Arrived, GoTo, Injected, Looked, NavFix, Sighted, StationKeep,
                                    Work)
from hfc_core.model.errors import ScenarioError
from hfc_core.model.problem import Problem, Task, Vehicle as Spec
from reef_sim.camera import ReefCamera
from reef_sim.navigation import (DeadReckoning, NavigationParams, navigation_from_doc,
                                 vehicle_seed)
from reef_sim.truth import Reef, TruthSpot
from reef_sim.vehicle import SimVehicle

EXACT = NavigationParams(drift_pct=0.0, walk_m_per_sqrt_km=0.0, start_sigma_m=0.0,
                         camera_sigma_m=0.0)
BIASES_ONLY = NavigationParams(drift_pct=1.0, walk_m_per_sqrt_km=0.0, start_sigma_m=0.0,
                               camera_sigma_m=0.0)


def field(tasks=((500.0, 0.0, -5.0),)) -> Problem:
    spec = Spec("auv1", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 7200.0, 1.0)
    return Problem.build("nav", [spec], [Task(i, p, 50.0, 60.0) for i, p in enumerate(tasks)])


def reports(v: SimVehicle, until_s: float, step_s: float) -> list:
    out, t = [], v.t_s
    while t < until_s:
        t = min(until_s, t + step_s)
        out += v.poll(t)
    return out


# -- the section ------------------------------------------------------------------------------


def test_no_section_is_exact_navigation_and_a_section_takes_its_defaults():
    assert navigation_from_doc({"name": "x"}) is None
    assert navigation_from_doc({"navigation": None}) is None
    assert navigation_from_doc({"navigation": {}}) == NavigationParams()
    got = navigation_from_doc({"navigation": {"drift_pct": 0.3, "fix_period_s": 600}})
    assert got == NavigationParams(drift_pct=0.3, fix_period_s=600.0)
    assert navigation_from_doc({"navigation": got.to_dict()}) == got
    # every field is read, each into its own place
    every = NavigationParams(*(0.5 + i for i in range(len(NavigationParams().to_dict()))))
    assert navigation_from_doc({"navigation": every.to_dict()}) == every


@pytest.mark.parametrize("section, message", [
    ({"drift_pct": -1}, "navigation.drift_pct: must be >= 0"),
    ({"drift_pct": "1%"}, "navigation.drift_pct: expected a finite number"),
    ({"fix_sigma_m": math.inf}, "navigation.fix_sigma_m: expected a finite number"),
    ({"fix_period_s": 0}, "navigation.fix_period_s: must be > 0 or null"),
    ({"drift_pct": None}, "navigation.drift_pct: expected a finite number, got null"),
    ({"drift": 1.0}, "navigation: unknown field(s) drift"),
    ([1.0], "navigation: expected an object"),
])
def test_a_bad_section_names_its_field(section, message):
    with pytest.raises(ScenarioError, match=message.replace("(", r"\(").replace(")", r"\)")):
        navigation_from_doc({"navigation": section})


def test_each_vehicle_draws_from_its_spawned_child_whatever_the_fleet_size():
    for n in (3, 8):
        children = np.random.SeedSequence([0x4E41, 42]).spawn(n)
        for i in (0, 2):
            assert vehicle_seed(42, i).generate_state(4).tolist() == \
                children[i].generate_state(4).tolist()
    a = DeadReckoning(BIASES_ONLY, 42, 0, (0.0, 0.0, 0.0))
    b = DeadReckoning(BIASES_ONLY, 42, 1, (0.0, 0.0, 0.0))
    c = DeadReckoning(BIASES_ONLY, 42, 0, (0.0, 0.0, 0.0))
    assert (a.scale, a.heading_rad) == (c.scale, c.heading_rad) != (b.scale, b.heading_rad)


# -- the model --------------------------------------------------------------------------------


def test_a_straight_run_is_off_by_drift_pct_of_its_length_per_axis():
    """Over many vehicles the error after a straight 500 m run has a per-axis spread of 1 %
    of 500 m, and the vehicle says so."""
    run = (500.0, 0.0, 0.0)
    errors = np.array([DeadReckoning(BIASES_ONLY, seed, 0, (0.0, 0.0, 0.0)).error(run, 500.0)
                       for seed in range(4000)])
    assert errors.std(axis=0) == pytest.approx([5.0, 5.0], rel=0.06)
    assert errors.mean(axis=0) == pytest.approx([0.0, 0.0], abs=0.3)
    nav = DeadReckoning(BIASES_ONLY, 7, 0, (0.0, 0.0, 0.0))
    assert nav.sigma_m(run, 500.0) == pytest.approx(5.0, rel=0.03)  # of its estimate's run


def test_the_random_walk_grows_with_the_square_root_of_the_distance():
    walk = NavigationParams(drift_pct=0.0, walk_m_per_sqrt_km=2.0, start_sigma_m=0.0)
    ends = np.array([DeadReckoning(walk, seed, 0, (0.0, 0.0, 0.0)).walk(4000.0)
                     for seed in range(1500)])
    assert ends.std(axis=0) == pytest.approx([4.0, 4.0], rel=0.08)  # 2 m x sqrt(4 km)
    nav = DeadReckoning(walk, 3, 0, (0.0, 0.0, 0.0))
    assert nav.sigma_m((0.0, 0.0, 0.0), 4000.0) == pytest.approx(4.0)
    # continuous between metres, and the same whatever order it is asked in
    assert nav.walk(1023.5) == pytest.approx((nav.walk(1023.0) + nav.walk(1024.0)) / 2)
    fresh = DeadReckoning(walk, 3, 0, (0.0, 0.0, 0.0))
    assert fresh.walk(3000.0).tolist() == nav.walk(3000.0).tolist()


def test_a_fix_is_a_kalman_update_and_the_drift_starts_again_from_it():
    params = NavigationParams(drift_pct=2.0, walk_m_per_sqrt_km=0.0, start_sigma_m=0.0,
                              fix_period_s=300.0, fix_sigma_m=2.0)
    nav = DeadReckoning(params, 5, 0, (0.0, 0.0, 0.0))
    there = (800.0, 0.0, 0.0)
    before, prior = np.array(nav.error(there, 800.0)), nav.sigma_m(there, 800.0) ** 2
    assert nav.next_fix_s(0.0) == 300.0 and nav.next_fix_s(300.0) == 600.0
    nav.fix(300.0, there, 800.0)
    assert nav.sigma_m(there, 800.0) ** 2 == pytest.approx(prior * 4.0 / (prior + 4.0))
    gain = prior / (prior + 4.0)
    nu = (np.array(nav.error(there, 800.0)) - (1 - gain) * before) / gain
    assert np.all(np.abs(nu) < 4 * 2.0)  # the fix's own noise, within 4 sigma
    # standing still adds nothing; running on adds the biases' share of the new run only
    assert nav.error(there, 800.0) == nav.error(there, 800.0)
    grown = np.array(nav.error((900.0, 0.0, 0.0), 900.0)) - np.array(nav.error(there, 800.0))
    assert grown == pytest.approx([nav.scale * 100.0, nav.heading_rad * 100.0])
    exact_fix = DeadReckoning(NavigationParams(fix_period_s=60.0, fix_sigma_m=0.0), 5, 0,
                              (0.0, 0.0, 0.0))
    exact_fix.fix(60.0, there, 800.0)
    assert exact_fix.error(there, 800.0) == (0.0, 0.0)
    assert exact_fix.sigma_m(there, 800.0) == 0.0


# -- the vehicle ------------------------------------------------------------------------------


def test_the_vehicle_flies_until_its_estimate_reads_the_waypoint():
    p = field()
    nav = DeadReckoning(BIASES_ONLY, 11, 0, (0.0, 0.0, 0.0))
    v = SimVehicle(p, 0, navigation=nav)
    goal = (500.0, 0.0, -5.0)
    v.command(GoTo(0, (goal,)), 0.0)
    got = reports(v, 2000.0, 37.0)
    arrived = [r for r in got if isinstance(r, Arrived)]
    fix = got[-1]
    assert len(arrived) == 1 and isinstance(fix, NavFix)
    assert fix.pos == pytest.approx(goal, abs=1e-6)  # where it believes it is: the waypoint
    off = math.dist(v.pos, goal)
    assert off > 0.5  # really off by its navigation error: 1 % of ~500 m, per axis
    assert off == pytest.approx(math.hypot(*nav.error(v.pos, v.odometer_m)), rel=1e-6)
    assert fix.sigma_m == pytest.approx(0.01 * 500.0, rel=1e-3)
    # it ran the true leg at its speed: arrival dated by the true distance
    assert arrived[0].t_s == pytest.approx(math.dist((0.0, 0.0, 0.0), v.pos), rel=1e-9)


@pytest.mark.parametrize("step_s", [0.7, 13.0, 250.0])
def test_with_fixes_what_the_vehicle_reports_does_not_depend_on_polling(step_s):
    params = NavigationParams(drift_pct=1.5, fix_period_s=200.0, fix_sigma_m=1.0)
    p = field(((300.0, 200.0, -5.0), (-200.0, 400.0, -3.0)))

    def run(step: float) -> tuple[list, tuple]:
        v = SimVehicle(p, 0, navigation=DeadReckoning(params, 3, 0, (0.0, 0.0, 0.0)))
        v.command(GoTo(0, ((300.0, 200.0, -5.0), (-200.0, 400.0, -3.0))), 0.0)
        out = [r for r in reports(v, 1500.0, step) if not isinstance(r, NavFix)]
        return out, v.pos

    base, pos = run(1500.0)
    got, pos_step = run(step_s)
    assert [type(r) for r in got] == [type(r) for r in base] == [Arrived]
    assert got[0].t_s == pytest.approx(base[0].t_s, abs=1e-6)
    assert pos_step == pytest.approx(pos, abs=1e-6)


def test_a_fix_under_way_is_due_as_a_report_and_steers_the_flight_again():
    params = NavigationParams(drift_pct=3.0, walk_m_per_sqrt_km=0.0, start_sigma_m=0.0,
                              fix_period_s=100.0, fix_sigma_m=0.0)
    goal = (500.0, 0.0, -5.0)
    off = {}
    for name, p in (("fixes", params), ("none", NavigationParams(**{**params.to_dict(),
                                                                     "fix_period_s": None}))):
        v = SimVehicle(field(), 0, navigation=DeadReckoning(p, 9, 0, (0.0, 0.0, 0.0)))
        v.command(GoTo(0, (goal,)), 0.0)
        if name == "fixes":
            assert v.next_report_s() == 100.0  # the fix, before the arrival
            v.poll(100.0)
            assert v.navigation.error(v.pos, v.odometer_m) == (0.0, 0.0)  # an exact fix
            after = v.pos
        got = v.poll(v.next_report_s())
        while not any(isinstance(r, Arrived) for r in got):
            got = v.poll(v.next_report_s())  # each fix is a report time, then the arrival
        assert got[-1].pos == pytest.approx(goal, abs=1e-6)  # where it believes it is
        off[name] = math.dist(v.pos, goal)
    # with a fix every 100 s only the run since the last one drifts: 3 % of under 100 m
    assert off["fixes"] < 0.03 * 100.0 * 3 and off["fixes"] < off["none"] / 3
    assert math.dist(after, (100.0, 0.0, -1.0)) < 3.0


def test_a_waypoint_at_the_surface_gives_a_gps_fix_whatever_the_polling():
    """A climb to the surface is a GPS fix (start_sigma_m): the error falls to about it, the
    flight is steered again from there, and its time is a report time, so what the vehicle
    reports does not depend on how often it is polled."""
    params = NavigationParams(drift_pct=3.0, walk_m_per_sqrt_km=0.0, start_sigma_m=1.0)
    p = field(((600.0, 0.0, -8.0),))
    up, goal = (400.0, 0.0, 0.0), (600.0, 0.0, -8.0)

    def run(step_s: float) -> tuple[SimVehicle, list, list[float]]:
        v = SimVehicle(p, 0, navigation=DeadReckoning(params, 4, 0, (0.0, 0.0, 0.0)))
        v.command(GoTo(0, ((400.0, 0.0, -8.0), goal)), 0.0)
        v.poll(300.0)
        before = v.fix().sigma_m
        v.command(GoTo(0, (up, goal)), 300.0)  # the same target, a climb added: a new leg
        due = [v.next_report_s()]
        out = [r for r in reports(v, 2000.0, step_s) if not isinstance(r, NavFix)]
        return v, out, [before, *due]

    v, got, (before, due) = run(2000.0)
    assert before > 5.0  # 3 % of 300 m per axis
    assert v.navigation is not None and v.navigation.fixes == 1  # the climb's
    stepped, got_step, _ = run(7.0)
    assert [type(r) for r in got_step] == [type(r) for r in got] == [Arrived]
    # the surface is a report time of its own, well before the arrival (its fix steers the rest)
    assert due < got[0].t_s - 100.0
    assert got_step[0].t_s == pytest.approx(got[0].t_s, abs=1e-6)
    assert stepped.pos == pytest.approx(v.pos, abs=1e-6)
    # without the climb the same vehicle ends farther off its goal, and knows it
    plain = SimVehicle(p, 0, navigation=DeadReckoning(params, 4, 0, (0.0, 0.0, 0.0)))
    plain.command(GoTo(0, ((400.0, 0.0, -8.0), goal)), 0.0)
    reports(plain, 2000.0, 2000.0)
    assert math.dist(v.pos, goal) < math.dist(plain.pos, goal)
    # the GPS fix's 1 m, then 3 % of the ~200 m run from the surface; 3 % of 600 m without
    assert v.fix().sigma_m < 0.03 * 220.0 < plain.fix().sigma_m / 2


def test_a_sighting_is_the_truth_moved_by_the_navigation_error_where_the_pass_began():
    p = field()
    reef = Reef(25.0, 1.0, 20.0, (TruthSpot((250.0, 20.0, -6.0), 40.0, 70.0, None),))
    params = NavigationParams(drift_pct=2.0, walk_m_per_sqrt_km=1.0, start_sigma_m=0.5,
                              camera_sigma_m=0.3)
    nav = DeadReckoning(params, 21, 0, (0.0, 0.0, 0.0))
    v = SimVehicle(p, 0, camera=ReefCamera(reef, 21, 0), navigation=nav)
    v.command(GoTo(0, ((500.0, 0.0, -5.0),)), 0.0)
    seen = [r for r in reports(v, 700.0, 41.0) if isinstance(r, Sighted)]
    assert len(seen) == 1
    # the pass began where the true track first came within 25 m of the spot
    entry = ReefCamera(reef, 21, 0)
    entry.sweep((0.0, 0.0, 0.0))
    (s,) = entry.sweep(v.pos)
    ex, ey = nav.error(s.at, math.dist((0.0, 0.0, 0.0), s.at))
    cx, cy = nav.camera_error(0, 1)
    assert seen[0].pos == pytest.approx((250.0 + ex + cx, 20.0 + ey + cy, -6.0), abs=1e-6)
    assert math.hypot(ex, ey) > 0.1 and 0 < math.hypot(cx, cy) < 2.0


def test_a_look_sees_the_predicted_aggregation_only_within_its_footprint_of_the_truth():
    p = field()
    reef = Reef(25.0, 1.0, 20.0, (TruthSpot((500.0, 0.0, -5.0), 40.0, 70.0, 0),),
                look_radius_m=4.0)
    big_drift = NavigationParams(drift_pct=5.0, walk_m_per_sqrt_km=0.0, start_sigma_m=0.0)
    outcomes = {}
    for name, params, seed in (("exact", None, 0), ("drift", big_drift, 2)):
        nav = None if params is None else DeadReckoning(params, seed, 0, (0.0, 0.0, 0.0))
        v = SimVehicle(p, 0, camera=ReefCamera(reef, seed, 0), navigation=nav)
        v.command(GoTo(0, ((500.0, 0.0, -5.0),)), 0.0)
        assert any(isinstance(r, Arrived) for r in reports(v, 1000.0, 100.0))
        v.command(StationKeep(Work.LOOK, 0, 20.0), v.t_s)
        look = next(r for r in v.poll(v.t_s + 30.0) if isinstance(r, Looked))
        outcomes[name] = (look.present, math.dist(v.pos[:2], (500.0, 0.0)))
    assert outcomes["exact"] == (True, 0.0)
    present, off = outcomes["drift"]
    assert off > 4.0 and present is False  # 5 % of 500 m: it looked at the wrong place


def test_the_world_books_what_an_injection_really_treated():
    p = field(((500.0, 0.0, -5.0), (0.0, 300.0, -5.0)))
    reef = Reef(25.0, 1.0, 20.0, (TruthSpot((500.0, 0.0, -5.0), 40.0, 70.0, 0),
                                  TruthSpot((8.0, 300.0, -5.0), 30.0, 60.0, None)))
    v = SimVehicle(p, 0, camera=ReefCamera(reef, 0, 0), pos=(500.0, 0.0, -5.0))
    v.command(StationKeep(Work.INJECT, 0, 60.0), 0.0)
    v.poll(60.0)
    v.command(GoTo(1, ((0.0, 300.0, -5.0),)), 60.0)  # a predicted spot that is empty...
    assert any(isinstance(r, Arrived) for r in reports(v, 2000.0, 50.0))
    v.command(StationKeep(Work.INJECT, 1, 60.0), v.t_s)
    v.poll(v.t_s + 60.0)
    v.command(StationKeep(Work.INJECT, 7, 60.0), v.t_s)  # a find, by position
    v.poll(v.t_s + 60.0)
    # ...with an unmapped aggregation 8 m off: the vehicle treated that one
    assert [(t.task, t.spot) for t in v.treatments] == [(0, 0), (1, 1), (7, 1)]


def test_an_injection_reports_where_and_what_its_camera_measured_it_treated():
    """`Injected` carries the treated aggregation's position and rho (the agent holds a
    find's or a look's rho against it: `discovery.treated_elsewhere`); bare seabed says
    neither."""
    p = field(((500.0, 0.0, -5.0), (0.0, 300.0, -5.0)))
    reef = Reef(25.0, 1.0, 20.0, (TruthSpot((8.0, 300.0, -5.0), 30.0, 60.0, None),))
    v = SimVehicle(p, 0, camera=ReefCamera(reef, 0, 0), pos=(0.0, 300.0, -5.0))
    v.command(StationKeep(Work.INJECT, 1, 60.0), 0.0)
    (done,) = [r for r in v.poll(60.0) if isinstance(r, Injected)]
    assert done == Injected(60.0, 1, (8.0, 300.0, -5.0), 30.0)
    bare = SimVehicle(p, 0, camera=ReefCamera(reef, 0, 0), pos=(500.0, 0.0, -5.0))
    bare.command(StationKeep(Work.INJECT, 0, 60.0), 0.0)
    assert [r for r in bare.poll(60.0) if isinstance(r, Injected)] == [Injected(60.0, 0)]


def test_an_injection_priority_needs_its_position_and_a_sane_value():
    with pytest.raises(ValueError, match="needs the position"):
        Injected(1.0, 0, None, 30.0)
    for bad in (-1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="priority"):
            Injected(1.0, 0, (0.0, 0.0, 0.0), bad)


def test_zero_error_navigation_reports_exactly_what_exact_navigation_does():
    p = field(((300.0, 200.0, -5.0), (-200.0, 400.0, -3.0)))
    reef = Reef(25.0, 0.8, 20.0, (TruthSpot((310.0, 190.0, -5.0), 40.0, 70.0, 0),
                                  TruthSpot((100.0, 300.0, -4.0), 30.0, 60.0, None)))
    runs = []
    for nav in (None, DeadReckoning(EXACT, 4, 0, (0.0, 0.0, 0.0))):
        v = SimVehicle(p, 0, camera=ReefCamera(reef, 4, 0), navigation=nav)
        v.command(GoTo(0, ((300.0, 200.0, -5.0),)), 0.0)
        out = reports(v, 400.0, 29.0)
        v.command(StationKeep(Work.LOOK, 0, 20.0), v.t_s)
        out += reports(v, 430.0, 29.0)
        v.command(GoTo(1, ((0.0, 300.0, -3.0), (-200.0, 400.0, -3.0))), v.t_s)
        out += reports(v, 1400.0, 29.0)
        runs.append(out)
    assert runs[0] == runs[1]
