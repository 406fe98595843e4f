"""The vehicle model (eq. 3-7): exact kinematics, injections, battery, redirection."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fleet_agent.vehicle import (HOME, INJECTING, RETURNING, TRANSIT, WAITING, Arrived, Cleared,
                                 Vehicle, fit_route, position_along)
from hfc_core.model.problem import Problem, Task, Vehicle as Spec


def small_problem(battery_s: float = 3600.0) -> Problem:
    tasks = [Task(1, (100.0, 0.0, -10.0), 50.0, 60.0), Task(2, (100.0, 100.0, -10.0), 20.0, 90.0),
             Task(3, (0.0, 100.0, 0.0), 70.0, 75.0), Task(4, (500.0, 500.0, -5.0), 10.0, 60.0)]
    spec = Spec("auv1", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), battery_s, 1.0)
    return Problem.build("small", [spec], tasks)


def run_to_end(v: Vehicle, step_s: float) -> list:
    events, t = [], 0.0
    while not v.done and t < 10_000:
        t += step_s
        events += v.advance(t)
    return events


@pytest.mark.parametrize("step_s", [0.37, 5.0, 61.0, 10_000.0])
def test_route_takes_exactly_the_planned_mission_time(step_s: float) -> None:
    p = small_problem()
    v = Vehicle(p, 0)
    v.set_route([0, 1, 2])
    events = run_to_end(v, step_s)
    assert [type(e) for e in events] == [Cleared, Cleared, Cleared, Arrived]
    assert [e.task for e in events[:3]] == [0, 1, 2]
    planned = p.route_time_s(0, [0, 1, 2])
    assert events[-1].t_s == pytest.approx(planned, abs=1e-6)
    assert v.home_at_s == pytest.approx(planned, abs=1e-6)
    assert v.battery_left_s(99_999.0) == pytest.approx(3600.0 - planned, abs=1e-6)
    legs = [math.dist(a, b) for a, b in zip([(0, 0, 0), *p.xyz[[0, 1, 2]], (0, 0, 0)],
                                               [*p.xyz[[0, 1, 2]], (0, 0, 0)])]
    assert v.distance_m == pytest.approx(sum(legs), abs=1e-6)  # eq. 7 summed over legs


@pytest.mark.parametrize("step_s", [0.37, 7.0, 10_000.0])
def test_a_spot_not_yet_settled_is_waited_for_then_worked(step_s: float) -> None:
    """Spot 0 (100.5 s away, 60 s of injection) may not be worked before t = 130 s (a claim
    settling): the vehicle hovers there until then, reported busy, and the wait is in its
    time to finish."""
    p = small_problem()
    v = Vehicle(p, 0)
    v.not_before = lambda task: 130.0 if task == 0 else 0.0
    v.set_route([0, 1])
    planned = p.route_time_s(0, [0, 1]) + 130.0 - math.dist((0, 0, 0), p.xyz[0])
    assert v.time_to_finish_s() == pytest.approx(planned)
    v.advance(110.0)
    assert v.mode == WAITING and v.injecting is None and v.state() == INJECTING
    assert v.next_event_s() == 130.0 and v.time_to_finish_s() == pytest.approx(planned - 110.0)
    w = Vehicle(p, 0)  # the same route from the start, advanced in steps of step_s
    w.not_before = v.not_before
    w.set_route([0, 1])
    events = run_to_end(w, step_s)
    assert [(type(e), getattr(e, "task", None)) for e in events] == [
        (Cleared, 0), (Cleared, 1), (Arrived, None)]
    assert events[0].t_s == pytest.approx(190.0, abs=1e-6)  # 130 s + 60 s, however stepped
    assert events[-1].t_s == pytest.approx(planned, abs=1e-6)


def test_a_vehicle_waiting_at_a_spot_leaves_it_when_the_spot_is_taken_away() -> None:
    p = small_problem()
    v = Vehicle(p, 0)
    v.not_before = lambda task: 130.0
    v.set_route([0])
    v.advance(120.0)
    assert v.mode == WAITING
    v.set_route([])  # a peer's earlier claim arrived: the spot is its own
    assert v.mode == RETURNING
    events = run_to_end(v, 5.0)
    assert [type(e) for e in events] == [Arrived]


def test_heading_follows_the_motion() -> None:
    p = small_problem()
    v = Vehicle(p, 0)
    v.set_route([1])
    v.advance(10.0)
    # toward (100, 100, -10) from the origin: yaw 45 deg (eq. 5), climbing nose-down (eq. 6)
    assert v.yaw_deg == pytest.approx(45.0)
    assert v.pitch_deg == pytest.approx(math.degrees(math.atan2(10.0, math.hypot(100, 100))))
    assert v.mode == TRANSIT
    assert math.dist(v.pos, (0, 0, 0)) == pytest.approx(10.0)


def test_redirect_mid_leg_and_abandoned_injection() -> None:
    p = small_problem()
    v = Vehicle(p, 0)
    v.set_route([0, 1])
    v.advance(150.0)  # 100 s to spot 0, then 50 s into its 60 s injection
    assert v.mode == INJECTING and v.injecting == 0
    v.set_route([1])  # spot 0 was cleared by someone else: leave it
    assert v.mode == TRANSIT
    events = v.advance(250.0)
    assert events == [] and math.dist(v.pos, p.xyz[0]) == pytest.approx(100.0)
    v.set_route([])
    assert v.mode == RETURNING
    events = run_to_end(v, 50.0)
    assert isinstance(events[-1], Arrived) and v.mode == HOME


def test_abort_heads_home_and_keeps_an_aborted_state() -> None:
    p = small_problem()
    v = Vehicle(p, 0)
    v.set_route([0, 1, 2])
    v.advance(50.0)
    v.abort()
    assert v.state() == "aborted" and v.route == []
    v.set_route([3])  # an aborted vehicle takes no work
    assert v.route == []
    events = run_to_end(v, 7.0)
    assert [type(e) for e in events] == [Arrived]
    assert events[0].t_s == pytest.approx(100.0)


def test_fit_route_drops_the_worst_spots_until_the_battery_suffices() -> None:
    p = small_problem(battery_s=700.0)
    v = Vehicle(p, 0)
    fitted = fit_route(v, [0, 1, 2, 3], reserve_s=0.0)
    assert 3 not in fitted  # far and worth little
    assert v.time_to_finish_s(fitted) <= 700.0
    assert fit_route(v, [0], 0.0) == [0]


def test_time_to_finish_is_what_advancing_takes() -> None:
    p = small_problem()
    for t0 in (0.0, 33.3, 130.0, 400.0):
        v = Vehicle(p, 0)
        v.set_route([0, 1, 2])
        v.advance(t0)
        predicted = v.time_to_finish_s()
        run_to_end_from = v.t_s
        events = []
        while not v.done:
            events += v.advance(v.t_s + 13.0)
        assert events[-1].t_s - run_to_end_from == pytest.approx(predicted, abs=1e-6)


def test_dead_reckoning_walks_the_route() -> None:
    p = small_problem()
    f = 50.0 / math.dist((0, 0, 0), p.xyz[0])  # 50 m along a 3-D leg (eq. 7)
    assert position_along(p, 0, (0.0, 0.0, 0.0), [0], 50.0) == \
        pytest.approx((100.0 * f, 0.0, -10.0 * f))
    # to spot 0, 60 s injecting, then 10 s toward the rendezvous
    arrive = math.dist((0, 0, 0), p.xyz[0])
    pos = position_along(p, 0, (0.0, 0.0, 0.0), [0], arrive + 70.0)
    assert np.linalg.norm(np.subtract(pos, p.xyz[0])) == pytest.approx(10.0)
