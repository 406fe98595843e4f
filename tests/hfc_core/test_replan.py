"""The replanner: what it may never do, determinism, stability, land, and its fast path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hfc_core.formats.scenario import problem_from_dict
from hfc_core.model.check import _segment_enters
from hfc_core.model.errors import ScenarioError
from hfc_core.model.live import IndexedVehicle
from hfc_core.model.problem import Problem, Task, Vehicle
from hfc_core.replan import LiveVehicle, replan, replan_indexed
from hfc_core.solve import solve
from reef_sim.scenarios.field import paper_preset_doc


@pytest.fixture(scope="module")
def paper() -> Problem:
    return problem_from_dict(paper_preset_doc(3))


@pytest.fixture(scope="module")
def paper_plan(paper) -> list[list[int]]:
    """A `best` plan of the preset, in scenario task ids per vehicle."""
    plan = solve(paper, "best", max_iterations=150, seed=0).plan
    return [[paper.tasks[t].id for t in r] for r in plan.routes]


def mission_s(problem: Problem, live: LiveVehicle, route: list[int]) -> float:
    """Time from the vehicle's position through ``route`` to its rendezvous, recomputed from
    raw coordinates (straight legs, or the waypoint paths around land)."""
    vehicle = problem.vehicles[problem.vehicle_index[live.id]]
    points = [live.pos, *(problem.tasks[problem.task_index[t]].pos for t in route),
              vehicle.rendezvous]
    travel = 0.0
    for a, b in zip(points[:-1], points[1:]):
        if problem.land is None:
            travel += math.dist(a, b)
            continue
        _, path = problem.land.shortest_path(a, b)
        for p, q in zip(path[:-1], path[1:]):
            for poly in problem.forbidden:
                assert not _segment_enters(p[:2], q[:2], [tuple(x) for x in poly.tolist()])
            travel += math.dist(p, q)
    speed = live.speed_mps or vehicle.speed_mps
    return travel / speed + sum(problem.tasks[problem.task_index[t]].service_s for t in route)


def assert_valid(problem, vehicles, routes, cleared=(), held=None):
    """The replanner's rules, checked from its inputs and outputs only."""
    held = held or {}
    live = {v.id for v in vehicles}
    assert set(routes) == live
    seen: set[int] = set()
    for v in vehicles:
        route = routes[v.id]
        assert not seen & set(route), "a spot given to two vehicles"
        assert len(set(route)) == len(route)
        # Locked spots come first, in order, except cleared ones, ones another live vehicle
        # holds, and ones an earlier vehicle already locked.
        kept = [t for t in v.locked
                if t not in cleared and held.get(t, v.id) in (v.id, *set(held.values()) - live)
                and t not in seen]
        assert route[: len(kept)] == kept
        for t in route[len(kept):]:
            assert t not in cleared
            assert t not in held or held[t] == v.id or held[t] not in live
        seen |= set(route)
        if route[len(kept):]:
            assert mission_s(problem, v, route) <= v.battery_s + 1e-6


def midway(problem, plan, done: int, battery_used_s: float = 0.0):
    """Each vehicle has treated its first ``done`` spots and sits at the last of them."""
    live, cleared = [], []
    for v, route in zip(problem.vehicles, plan):
        cleared += route[:done]
        spent = mission_s(problem, LiveVehicle(v.id, v.start, v.battery_s), route[:done])
        spent -= math.dist(problem.tasks[problem.task_index[route[done - 1]]].pos, v.rendezvous)
        pos = problem.tasks[problem.task_index[route[done - 1]]].pos
        live.append(LiveVehicle(v.id, pos, v.battery_s - spent - battery_used_s,
                                route=tuple(route[done:])))
    return live, cleared


@pytest.mark.parametrize("seed", range(6))
def test_random_replans_respect_every_rule(paper, paper_plan, seed):
    rng = np.random.default_rng(seed)
    ids = [t.id for t in paper.tasks]
    live, cleared = midway(paper, paper_plan, int(rng.integers(1, 6)))
    gone = live.pop(int(rng.integers(len(live))))
    cleared += list(rng.choice(ids, size=10, replace=False))
    held = {int(t): str(rng.choice([v.id for v in paper.vehicles])) for t in rng.choice(ids, 20)}
    live = [LiveVehicle(v.id, v.pos, v.battery_s * rng.uniform(0.3, 1.0), route=v.route,
                        locked=tuple(int(t) for t in rng.choice(ids, 2)))
            for v in live]
    routes = replan(paper, live, cleared=set(cleared), held=held, max_iterations=40, seed=seed)
    assert_valid(paper, live, routes, set(cleared), held)
    assert gone.id not in routes


def test_survivors_take_over_a_lost_vehicles_spots(paper, paper_plan):
    live, cleared = midway(paper, paper_plan, 3)
    lost = live.pop(0)
    routes = replan(paper, live, cleared=cleared)
    assert_valid(paper, live, routes, set(cleared))
    taken = {t for r in routes.values() for t in r} & set(lost.route)
    assert taken, "nobody took any of the lost vehicle's spots"


def test_replan_is_deterministic_whatever_the_order_of_its_inputs(paper, paper_plan):
    live, cleared = midway(paper, paper_plan, 2)
    held = {paper_plan[0][5]: live[0].id, paper_plan[1][6]: live[1].id}
    a = replan(paper, live[1:], cleared=cleared, held=held, max_iterations=60, seed=4)
    b = replan(paper, live[1:], cleared=list(reversed(cleared)),
               held=dict(reversed(list(held.items()))), max_iterations=60, seed=4)
    assert a == b


def test_nothing_changed_means_nothing_changes(paper, paper_plan):
    live = [LiveVehicle(v.id, v.start, v.battery_s, route=tuple(r))
            for v, r in zip(paper.vehicles, paper_plan)]
    assert replan(paper, live) == {v.id: r for v, r in zip(paper.vehicles, paper_plan)}


def test_a_small_change_changes_the_plan_little(paper, paper_plan):
    live, cleared = midway(paper, paper_plan, 2)
    # One spot further down vehicle 0's route turns out to be cleared already.
    gone_spot = live[0].route[3]
    routes = replan(paper, live, cleared=cleared + [gone_spot])
    assert_valid(paper, live, routes, set(cleared + [gone_spot]))
    for v in live:
        old = [t for t in v.route if t != gone_spot]
        moved = set(old) ^ set(routes[v.id])
        assert len(moved) <= 2, f"{v.id}: {sorted(moved)} changed for one cleared spot"


def test_locked_spots_stay_first_and_in_order_unless_cleared_or_held(paper, paper_plan):
    live, cleared = midway(paper, paper_plan, 2)
    a, b = live[0], live[1]
    lock = (b.route[1], b.route[0], a.route[2])
    a = LiveVehicle(a.id, a.pos, a.battery_s, route=a.route, locked=lock)
    held = {b.route[0]: b.id}  # b holds one of them: a must drop it
    routes = replan(paper, [a, b, live[2]], cleared=cleared + [a.route[2]], held=held)
    assert routes[a.id][0] == b.route[1]
    assert b.route[0] not in routes[a.id] and a.route[2] not in routes[a.id]


def test_spots_held_by_a_gone_vehicle_are_free(paper, paper_plan):
    live, cleared = midway(paper, paper_plan, 1)
    gone = live.pop()
    held = {t: gone.id for t in gone.route}
    routes = replan(paper, live, cleared=cleared, held=held)
    assert {t for r in routes.values() for t in r} & set(gone.route)


def test_an_empty_battery_keeps_only_the_locked_spots(paper, paper_plan):
    v = paper.vehicles[0]
    lock = (paper_plan[0][0],)
    live = LiveVehicle(v.id, v.start, 5.0, route=tuple(paper_plan[0]), locked=lock)
    routes = replan(paper, [live])
    assert routes == {v.id: list(lock)}


def test_one_vehicle_inserts_free_spots_into_its_own_route(paper, paper_plan):
    """The online cooperation operator: others' spots are marked unavailable."""
    live, cleared = midway(paper, paper_plan, 2)
    me = live[2]
    others = [t for v in live[:2] for t in v.route]
    free = set(t.id for t in paper.tasks) - set(cleared) - set(others) - set(me.route)
    me = LiveVehicle(me.id, me.pos, me.battery_s + 600.0, route=me.route)  # spare battery
    routes = replan(paper, [me], cleared=cleared + others)
    assert_valid(paper, [me], routes, set(cleared + others))
    assert set(routes[me.id]) & free
    assert set(me.route) <= set(routes[me.id])  # with time to spare it keeps all its own


def test_unknown_ids_are_errors(paper):
    v = paper.vehicles[0]
    with pytest.raises(ScenarioError, match="unknown vehicle"):
        replan(paper, [LiveVehicle("nope", v.start, 100.0)])
    with pytest.raises(ScenarioError, match="unknown task"):
        replan(paper, [LiveVehicle(v.id, v.start, 100.0)], cleared=[123456])


@pytest.mark.parametrize("seed", range(3))
def test_the_index_core_is_the_id_edge_without_the_ids(paper, paper_plan, seed):
    """`replan_indexed` on indices gives exactly `replan`'s routes on the same ids, held spots
    of gone vehicles and locked chains included."""
    rng = np.random.default_rng(seed)
    ids = [t.id for t in paper.tasks]
    live, cleared = midway(paper, paper_plan, int(rng.integers(1, 4)))
    live.pop(int(rng.integers(len(live))))
    live = [LiveVehicle(v.id, v.pos, v.battery_s, route=v.route,
                        locked=tuple(int(t) for t in rng.choice(ids, 2))) for v in live]
    held = {int(t): str(rng.choice([v.id for v in paper.vehicles])) for t in rng.choice(ids, 8)}
    by_id = replan(paper, live, cleared=cleared, held=held, max_iterations=20, seed=seed)
    task = paper.task_index
    indexed = [IndexedVehicle(paper.vehicle_index[v.id], v.pos, v.battery_s,
                              route=tuple(task[t] for t in v.route),
                              locked=tuple(task[t] for t in v.locked)) for v in live]
    by_index = replan_indexed(paper, indexed, cleared={task[t] for t in cleared},
                              held={task[t]: paper.vehicle_index[v] for t, v in held.items()},
                              max_iterations=20, seed=seed)
    assert list(by_index) == [paper.vehicle_index[v.id] for v in live]
    assert {paper.vehicles[v].id: [ids[u] for u in r] for v, r in by_index.items()} == by_id


def test_bad_indices_are_errors(paper):
    start = paper.vehicles[0].start
    for index in (3, -1, True, 0.0):
        with pytest.raises(ScenarioError, match="no vehicle with index"):
            replan_indexed(paper, [IndexedVehicle(index, start, 100.0)])
    with pytest.raises(ScenarioError, match="listed twice"):
        replan_indexed(paper, [IndexedVehicle(0, start, 100.0), IndexedVehicle(0, start, 9.0)])
    for bad in ({"cleared": [paper.n_tasks]}, {"held": {-1: 0}}):
        with pytest.raises(ScenarioError, match="no task with index"):
            replan_indexed(paper, [IndexedVehicle(0, start, 100.0)], **bad)
    with pytest.raises(ScenarioError, match="no task with index"):
        replan_indexed(paper, [IndexedVehicle(0, start, 100.0, route=(paper.n_tasks,))])


def island_problem() -> Problem:
    island = [[400, 0], [600, 0], [600, 600], [400, 600]]
    vehicles = [Vehicle("a", (100, 300, 0), (900, 300, 0), 2000.0, 1.0),
                Vehicle("b", (100, 300, 0), (900, 300, 0), 2000.0, 1.0)]
    rng = np.random.default_rng(1)
    tasks = []
    for i in range(30):
        x = float(rng.choice([rng.uniform(0, 380), rng.uniform(620, 1000)]))
        pos = (x, float(rng.uniform(0, 1000)), -3.0)
        tasks.append(Task(i, pos, float(rng.integers(1, 50)), 20.0))
    return Problem.build("island", vehicles, tasks, [island])


def test_replanning_around_land_from_mid_route(assert_feasible):
    problem = island_problem()
    plan = solve(problem, "best", max_iterations=60, seed=0).plan
    assert_feasible(problem, {problem.vehicles[v].id: [problem.tasks[t].id for t in r]
                              for v, r in enumerate(plan.routes)})
    # Vehicle a is west of the island, its rendezvous east: every way passes the island.
    live = [LiveVehicle("a", (300.0, 100.0, -3.0), 1500.0,
                        route=tuple(problem.tasks[t].id for t in plan.routes[0]))]
    routes = replan(problem, live, cleared=[problem.tasks[t].id for t in plan.routes[1]])
    assert_valid(problem, live, routes)
    assert routes["a"]
    with pytest.raises(ValueError, match="on land"):
        replan(problem, [LiveVehicle("a", (500.0, 300.0, 0.0), 1500.0)])
