"""The simulated vehicle (eq. 3-7) behind the vehicle port: exact kinematics, station
keeping, redirection, aborts, and what it refuses."""

from __future__ import annotations

import math

import pytest

from fleet_bus.vehicle_port import (HOME_TARGET, Abort, Arrived, GoTo, Injected, NavFix,
                                    Refused, ReturnHome, StationKeep, Work)
from hfc_core.model.problem import Problem, Task, Vehicle as Spec
from reef_sim.vehicle import Phase, SimVehicle, fly


def small_problem(battery_s: float = 3600.0) -> Problem:
    tasks = [Task(1, (100.0, 0.0, -10.0), 50.0, 60.0), Task(2, (100.0, 100.0, -10.0), 20.0, 90.0),
             Task(3, (0.0, 100.0, 0.0), 70.0, 75.0), Task(4, (500.0, 500.0, -5.0), 10.0, 60.0)]
    spec = Spec("auv1", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), battery_s, 1.0)
    return Problem.build("small", [spec], tasks)


def spot(p: Problem, task: int) -> tuple[float, float, float]:
    return tuple(float(c) for c in p.xyz[task])  # type: ignore[return-value]


def test_a_replayed_plan_takes_exactly_the_planned_mission_time() -> None:
    p = small_problem()
    events = fly(p, 0, [0, 1, 2])
    assert [type(e) for e in events] == [Injected, Injected, Injected, Arrived]
    assert [e.task for e in events[:3]] == [0, 1, 2]
    assert events[-1].t_s == pytest.approx(p.route_time_s(0, [0, 1, 2]), abs=1e-6)


@pytest.mark.parametrize("step_s", [0.37, 5.0, 61.0])
def test_reports_do_not_depend_on_how_often_the_vehicle_is_polled(step_s: float) -> None:
    p = small_problem()
    legs = [math.dist(a, b) for a, b in zip([(0, 0, 0), *p.xyz[[0, 1]]], p.xyz[[0, 1]])]
    v = SimVehicle(p, 0)
    v.command(GoTo(0, (spot(p, 0),)), 0.0)
    reports, t = [], 0.0
    while t < 400.0:
        t += step_s
        reports += [r for r in v.poll(t) if not isinstance(r, NavFix)]
    assert reports == [Arrived(pytest.approx(legs[0]), 0)]
    assert v.odometer_m == pytest.approx(legs[0])
    v.command(GoTo(1, (spot(p, 1),)), t)  # on from where it waits, whenever told
    assert [r for r in v.poll(t + legs[1]) if not isinstance(r, NavFix)] == \
        [Arrived(pytest.approx(t + legs[1]), 1)]
    assert v.odometer_m == pytest.approx(sum(legs))


def test_station_keeping_ends_with_the_report_of_the_work() -> None:
    p = small_problem()
    v = SimVehicle(p, 0, pos=spot(p, 0))
    v.command(StationKeep(Work.INJECT, 0, 60.0), 0.0)
    assert v.next_report_s() == 60.0 and v.phase is Phase.WORKING
    assert [r for r in v.poll(59.0) if not isinstance(r, NavFix)] == []
    assert [r for r in v.poll(100.0) if not isinstance(r, NavFix)] == [Injected(60.0, 0)]
    v.command(StationKeep(Work.WAIT, 1, 30.0), 100.0)  # a wait is ended by the next order
    assert v.next_report_s() is None and v.phase is Phase.HOLDING


def test_heading_follows_the_motion_and_the_fix_says_where_it_is() -> None:
    p = small_problem()
    v = SimVehicle(p, 0)
    v.command(GoTo(1, (spot(p, 1),)), 0.0)
    fix = v.poll(10.0)[-1]
    # toward (100, 100, -10) from the origin: yaw 45 deg (eq. 5), nose down (eq. 6)
    assert isinstance(fix, NavFix) and fix.t_s == 10.0
    assert fix.yaw_deg == pytest.approx(45.0)
    assert fix.pitch_deg == pytest.approx(math.degrees(math.atan2(10.0, math.hypot(100, 100))))
    assert math.dist(fix.pos, (0, 0, 0)) == pytest.approx(10.0) and fix.speed_mps == 1.0


def test_a_new_target_mid_leg_redirects_and_work_left_is_never_reported() -> None:
    p = small_problem()
    v = SimVehicle(p, 0)
    v.command(GoTo(0, (spot(p, 0),)), 0.0)
    due = v.next_report_s()
    assert due is not None
    arrival = v.poll(due)[0]
    assert isinstance(arrival, Arrived) and arrival.t_s == due
    v.command(StationKeep(Work.INJECT, 0, 60.0), arrival.t_s)
    v.poll(arrival.t_s + 50.0)
    v.command(GoTo(1, (spot(p, 1),)), arrival.t_s + 50.0)  # cleared by another: leave it
    reports = [r for r in v.poll(arrival.t_s + 140.0) if not isinstance(r, NavFix)]
    assert reports == [] and math.dist(v.pos, spot(p, 0)) == pytest.approx(90.0)


def test_the_same_target_again_does_not_restart_the_leg() -> None:
    p = small_problem()
    v = SimVehicle(p, 0)
    v.command(GoTo(3, (spot(p, 3),)), 0.0)
    end = v.next_report_s()
    v.poll(40.0)
    v.command(GoTo(3, (spot(p, 3),), ahead=(spot(p, 0),)), 40.0)
    assert v.next_report_s() == end and v.ahead == (spot(p, 0),)


def test_abort_returns_home_or_surfaces_and_a_recovered_vehicle_refuses_orders() -> None:
    p = small_problem()
    v = SimVehicle(p, 0)
    v.command(GoTo(3, (spot(p, 3),)), 0.0)
    v.poll(50.0)
    v.command(Abort(((0.0, 0.0, 0.0),)), 50.0)
    assert [r for r in v.poll(1000.0) if not isinstance(r, NavFix)] == \
        [Arrived(pytest.approx(100.0), HOME_TARGET)]
    assert v.phase is Phase.HOME
    v.command(GoTo(0, (spot(p, 0),)), 1000.0)
    refused = v.poll(1001.0)[0]
    assert isinstance(refused, Refused) and refused.command == "GoTo"
    w = SimVehicle(p, 0)
    w.command(ReturnHome(((0.0, 0.0, 0.0),)), 0.0)
    w.command(Abort((), surface=True), 0.0)
    assert w.poll(0.0)[0] == Arrived(0.0, HOME_TARGET) and w.phase is Phase.HOME


def test_a_look_without_a_camera_is_refused() -> None:
    p = small_problem()
    v = SimVehicle(p, 0)
    v.command(StationKeep(Work.LOOK, 0, 20.0), 0.0)
    refused = v.poll(1.0)[0]
    assert isinstance(refused, Refused) and "camera" in refused.reason


def test_the_same_target_somewhere_else_is_a_new_leg_and_the_same_goal_flies_on():
    p = small_problem()
    v = SimVehicle(p, 0)
    v.command(GoTo(0, ((50.0, 0.0, -10.0), spot(p, 0))), 0.0)
    v.poll(30.0)
    v.command(GoTo(0, (spot(p, 0),), ahead=(spot(p, 1),)), 30.0)  # a new path, same goal
    assert v._waypoints == [(50.0, 0.0, -10.0), spot(p, 0)] and v.ahead == (spot(p, 1),)
    moved = (100.0, 12.0, -10.0)  # its camera saw the spot here
    v.command(GoTo(0, (moved,)), 30.0)
    got = [r for r in v.poll(500.0) if isinstance(r, Arrived)]
    assert got and v.pos == pytest.approx(moved)
