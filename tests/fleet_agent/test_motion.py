"""The agent's model of its own vehicle (`fleet_agent.motion`): it expects what the vehicle
does. Each test drives the simulated vehicle and the model together (`vehicle_loop.Loop`, as
the agent wires them), so a model that mistimes its vehicle fails here."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fleet_agent import motion
from fleet_agent.motion import Activity, Cleared, ReachedHome
from fleet_agent.reckoning import position_along
from fleet_agent.routing import fit_route
from fleet_bus.vehicle_port import NavFix
from hfc_core.model.paths import path_function
from hfc_core.model.problem import Problem, Task, Vehicle as Spec
from vehicle_loop import Loop, conduct


def small_problem(battery_s: float = 3600.0) -> Problem:
    tasks = [Task(1, (100.0, 0.0, -10.0), 50.0, 60.0), Task(2, (100.0, 100.0, -10.0), 20.0, 90.0),
             Task(3, (0.0, 100.0, 0.0), 70.0, 75.0), Task(4, (500.0, 500.0, -5.0), 10.0, 60.0)]
    spec = Spec("auv1", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), battery_s, 1.0)
    return Problem.build("small", [spec], tasks)


@pytest.mark.parametrize("step_s", [0.37, 5.0, 61.0, 10_000.0])
def test_route_takes_exactly_the_planned_mission_time(step_s: float) -> None:
    p = small_problem()
    loop = Loop(p)
    loop.set_route([0, 1, 2])
    events, t = [], 0.0
    while not loop.own.done and t < 10_000:
        t += step_s
        events += loop.run_until(t)
    assert [type(e) for e in events] == [Cleared, Cleared, Cleared, ReachedHome]
    assert [e.task for e in events[:3]] == [0, 1, 2]
    planned = p.route_time_s(0, [0, 1, 2])
    assert events[-1].t_s == pytest.approx(planned, abs=1e-6)
    assert loop.own.home_at_s == pytest.approx(planned, abs=1e-6)
    assert loop.own.battery_left_s(99_999.0) == pytest.approx(3600.0 - planned, abs=1e-6)
    legs = [math.dist(a, b) for a, b in zip([(0, 0, 0), *p.xyz[[0, 1, 2]], (0, 0, 0)],
                                               [*p.xyz[[0, 1, 2]], (0, 0, 0)])]
    assert loop.own.distance_m == pytest.approx(sum(legs), abs=1e-6)  # eq. 7 summed


@pytest.mark.parametrize("settle_s", [0.0, 150.0, 400.0, 1000.0])
def test_the_settle_bound_leaves_the_projection_as_it_was(settle_s: float) -> None:
    """`Conduct.settled_by` (no ``not_before`` is later) lets the projection stop asking once
    past it: a wait on the route's second spot counts as before (400 s and 1000 s make one),
    and a bound that is the latest settle changes nothing."""
    p = small_problem()
    late = {0: settle_s}
    asked: list[int] = []

    def not_before(task: int) -> float:
        asked.append(task)
        return late.get(task, 0.0)

    plain, bounded = (Loop(p, rules=conduct(not_before=not_before, settled_by=by))
                      for by in (None, lambda: settle_s))
    for loop in (plain, bounded):
        loop.set_route([1, 0, 2])
    asked.clear()
    expected = plain.own.time_to_finish_s()
    assert sorted(asked) == [0, 1, 2]  # every spot is asked without a bound
    asked.clear()
    assert bounded.own.time_to_finish_s() == pytest.approx(expected)
    # Past the first spot, a spot is asked only while the bound is ahead of the arrival:
    # spot 0 (reached at 331 s) under the bounds of 400 s and 1000 s; spot 2 never (it is
    # reached past any wait at spot 0).
    reach_0 = p.route_time_s(0, [1, 0]) - float(p.service_s[0]) - p.travel_s[0][0, p.end_node(0)]
    assert sorted(asked) == sorted([1, *([0] if reach_0 < settle_s else [])])


@pytest.mark.parametrize("step_s", [0.37, 7.0, 10_000.0])
def test_a_spot_not_yet_settled_is_waited_for_then_worked(step_s: float) -> None:
    """Spot 0 (100.5 s away, 60 s of injection) may not be worked before t = 130 s (a claim
    settling): the vehicle keeps station there until then, reported busy, and the wait is in
    its time to finish."""
    p = small_problem()
    rules = conduct(not_before=lambda task: 130.0 if task == 0 else 0.0)
    loop = Loop(p, rules=rules)
    loop.set_route([0, 1])
    planned = p.route_time_s(0, [0, 1]) + 130.0 - math.dist((0, 0, 0), p.xyz[0])
    assert loop.own.time_to_finish_s() == pytest.approx(planned)
    loop.run_until(110.0)
    own = loop.own
    assert own.activity is Activity.WAITING and own.injecting is None
    assert own.state() == "injecting" and own.busy_until_s == 130.0
    assert own.time_to_finish_s() == pytest.approx(planned - 110.0)
    other = Loop(p, rules=rules)  # the same route from the start, stepped every step_s
    other.set_route([0, 1])
    events, t = [], 0.0
    while not other.own.done:
        t += step_s
        events += other.run_until(t)
    assert [(type(e), getattr(e, "task", None)) for e in events] == [
        (Cleared, 0), (Cleared, 1), (ReachedHome, None)]
    assert events[0].t_s == pytest.approx(190.0, abs=1e-6)  # 130 s + 60 s, however stepped
    assert events[-1].t_s == pytest.approx(planned, abs=1e-6)


def test_a_wait_held_back_by_an_unproven_frame_is_judged_again_at_every_wake() -> None:
    """Spot 0 settles at 130 s; a frame not yet proven holds it back to 200 s at most
    (`Conduct.held_back`). Proven harmless at 150 s, the work begins then, not at 130 s (the
    vehicle was still waiting at its last wake) and not at 200 s."""
    p = small_problem()
    proven = {"at": math.inf}

    def held_back(task: int, settled_s: float) -> float:
        return 200.0 if loop.own.t_s < proven["at"] else 0.0

    loop = Loop(p, rules=conduct(not_before=lambda task: 130.0 if task == 0 else 0.0,
                                 held_back=held_back))
    loop.set_route([0, 1])
    loop.run_until(140.0)
    assert loop.own.activity is Activity.WAITING and loop.own.busy_until_s == 200.0
    loop.run_until(150.0)
    proven["at"] = 150.0  # the frame's key came in at 150 s
    loop.step(150.0)
    assert loop.own.activity is Activity.INJECTING
    events = loop.run_home()
    assert (type(events[0]), events[0].task) == (Cleared, 0)
    assert events[0].t_s == pytest.approx(150.0 + 60.0)  # begun at 150 s, its 60 s injection


def test_a_vehicle_waiting_at_a_spot_leaves_it_when_the_spot_is_taken_away() -> None:
    p = small_problem()
    loop = Loop(p, rules=conduct(not_before=lambda task: 130.0))
    loop.set_route([0])
    loop.run_until(120.0)
    assert loop.own.activity is Activity.WAITING
    loop.set_route([])  # a peer's earlier claim arrived: the spot is its own
    assert loop.own.activity is Activity.RETURNING
    assert [type(e) for e in loop.run_home()] == [ReachedHome]


def test_leaving_a_spot_mid_injection_abandons_it() -> None:
    p = small_problem()
    loop = Loop(p)
    loop.set_route([0, 1])
    loop.run_until(150.0)  # 100.5 s to spot 0, then into its 60 s injection
    assert loop.own.activity is Activity.INJECTING and loop.own.injecting == 0
    loop.set_route([1])  # spot 0 was cleared by someone else: leave it
    assert loop.own.activity is Activity.TRANSIT
    assert loop.run_until(250.0) == []
    assert math.dist(loop.own.pos, p.xyz[0]) == pytest.approx(100.0)
    loop.set_route([])
    events = loop.run_home()
    assert isinstance(events[-1], ReachedHome) and loop.own.done


def test_abort_heads_home_and_keeps_an_aborted_state() -> None:
    p = small_problem()
    loop = Loop(p)
    loop.set_route([0, 1, 2])
    loop.run_until(50.0)
    loop.abort()
    assert loop.own.state() == "aborted" and loop.own.route == []
    loop.set_route([3])  # an aborted vehicle takes no work
    assert loop.own.route == []
    events = loop.run_home()
    assert [type(e) for e in events] == [ReachedHome]
    assert events[0].t_s == pytest.approx(100.0)


def test_fit_route_drops_the_worst_spots_until_the_battery_suffices() -> None:
    p = small_problem(battery_s=700.0)
    own = Loop(p).own
    fitted = fit_route(own, [0, 1, 2, 3], reserve_s=0.0)
    assert 3 not in fitted  # far and worth little
    assert own.time_to_finish_s(fitted) <= 700.0
    assert fit_route(own, [0], 0.0) == [0]


def test_time_to_finish_is_what_the_vehicle_takes() -> None:
    p = small_problem()
    for t0 in (0.0, 33.3, 130.0, 400.0):
        loop = Loop(p)
        loop.set_route([0, 1, 2])
        loop.run_until(t0)
        predicted = loop.own.time_to_finish_s()
        events = loop.run_home()
        assert events[-1].t_s - t0 == pytest.approx(predicted, abs=1e-6)


def test_dead_reckoning_walks_the_route() -> None:
    p = small_problem()
    f = 50.0 / math.dist((0, 0, 0), p.xyz[0])  # 50 m along a 3-D leg (eq. 7)
    assert position_along(p, 0, (0.0, 0.0, 0.0), [0], 50.0) == \
        pytest.approx((100.0 * f, 0.0, -10.0 * f))
    # to spot 0, 60 s injecting, then 10 s toward the rendezvous
    arrive = math.dist((0, 0, 0), p.xyz[0])
    pos = position_along(p, 0, (0.0, 0.0, 0.0), [0], arrive + 70.0)
    assert np.linalg.norm(np.subtract(pos, p.xyz[0])) == pytest.approx(10.0)


def test_the_vehicle_knows_where_it_was() -> None:
    """`position_at`: a point every TRAIL_STEP_S, linear between; now's position from the
    last point on; before the trail, its oldest point (membership judges a silence where the
    judge was when it began)."""
    p = small_problem()
    own = motion.OwnVehicle(p, 0, path_function(p), conduct())
    for t in range(0, 400, 10):
        own.fix(NavFix(float(t), (float(t), 0.0, 0.0)))
    assert own.position_at(400.0) == own.pos == (390.0, 0.0, 0.0)
    assert own.position_at(95.0)[0] == pytest.approx(95.0)  # between trail points 90 and 120
    assert own.position_at(385.0)[0] == pytest.approx(385.0)  # between the last point and now
    assert own.position_at(-50.0) == (0.0, 0.0, 0.0)
    assert len(own.trail) == math.ceil(400 / motion.TRAIL_STEP_S)


def test_an_estimate_on_land_is_taken_at_the_nearest_sea() -> None:
    """A drifted dead reckoning near the shore puts the vehicle's estimate on the island
    (Green Island at 1 % drift: a path from it raised `LandError` and ended the mission).
    The vehicle is at sea: its position is the nearest sea, and its route is timed from
    there."""
    island = [(40.0, -20.0), (60.0, -20.0), (60.0, 20.0), (40.0, 20.0)]
    tasks = [Task(1, (100.0, 0.0, -10.0), 50.0, 60.0), Task(2, (0.0, 100.0, 0.0), 70.0, 75.0)]
    spec = Spec("auv1", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 3600.0, 1.0)
    p = Problem.build("island", [spec], tasks, [island])
    own = motion.OwnVehicle(p, 0, path_function(p), conduct())
    own.set_route([0, 1])
    own.fix(NavFix(10.0, (45.0, 2.0, -3.0), sigma_m=8.0))
    assert own.pos == pytest.approx((39.5, 2.0, -3.0))  # the west coast, the clearance out
    assert math.isfinite(own.time_to_finish_s())
