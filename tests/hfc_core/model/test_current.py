"""Currents: the scenario section, ground speeds, travel times, and every part agreeing."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fleet_agent.reckoning import position_along
from hfc_core.engines.best.instance import instance_from_problem
from hfc_core.formats.scenario import problem_from_dict, problem_to_dict
from hfc_core.model.check import check_routes
from hfc_core.model.current import (
    M2_PERIOD_S,
    GridCurrent,
    TidalCurrent,
    UniformCurrent,
    current_from_dict,
    ieee_cos,
    sample,
)
from hfc_core.model.errors import ScenarioError
from hfc_core.model.feasibility import fits
from hfc_core.model.problem import Problem, Task, Vehicle
from hfc_core.model.travel import (
    IMPOSSIBLE_S,
    ground_speed,
    path_time_s,
    segment_times,
    tide_range,
)
from hfc_core.replan import LiveVehicle, replan
from hfc_core.solve import solve
from reef_sim.scenarios.field import paper_preset_doc
from vehicle_loop import Loop


def grid_doc(seed: int, cell_m: float = 250.0, size: int = 5, peak: float = 0.4) -> dict:
    rng = np.random.default_rng(seed)
    return {"kind": "grid", "origin": [0.0, 0.0], "cell_m": cell_m,
            "u": rng.uniform(-peak, peak, (size, size)).tolist(),
            "v": rng.uniform(-peak, peak, (size, size)).tolist()}


CURRENTS = {
    "uniform": {"kind": "uniform", "velocity_mps": [0.4, -0.2]},
    "tidal": {"kind": "tidal", "velocity_mps": [0.5, 0.3], "period_s": M2_PERIOD_S,
              "phase_s": 9000.0},
    "grid": grid_doc(0),
}


def paper_with(current: dict | None, seed: int = 3) -> Problem:
    doc = paper_preset_doc(seed)
    if current is not None:
        doc["current"] = current
    return problem_from_dict(doc)


def ids(problem: Problem, routes) -> dict[str, list[int]]:
    return {problem.vehicles[v].id: [problem.tasks[u].id for u in r] for v, r in enumerate(routes)}


# --- the scenario section -----------------------------------------------------------------------
@pytest.mark.parametrize("kind", sorted(CURRENTS))
def test_current_round_trips_through_the_scenario(kind):
    problem = paper_with(CURRENTS[kind])
    again = problem_from_dict(problem_to_dict(problem))
    assert problem_to_dict(again)["current"] == problem_to_dict(problem)["current"]
    np.testing.assert_array_equal(again.travel_s[0], problem.travel_s[0])


@pytest.mark.parametrize(("doc", "message"), [
    ({"kind": "uniform", "velocity_mps": [float("nan"), 0.0]}, "velocity_mps[0]: must be finite"),
    ({"kind": "uniform", "velocity_mps": [0.1]}, "velocity_mps must be [x, y]"),
    ({"kind": "uniform"}, "missing field 'velocity_mps'"),
    ({"kind": "uniform", "velocity_mps": [0, 0], "phase_s": 3}, "unknown field(s) ['phase_s']"),
    ({"kind": "eddy"}, "kind must be 'uniform', 'tidal' or 'grid'"),
    ("east", "current: expected an object"),
    ({"kind": "tidal", "velocity_mps": [1, 0], "period_s": 0}, "period_s must be positive"),
    ({"kind": "tidal", "velocity_mps": [1, 0], "phase_s": "noon"}, "phase_s: expected a number"),
    ({**grid_doc(0), "cell_m": -5.0}, "cell_m must be positive"),
    ({**grid_doc(0), "u": [[0.1, 0.2], [0.3]]}, "u must be a rectangular list"),
    ({**grid_doc(0), "v": [[0.1, 0.2], [0.3, 0.4]]}, "u has shape (5, 5) but v has (2, 2)"),
    ({**grid_doc(0), "u": [[0.1]], "v": [[0.1]]}, "at least 2 x 2 nodes"),
    ({**grid_doc(0), "origin": [0.0, float("inf")]}, "origin[1]: must be finite"),
])
def test_malformed_current_sections_are_scenario_errors(doc, message):
    scenario = paper_preset_doc(0)
    scenario["current"] = doc
    with pytest.raises(ScenarioError) as err:
        problem_from_dict(scenario)
    assert message in str(err.value) and str(err.value).startswith("current")


def test_without_a_current_travel_is_distance_over_speed():
    for doc in (paper_preset_doc(2), {**paper_preset_doc(2), "current": None}):
        problem = problem_from_dict(doc)
        assert problem.current is None and problem.symmetric
        np.testing.assert_array_equal(problem.travel_s[0], problem.dist_m / 1.0)


# --- ground speed --------------------------------------------------------------------------------
def test_ground_speed_of_the_course_to_steer_triangle():
    assert ground_speed(1.0, 0.0, 0.0, 0.6, 0.8) == 1.0  # still water: exactly the speed
    assert ground_speed(1.0, 0.5, 0.0, 1.0, 0.0) == 1.5  # with the current
    assert ground_speed(1.0, -0.5, 0.0, 1.0, 0.0) == 0.5  # against it
    assert ground_speed(1.0, 0.0, 0.6, 1.0, 0.0) == pytest.approx(0.8)  # crabbing: 0.6-0.8-1
    assert np.isnan(ground_speed(1.0, 0.0, 1.2, 1.0, 0.0))  # swept off the track
    assert np.isnan(ground_speed(1.0, -1.0, 0.0, 1.0, 0.0))  # no headway
    # whatever the direction, the water velocity has the cruise speed
    rng = np.random.default_rng(0)
    c, angle = rng.uniform(-0.7, 0.7, (50, 2)), rng.uniform(0, 2 * np.pi, 50)
    d = np.column_stack([np.cos(angle), np.sin(angle)])
    g = ground_speed(1.0, c[:, 0], c[:, 1], d[:, 0], d[:, 1])
    np.testing.assert_allclose(np.linalg.norm(g[:, None] * d - c, axis=1), 1.0)


def test_up_current_costs_more_than_down_current():
    problem = paper_with({"kind": "uniform", "velocity_mps": [0.5, 0.0]})
    s, e = problem.start_node(0), problem.end_node(0)  # (80, 80) -> (920, 920): north-east
    t = problem.travel_s[0]
    assert t[s, e] < problem.dist_m[s, e] < t[e, s]
    assert not problem.symmetric
    assert not np.array_equal(t, t.T)


def test_impossible_legs_have_a_reason_and_are_never_planned():
    # A 1.2 m/s northward stream: a vehicle at 1 m/s cannot cross it east-west.
    vehicles = [Vehicle("a", (0, 0, 0), (0, 500, 0), 2000.0, 1.0)]
    tasks = [Task(1, (0, 200, 0), 50.0, 60.0), Task(2, (300, 0, 0), 90.0, 60.0)]
    problem = Problem.build("strong", vehicles, tasks,
                            current=UniformCurrent((0.0, 1.2)))
    u = problem.task_index[2]
    assert problem.travel_s[0][problem.start_node(0), u] == IMPOSSIBLE_S
    result = solve(problem, "best", max_iterations=20, seed=0)
    assert [problem.tasks[t].id for t in result.plan.routes[0]] == [1]
    errors = check_routes(problem, {"a": [2]})
    assert errors and "across the track" in errors[0]
    with pytest.raises(ScenarioError, match="cannot go from its start to its rendezvous"):
        Problem.build("home", [Vehicle("a", (0, 0, 0), (0, -500, 0), 2000.0, 1.0)], tasks,
                      current=UniformCurrent((0.0, 1.2)))


# --- the water models ------------------------------------------------------------------------
def test_ieee_cosine_matches_the_library():
    xs = np.linspace(-200.0, 200.0, 4001)
    assert max(abs(ieee_cos(float(x)) - math.cos(x)) for x in xs) < 1e-14


def test_tide_steps_hold_the_stream_at_its_mid_step_value():
    tide = TidalCurrent((0.5, 0.0), period_s=1200.0, phase_s=0.0)
    assert tide.velocity([[0, 0]], 0.0)[0, 0] == pytest.approx(0.5 * math.cos(math.pi / 20))
    assert tide.velocity([[0, 0]], 59.9)[0, 0] == tide.velocity([[0, 0]], 0.0)[0, 0]
    assert tide.velocity([[0, 0]], 600.0)[0, 0] < 0  # ebb half a period later


@pytest.mark.parametrize("seed", range(3))
def test_grid_pieces_are_within_2e3_of_a_fine_integration(seed):
    """Random nodes up to 0.4 m/s each way (rougher than a tidal field): median error ~1e-4."""
    coarse = current_from_dict(grid_doc(seed, peak=0.4))
    fine = GridCurrent(coarse.origin, coarse.cell_m / 16, *_refined(coarse, 16))
    rng = np.random.default_rng(seed)
    for _ in range(20):
        p, q = rng.uniform(0, 1000, 3), rng.uniform(0, 1000, 3)
        t_coarse = path_time_s(coarse, [p, q], 1.0)
        t_fine = path_time_s(fine, [p, q], 1.0)
        assert abs(t_coarse - t_fine) <= 2e-3 * t_fine


def _refined(grid: GridCurrent, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The same bilinear field sampled on a k-times finer grid (bilinear again in between)."""
    ny, nx = grid.u.shape
    ys, xs = np.mgrid[0:(ny - 1) * k + 1, 0:(nx - 1) * k + 1]
    xy = np.column_stack([xs.ravel(), ys.ravel()]) * (grid.cell_m / k)
    uv = grid.velocity(xy)
    return uv[:, 0].reshape(xs.shape), uv[:, 1].reshape(xs.shape)


@pytest.mark.parametrize("phase_s", [0.0, 11_178.0, 20_000.0, 33_534.0])
def test_tidal_planning_time_bounds_every_departure(phase_s):
    tide = TidalCurrent((0.6, 0.2), phase_s=phase_s)
    window = (0.0, 3600.0)
    lo, hi = tide_range(tide, window)
    assert -1.0 <= lo <= hi <= 1.0
    rng = np.random.default_rng(int(phase_s))
    p, q = rng.uniform(0, 1000, (40, 3)), rng.uniform(0, 1000, (40, 3))
    bound = segment_times(tide, p, q, 1.0, window)
    for i in range(40):
        flown = [path_time_s(tide, [p[i], q[i]], 1.0, t0) for t0 in rng.uniform(0, 3000, 8)]
        assert max(flown) <= bound[i] + 1e-9
        # a bound, not a guess: near slack water the tide turns within the hour and the
        # longest leg time exceeds any one flight by up to ~15 %
        assert max(flown) >= 0.8 * bound[i]


def test_sample_for_the_dashboard():
    xy, uv = sample(UniformCurrent((0.2, -0.1)), (0.0, 1000.0, 0.0, 500.0), 5, t_s=0.0)
    assert xy.shape == uv.shape == (25, 2)
    assert xy[0].tolist() == [0.0, 0.0] and xy[-1].tolist() == [1000.0, 500.0]
    np.testing.assert_array_equal(uv, np.tile([0.2, -0.1], (25, 1)))
    tide = TidalCurrent((0.5, 0.0), period_s=1200.0)
    ebb, flood = sample(tide, (0, 1, 0, 1), 2, 630.0), sample(tide, (0, 1, 0, 1), 2, 0.0)
    assert ebb[1][0, 0] < 0 < flood[1][0, 0]
    grid = current_from_dict(grid_doc(1))
    xy, uv = sample(grid, grid.bounds(), 5)
    np.testing.assert_allclose(uv[:, 0], np.asarray(grid.u).ravel())


# --- every part agrees ------------------------------------------------------------------------
@pytest.mark.parametrize("kind", sorted(CURRENTS))
def test_planner_checker_and_vehicle_agree_on_plans_in_a_current(kind):
    problem = paper_with(CURRENTS[kind])
    result = solve(problem, "best", max_iterations=60, seed=1)  # conftest: checked feasible
    inst = instance_from_problem(problem)
    for v, route in enumerate(result.plan.routes):
        route = list(route)
        flown = problem.route_time_s(v, route)
        planned = inst.route_time_s(v, route)
        assert fits(planned, problem.vehicles[v].battery_s)
        assert flown == pytest.approx(planned, abs=1e-6)  # a tide is clocked as flown
        auv = Loop(problem, v)
        assert auv.own.time_to_finish_s(route) == pytest.approx(flown, abs=1e-6)
        auv.set_route(route)
        t, arrived = 0.0, None
        while not auv.own.done:
            t += 47.3
            for event in auv.run_until(t):
                arrived = event.t_s
        assert arrived == pytest.approx(flown, abs=1e-6)
    assert check_routes(problem, ids(problem, result.plan.routes)) == []


@pytest.mark.parametrize("kind", sorted(CURRENTS))
@pytest.mark.parametrize("step_s", [0.9, 13.0, 500.0])
def test_positions_in_a_current_do_not_depend_on_the_stepping(kind, step_s):
    problem = paper_with(CURRENTS[kind])
    route = [0, 5, 9, 14]
    ref, auv = Loop(problem, 0), Loop(problem, 0)
    ref.set_route(route)
    auv.set_route(route)
    t = 0.0
    while t < 2000.0:
        t += step_s
        auv.run_until(t)
    ref.run_until(t)  # from one event to the next only
    assert auv.own.pos == pytest.approx(ref.own.pos, abs=1e-9)
    assert auv.own.distance_m == pytest.approx(ref.own.distance_m, abs=1e-9)


@pytest.mark.parametrize("kind", sorted(CURRENTS))
def test_dead_reckoning_in_a_current_follows_the_vehicle(kind):
    problem = paper_with(CURRENTS[kind])
    auv = Loop(problem, 0)
    auv.set_route([3, 7])
    auv.run_until(700.0)
    assert position_along(problem, 0, problem.vehicles[0].start, [3, 7], 700.0) == \
        pytest.approx(auv.own.pos, abs=1e-6)


@pytest.mark.parametrize("kind", sorted(CURRENTS))
@pytest.mark.parametrize("clocked", [True, False])
def test_replan_in_a_current_fits_what_the_vehicle_will_fly(kind, clocked):
    problem = paper_with(CURRENTS[kind])
    plan = solve(problem, "best", max_iterations=40, seed=0).plan.routes
    auvs = []
    for v, route in enumerate(plan):
        loop = Loop(problem, v)
        loop.set_route(route)
        loop.run_until(1200.0)
        auvs.append(loop.own)
    survivors = [LiveVehicle(problem.vehicles[v].id, auv.pos, auv.battery_left_s(),
                             route=tuple(problem.tasks[u].id for u in auv.route),
                             locked=(() if auv.injecting is None
                                     else (problem.tasks[auv.injecting].id,)))
                 for v, auv in enumerate(auvs) if v != 1]
    cleared = [problem.tasks[u].id for u in range(problem.n_tasks)
               if u in plan[0] + plan[2] and u not in auvs[0].route + auvs[2].route]
    routes = replan(problem, survivors, cleared=cleared, max_iterations=30, seed=2,
                    now_s=1200.0 if clocked else None)
    for live in survivors:
        v = problem.vehicle_index[live.id]
        new = [problem.task_index[t] for t in routes[live.id]]
        finish = auvs[v].time_to_finish_s(new)
        assert fits(finish, auvs[v].battery_left_s()), (live.id, finish)


@pytest.mark.parametrize("mode", ["hfc-ncm2", "hfc-cm", "ga"])
@pytest.mark.parametrize("kind", sorted(CURRENTS))
def test_the_papers_modes_plan_feasibly_in_a_current(mode, kind):
    problem = paper_with(CURRENTS[kind])
    result = solve(problem, mode, max_iterations=15, seed=0, population=20)  # conftest checks
    assert sum(len(r) for r in result.plan.routes) > 20


def _route_time(t: np.ndarray, nodes) -> float:
    return float(sum(t[a, b] for a, b in zip(nodes[:-1], nodes[1:])))


@pytest.mark.parametrize("seed", range(3))
def test_moves_predict_what_they_change_when_times_depend_on_direction(seed):
    from hfc_core.engines.best.intra import improve_route, or_opt_step, two_opt_step
    from hfc_core.engines.operators.ordering import MOVES, move_delta_m
    from hfc_core.model.cost import RouteModel

    problem = paper_with({"kind": "uniform", "velocity_mps": [0.6, 0.3]}, seed)
    t = problem.travel_s[0]
    rng = np.random.default_rng(seed)
    nodes = np.array([problem.start_node(0), *rng.permutation(problem.n_tasks)[:15],
                      problem.end_node(0)])
    for step in (two_opt_step, or_opt_step):
        better = step(t, nodes, symmetric=False)
        assert better is not None and sorted(better) == sorted(nodes)
        assert _route_time(t, better) < _route_time(t, nodes)
    best = improve_route(t, nodes, symmetric=False)
    assert two_opt_step(t, best, symmetric=False) is None
    assert or_opt_step(t, best, symmetric=False) is None
    model = RouteModel(problem)
    seq = [int(x) for x in nodes]
    for kind, move in MOVES.items():
        for i, j in [(0, 5), (7, 2), (3, 4), (11, 10)]:
            after = [seq[0], *move(seq[1:-1], i, j), seq[-1]]
            assert move_delta_m(model.time_rows[0], seq, kind, i, j, symmetric=False) == \
                pytest.approx(_route_time(t, after) - _route_time(t, seq), abs=1e-9)


@pytest.mark.parametrize("seed", range(3))
def test_the_tide_clock_times_routes_as_the_checker_flies_them(seed):
    from hfc_core.engines.best.instance import instance_from_problem

    problem = paper_with({"kind": "tidal", "velocity_mps": [0.6, -0.3], "phase_s": 3000.0 * seed},
                         seed)
    inst = instance_from_problem(problem)
    assert inst.clock is not None
    rng = np.random.default_rng(seed)
    for v in range(problem.n_vehicles):
        route = [int(u) for u in rng.permutation(problem.n_tasks)[:6]]
        flown = problem.route_time_s(v, route)
        if flown <= problem.vehicles[v].battery_s:
            assert inst.route_time_s(v, route) == pytest.approx(flown, abs=1e-6)
        else:  # beyond the mission the clock does not run: such a route never fits
            assert not fits(inst.route_time_s(v, route), problem.vehicles[v].battery_s)
        points = [problem.vehicles[v].start, *(problem.tasks[u].pos for u in route),
                  problem.vehicles[v].rendezvous]
        walked = sum(path_time_s(problem.current, [a, b], 1.0) for a, b in
                     zip(points[:1], points[1:2]))
        assert inst.clock.leg_end_s(v, problem.start_node(v), route[0], 0.0) == \
            pytest.approx(walked, abs=1e-9)


def test_a_tide_aware_plan_uses_its_battery():
    """Timed as flown, a tide-aware plan ends close to its battery (the bound alone left
    minutes unused in some tide phases)."""
    problem = paper_with({"kind": "tidal", "velocity_mps": [0.0, 0.6], "phase_s": 11178.0}, 1)
    plan = solve(problem, "best", max_iterations=100, seed=0).plan.routes
    left = [problem.vehicles[v].battery_s - problem.route_time_s(v, list(r))
            for v, r in enumerate(plan)]
    assert max(left) < 90.0  # less than one injection unused per vehicle
