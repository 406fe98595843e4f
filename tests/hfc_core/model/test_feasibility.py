"""One feasibility rule: a route whose time equals the battery fits, in every part.

The instances are generated (seeded spots out of reach) around one spot whose route takes
exactly the battery: start -> spot -> rendezvous along a 3-4-5 triangle, so that every
floating-point order of summing it gives the budget to the last digit (as Chao's p7.2.a,
where the best-known score needs such a route).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hfc_core.engines.best.construct import screen as best_screen
from hfc_core.engines.best.insert import fill
from hfc_core.engines.best.instance import instance_from_problem
from hfc_core.engines.best.state import State
from hfc_core.engines.operators.cooperation import take_nearest
from hfc_core.engines.operators.screening import screen_route
from hfc_core.formats.top import parse_top
from hfc_core.model.check import check_routes
from hfc_core.model.cost import CostWeights, RouteModel
from hfc_core.model.feasibility import FEASIBILITY_TOL_S, fits, room_s
from hfc_core.model.problem import Problem, Task, Vehicle
from hfc_core.replan import LiveVehicle, replan
from hfc_core.solve import solve
from fleet_agent.routing import fit_route
from vehicle_loop import Loop

EXACT_ID, NEAR_ID = 1, 2
SERVICE_S = 90.0
# Start and rendezvous at the origin, the exact spot at (300, 400): 500 m there, 500 m back.
EXACT_TIME_S = 1000.0 + SERVICE_S


def exact_budget_problem(seed: int, over_s: float = 0.0) -> Problem:
    """Two vehicles; the rich spot takes exactly the battery (plus ``over_s``), a cheap one is
    near the start, and seeded spots lie out of reach (beyond half the battery)."""
    rng = np.random.default_rng(seed)
    battery = EXACT_TIME_S + over_s
    vehicles = [Vehicle(f"v{i}", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), battery, 1.0)
                for i in range(2)]
    tasks = [Task(EXACT_ID, (300.0, 400.0, 0.0), 100.0, SERVICE_S),
             Task(NEAR_ID, (10.0, 0.0, 0.0), 5.0, SERVICE_S)]
    for i in range(20):
        angle, radius = rng.uniform(0, 2 * math.pi), rng.uniform(600, 900)
        tasks.append(Task(10 + i, (radius * math.cos(angle), radius * math.sin(angle), 0.0),
                          float(rng.integers(1, 101)), SERVICE_S))
    return Problem.build("exact-budget", vehicles, tasks)


def collected_ids(problem: Problem, routes) -> set[int]:
    return {problem.tasks[u].id for r in routes for u in r}


def test_the_rule_counts_a_time_equal_to_the_budget():
    assert fits(3600.0, 3600.0)
    assert fits(3600.0 + FEASIBILITY_TOL_S / 2, 3600.0)
    assert not fits(3600.0 + 2 * FEASIBILITY_TOL_S, 3600.0)
    np.testing.assert_array_equal(fits(np.array([1.0, 2.0, 3.0]), np.array([2.0, 2.0, 2.0])),
                                  [True, True, False])
    assert room_s(3600.0, 3600.0) == FEASIBILITY_TOL_S


@pytest.mark.parametrize("seed", range(3))
def test_every_sum_of_the_exact_route_gives_the_budget(seed):
    problem = exact_budget_problem(seed)
    u = problem.task_index[EXACT_ID]
    inst = instance_from_problem(problem)
    assert problem.route_time_s(0, [u]) == EXACT_TIME_S
    assert inst.route_time_s(0, [u]) == EXACT_TIME_S
    assert State(inst, [[u], []]).time_s(0) == EXACT_TIME_S
    assert RouteModel(problem).time_s(0, [u]) == EXACT_TIME_S


@pytest.mark.parametrize("seed", range(3))
def test_checker_accepts_the_exact_route_and_rejects_one_just_over(seed):
    assert check_routes(exact_budget_problem(seed), {"v0": [EXACT_ID]}) == []
    errors = check_routes(exact_budget_problem(seed, over_s=-2 * FEASIBILITY_TOL_S),
                          {"v0": [EXACT_ID]})
    assert errors and "exceeds battery" in errors[0]


@pytest.mark.parametrize("seed", range(3))
def test_best_uses_the_exact_route(seed):
    """Like p7.2.a: one vehicle takes the cheap spot, the other must take the exact one."""
    problem = exact_budget_problem(seed)
    result = solve(problem, "best", max_iterations=30, seed=seed)
    assert collected_ids(problem, result.plan.routes) == {EXACT_ID, NEAR_ID}


@pytest.mark.parametrize("seed", range(3))
def test_nobody_takes_a_route_just_over_the_budget(seed):
    problem = exact_budget_problem(seed, over_s=-2 * FEASIBILITY_TOL_S)
    for mode in ("best", "hfc-cm", "ga"):
        result = solve(problem, mode, max_iterations=20, seed=seed)
        assert EXACT_ID not in collected_ids(problem, result.plan.routes), mode
    routes = replan(problem, [LiveVehicle("v0", (0.0, 0.0, 0.0), problem.vehicles[0].battery_s)],
                    max_iterations=20)
    assert EXACT_ID not in routes["v0"]


def test_the_papers_operators_keep_the_exact_route():
    problem = exact_budget_problem(0)
    model, weights = RouteModel(problem), CostWeights().scaled_to(problem)
    u, near = problem.task_index[EXACT_ID], problem.task_index[NEAR_ID]
    assert screen_route([u], model=model, v=0, weights=weights) == [u]  # Algorithm 2
    abandoned = np.zeros(problem.n_tasks, dtype=bool)
    abandoned[u] = True
    assert take_nearest([], abandoned, model=model, v=0) == [u]  # Algorithm 3
    assert len(screen_route([u, near], model=model, v=0, weights=weights)) == 1
    inst = instance_from_problem(problem)
    assert best_screen(inst, 0, [u]) == [u]
    state = fill(State(inst, [[near], []]))
    assert state.routes[1] == [u] and state.feasible()
    for mode in ("hfc-cm", "hfc-ncm2"):
        result = solve(problem, mode, max_iterations=10, seed=0)
        assert EXACT_ID in collected_ids(problem, result.plan.routes), mode


@pytest.mark.parametrize("seed", range(3))
def test_replan_uses_the_exact_route(seed):
    problem = exact_budget_problem(seed)
    live = [LiveVehicle("v0", (0.0, 0.0, 0.0), EXACT_TIME_S, route=(NEAR_ID,)),
            LiveVehicle("v1", (0.0, 0.0, 0.0), EXACT_TIME_S)]
    routes = replan(problem, live, max_iterations=20, seed=seed)
    assert set(routes["v0"]) | set(routes["v1"]) == {EXACT_ID, NEAR_ID}
    # Mid-mission: halfway to the spot with exactly the battery the rest takes.
    half = LiveVehicle("v1", (150.0, 200.0, 0.0), 250.0 + SERVICE_S + 500.0)
    assert replan(problem, [half], max_iterations=20, seed=seed)["v1"] == [EXACT_ID]


def test_vehicle_model_keeps_and_flies_the_exact_route():
    problem = exact_budget_problem(0)
    u = problem.task_index[EXACT_ID]
    auv = Loop(problem, 0)
    assert auv.own.time_to_finish_s([u]) == EXACT_TIME_S
    assert fit_route(auv.own, [u], reserve_s=0.0) == [u]
    auv.set_route([u])
    assert auv.own.slack_s() == pytest.approx(FEASIBILITY_TOL_S, abs=1e-12)
    events = auv.run_home()
    assert events[-1].t_s == EXACT_TIME_S and auv.own.battery_left_s() == 0.0


@pytest.mark.parametrize("seed", range(4))
def test_a_budget_summed_in_another_order_still_fits_everywhere(seed):
    """Budget = the checker's own sum of a random multi-spot route; the planner's sums of
    the same route (numpy, cached legs) may differ in the last bits, and must still agree."""
    rng = np.random.default_rng(seed)
    tasks = [Task(i, (*rng.uniform(0, 1000, 2), -rng.uniform(0, 20)), 10.0, rng.uniform(60, 90))
             for i in range(12)]
    route_ids = [int(t) for t in rng.permutation(12)[:6]]
    start, end = (0.0, 0.0, 0.0), (1000.0, 1000.0, 0.0)
    points = [start, *(tasks[t].pos for t in route_ids), end]
    budget = (sum(math.dist(a, b) for a, b in zip(points[:-1], points[1:])) / 0.7
              + sum(tasks[t].service_s for t in route_ids))
    problem = Problem.build("orders", [Vehicle("v0", start, end, budget, 0.7)], tasks)
    route = [problem.task_index[t] for t in route_ids]
    assert check_routes(problem, {"v0": route_ids}) == []
    assert abs(problem.route_time_s(0, route) - budget) < FEASIBILITY_TOL_S / 100
    assert State(instance_from_problem(problem), [route]).feasible()
    assert fit_route(Loop(problem, 0).own, route, reserve_s=0.0) == route
    kept = replan(problem, [LiveVehicle("v0", start, budget, route=tuple(route_ids))],
                  max_iterations=0)["v0"]
    assert set(kept) >= set(route_ids)


def test_chaos_p7_2_a_needs_the_exact_route(top_dir):
    """The TOP instance the rule was found on: best-known 30 = both reachable spots."""
    problem = parse_top((top_dir / "p7.2.a.txt").read_text(), "p7.2.a")
    result = solve(problem, "best", max_iterations=50, seed=0)
    assert sum(problem.route_priority(r) for r in result.plan.routes) == 30.0
