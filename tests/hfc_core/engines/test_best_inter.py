"""2-opt* (route tail exchange): every (i, j) of the numpy evaluation against brute force."""

from __future__ import annotations

import numpy as np
import pytest

from hfc_core.engines.best.insert import fill
from hfc_core.engines.best.instance import instance_from_problem
from hfc_core.engines.best.inter import (
    EPS_S,
    PairMemo,
    best_relocate,
    best_swap,
    best_tail_swap,
    improve_between,
    swap_tails,
)
from hfc_core.engines.best.state import State
from hfc_core.model.problem import Problem, Task, Vehicle
from tests.hfc_core.engines.test_best import random_problem


def assert_best_move(move: tuple | None, best_gain: float, tie: float) -> None:
    """``move`` (gain first) is the brute-force best, or None when nothing gains more than
    rounding (`inter.EPS_S` seconds of tie-weighted time)."""
    if best_gain <= tie * EPS_S:
        assert move is None
    else:
        assert move is not None and move[0] == pytest.approx(best_gain, rel=1e-9, abs=1e-12)


def brute_force(state: State, a: int, b: int, tie: float) -> float:
    """The best objective gain of any feasible tail exchange of routes a and b (0: none)."""
    inst, ra, rb = state.inst, state.routes[a], state.routes[b]
    old = state.objective(tie)
    best = 0.0
    for i in range(len(ra) + 1):
        for j in range(len(rb) + 1):
            na, nb = ra[:i] + rb[j:], rb[:j] + ra[i:]
            if not (inst.allowed[a, na].all() and inst.allowed[b, nb].all()):
                continue
            trial = State(inst, [na if v == a else nb if v == b else r
                                 for v, r in enumerate(state.routes)])
            if trial.feasible():
                best = max(best, trial.objective(tie) - old)
    return best


@pytest.mark.parametrize("seed", range(6))
def test_the_numpy_evaluation_finds_the_brute_force_best_exchange(seed):
    """Vehicles of different speeds (random_problem), random routes, some tasks forbidden."""
    problem = random_problem(16, 2, seed, battery_s=3000.0)
    inst = instance_from_problem(problem)
    rng = np.random.default_rng(seed)
    allowed = rng.random((2, 16)) > 0.15
    inst = type(inst)(**{**inst.__dict__, "allowed": allowed})
    order = rng.permutation(16)
    ra = [int(u) for u in order[:8] if allowed[0, u]]
    rb = [int(u) for u in order[8:] if allowed[1, u]]
    state = State(inst, [ra, rb])
    assert state.feasible()
    tie = inst.tie_weight()
    expected = brute_force(state, 0, 1, tie)
    assert_best_move(best_tail_swap(state, 0, 1, tie), expected, tie)


def test_crossing_routes_are_uncrossed_and_the_saving_kept():
    """Two vehicles from (0,0) to (100,0); a visits the far-left then far-right task of the
    upper row, b of the lower row, crossed over: a x-shaped pair of routes. Swapping the
    tails gives each vehicle one row, shorter in total, with every task still served."""
    vehicles = [Vehicle(v, (0, 0, 0), (100, 0, 0), 1000.0, 1.0) for v in ("a", "b")]
    tasks = [Task(1, (10, 40, 0), 5.0, 1.0), Task(2, (90, 40, 0), 5.0, 1.0),
             Task(3, (10, -40, 0), 5.0, 1.0), Task(4, (90, -40, 0), 5.0, 1.0)]
    problem = Problem.build("cross", vehicles, tasks)
    state = State(instance_from_problem(problem), [[0, 3], [2, 1]])
    before = state.total_time_s()
    assert swap_tails(state) == [0, 1]
    assert sorted(map(sorted, state.routes)) == [[0, 1], [2, 3]]
    assert state.total_time_s() < before - 50 and state.feasible()
    assert swap_tails(state) == []  # a local optimum: nothing more to take


def test_no_exchange_breaks_a_battery_or_a_forbidden_task():
    """The uncrossing would save time, but a may not treat task 2 and b not task 4 (a
    replan's locks): every exchange would hand one of them a task it may not take, so the
    routes stay as they were."""
    vehicles = [Vehicle(v, (0, 0, 0), (100, 0, 0), 1000.0, 1.0) for v in ("a", "b")]
    tasks = [Task(1, (10, 40, 0), 5.0, 1.0), Task(2, (90, 40, 0), 5.0, 1.0),
             Task(3, (10, -40, 0), 5.0, 1.0), Task(4, (90, -40, 0), 5.0, 1.0)]
    problem = Problem.build("locked", vehicles, tasks)
    inst = instance_from_problem(problem)
    allowed = np.ones((2, 4), dtype=bool)
    allowed[0, 1] = allowed[1, 3] = False
    inst = type(inst)(**{**inst.__dict__, "allowed": allowed})
    state = State(inst, [[0, 3], [2, 1]])
    assert swap_tails(state) == [] and state.routes == [[0, 3], [2, 1]]


def _random_state(seed: int) -> State:
    """Three vehicles of different speeds, random routes, some tasks forbidden to each, and
    values that differ by vehicle (the replanner's stability bonus)."""
    problem = random_problem(14, 3, seed, battery_s=2500.0)
    inst = instance_from_problem(problem)
    rng = np.random.default_rng(seed)
    allowed = rng.random((3, 14)) > 0.15
    value = inst.value * (1.0 + 0.2 * rng.random((3, 14)))
    inst = type(inst)(**{**inst.__dict__, "allowed": allowed, "value": value})
    order = rng.permutation(14)
    routes = [[int(u) for u in part if allowed[v, u]]
              for v, part in enumerate((order[:5], order[5:10], order[10:]))]
    return State(inst, routes)


def _gain(state: State, routes: list[list[int]], tie: float) -> float | None:
    """Objective gain of ``routes`` if allowed and feasible, else None."""
    if not all(state.inst.allowed[v, r].all() for v, r in enumerate(routes)):
        return None
    trial = State(state.inst, routes)
    return trial.objective(tie) - state.objective(tie) if trial.feasible() else None


@pytest.mark.parametrize("seed", range(6))
def test_relocate_finds_the_brute_force_best_move(seed):
    """Against every (task, other route, position): the cached cheapest position is the best
    position, so the best move's gain is the brute-force best."""
    state = _random_state(seed)
    assert state.feasible()
    tie = state.inst.tie_weight()
    best = 0.0
    for a, route in enumerate(state.routes):
        for u in route:
            for b in range(3):
                if b == a:
                    continue
                for at in range(len(state.routes[b]) + 1):
                    routes = [list(r) for r in state.routes]
                    routes[a].remove(u)
                    routes[b].insert(at, u)
                    gain = _gain(state, routes, tie)
                    if gain is not None:
                        best = max(best, gain)
    assert_best_move(best_relocate(state, tie), best, tie)


@pytest.mark.parametrize("seed", range(6))
def test_swap_finds_the_brute_force_best_move(seed):
    state = _random_state(seed)
    tie = state.inst.tie_weight()
    best = 0.0
    for a in range(3):
        for b in range(a + 1, 3):
            for i in range(len(state.routes[a])):
                for j in range(len(state.routes[b])):
                    routes = [list(r) for r in state.routes]
                    routes[a][i], routes[b][j] = routes[b][j], routes[a][i]
                    gain = _gain(state, routes, tie)
                    if gain is not None:
                        best = max(best, gain)
    assert_best_move(best_swap(state, tie), best, tie)


@pytest.mark.parametrize("seed", range(4))
def test_improve_between_keeps_every_task_and_never_loses(seed):
    state = _random_state(seed)
    tie = state.inst.tie_weight()
    tasks, before = sorted(u for r in state.routes for u in r), state.objective(tie)
    improve_between(state)
    assert sorted(u for r in state.routes for u in r) == tasks
    assert state.feasible() and state.objective(tie) >= before
    assert all(state.inst.allowed[v, r].all() for v, r in enumerate(state.routes))
    assert best_relocate(state, tie) is None and best_swap(state, tie) is None


def test_polishing_is_reproducible_and_can_be_switched_off():
    """An iteration budget keeps `best` a pure function of its inputs with polishing on, and
    `polish=None` gives a different search (the option is live)."""
    from hfc_core.formats.scenario import problem_from_dict
    from hfc_core.solve import solve
    from reef_sim.scenarios.field import paper_preset_doc

    problem = problem_from_dict(paper_preset_doc(5000))
    one = solve(problem, "best", max_iterations=150, seed=3).plan.routes
    two = solve(problem, "best", max_iterations=150, seed=3).plan.routes
    off = solve(problem, "best", max_iterations=150, seed=3, polish=None).plan.routes
    assert one == two and one != off


@pytest.mark.parametrize("seed", range(3))
def test_a_memo_answers_what_a_fresh_evaluation_answers(seed):
    """A `PairMemo` kept across edits (moves, in-place inserts, removals) gives the same best
    swap and the same tail exchanges as evaluating every pair afresh."""
    problem = random_problem(36, 6, seed, battery_s=2500.0)
    state = State(instance_from_problem(problem))
    fill(state)
    tie, memo, rng = state.inst.tie_weight(), PairMemo(), np.random.default_rng(seed)
    for _ in range(12):
        assert best_swap(state, tie, memo) == best_swap(state, tie)
        fresh, kept = state.copy(), state.copy()
        assert swap_tails(kept, memo) == swap_tails(fresh) and kept.routes == fresh.routes
        state = kept
        routed = np.flatnonzero(state.owner >= 0)
        u = int(rng.choice(routed))
        state.remove([u])
        state.refresh()
        v = int(rng.integers(state.inst.k))
        state.insert(v, u, int(state.ins_pos[v, u]))  # edits route v's list in place
        if not state.fits(v):
            state.remove([u])


def filled_three(seed: int) -> tuple[State, np.random.Generator]:
    """Three vehicles greedily filled from 20 random spots, and the generator that filled
    them (the tests go on drawing from it)."""
    rng = np.random.default_rng(seed)
    state = State(instance_from_problem(random_problem(20, 3, seed, battery_s=2500.0)))
    fill(state, rng)
    return state, rng


@pytest.mark.parametrize("seed", range(4))
def test_a_trial_judges_and_sets_routes_as_set_route_does(seed):
    """`State.trial` (the moves' judge) gives the bits `set_route` would: the same fit, the
    same objective, and once accepted the same routes, owners and cached figures."""
    state, rng = filled_three(seed)
    tie = state.inst.tie_weight()
    for _ in range(30):
        a, b = (int(v) for v in rng.choice(3, size=2, replace=False))
        ra, rb = state.routes[a], state.routes[b]
        i, j = int(rng.integers(len(ra) + 1)), int(rng.integers(len(rb) + 1))
        routes = {a: ra[:i] + rb[j:], b: rb[:j] + ra[i:]}
        trial = state.trial(routes)
        by_set = state.copy()
        for v in routes:
            by_set.set_route(v, [])
        for v, r in routes.items():
            by_set.set_route(v, r)
        assert trial.fits() == all(by_set.fits(v) for v in routes)
        assert trial.objective(tie) == by_set.objective(tie)  # bit for bit
        trial.accept()
        assert state.routes == by_set.routes
        assert (state.owner == by_set.owner).all()
        assert state.travel_s == by_set.travel_s and state.service_s == by_set.service_s
        assert all((x == y).all() for x, y in zip(state._nodes, by_set._nodes))


def twin_fleet(seed: int) -> Problem:
    """Eight identical vehicles from one station, 200 spots of fractional priority: the
    COTSbot fleet's shape, where exchanging two whole routes between twins seems to gain the
    rounding of the value sums and the fleet's objective rejects it."""
    rng = np.random.default_rng(seed)
    vehicles = [Vehicle(f"v{i}", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 3000.0, 1.0)
                for i in range(8)]
    tasks = [Task(100 + i, (*rng.uniform(-600, 600, 2), 0.0), float(rng.uniform(1, 1000)),
                  float(rng.uniform(10, 30))) for i in range(200)]
    return Problem.build("twins", vehicles, tasks)


@pytest.mark.parametrize("seed", range(3))
def test_a_pair_is_evaluated_once_while_its_routes_stand(seed, monkeypatch):
    """A pair's best tail exchange is a pure function of its two routes: a second pass over a
    fleet whose routes did not change evaluates no pair, also those whose move the fleet's
    objective rejected (before, such a pair was evaluated again on every pass: 6 of them in
    each of these fleets, a third of the evaluations of benchmarks.fleet_scale's 100-vehicle
    plan)."""
    from hfc_core.engines.best import inter

    state = State(instance_from_problem(twin_fleet(seed)))
    fill(state)
    memo = PairMemo()
    swap_tails(state, memo)  # to a state no exchange improves
    tie, k = state.inst.tie_weight(), state.inst.k
    proposed = [(a, b) for a in range(k) for b in range(a + 1, k)
                if best_tail_swap(state, a, b, tie) is not None]
    assert proposed  # the case this test is about: moves still proposed, and refused
    calls = []
    real = inter.best_tail_swap
    monkeypatch.setattr(inter, "best_tail_swap",
                        lambda *a, **k: calls.append(a[1:3]) or real(*a, **k))
    before = [list(r) for r in state.routes]
    assert swap_tails(state, memo) == [] and state.routes == before
    assert calls == []


@pytest.mark.parametrize("seed", range(3))
def test_the_kept_objective_follows_every_edit(seed):
    """`State.objective` is kept until a route changes: after every kind of edit (set, insert,
    remove, an accepted trial, a copy's own edits) it is, bit for bit, a fresh state's."""
    state, rng = filled_three(seed)
    inst, tie = state.inst, state.inst.tie_weight()

    def fresh(s: State) -> float:
        return State(inst, s.routes).objective(tie)

    for step in range(24):
        assert state.objective(tie) == fresh(state)
        v = int(rng.integers(inst.k))
        kind = step % 4
        if kind == 0 and state.routes[v]:
            state.remove([state.routes[v][0]])
        elif kind == 1:
            free = np.flatnonzero(state.owner < 0)
            if len(free):
                state.refresh()
                state.insert(v, int(free[0]), int(state.ins_pos[v, free[0]]))
        elif kind == 2:
            w = (v + 1) % inst.k
            state.trial({v: state.routes[w], w: state.routes[v]}).accept()
        else:
            other = state.copy()
            assert other.objective(tie) == state.objective(tie)
            other.set_route(v, [])
            assert other.objective(tie) == fresh(other)
        assert state.objective(tie) == fresh(state)


@pytest.mark.parametrize("seed", range(3))
def test_whole_routes_exchanged_between_doubles_judge_as_a_trial_does(seed):
    """`State.exchanged` (two whole routes exchanged between vehicles that fly any route
    alike, from the cached figures) gives the bits `State.trial` computes from the travel
    times: the same fit, objective, and once accepted the same routes and figures. Vehicles
    of other speeds, or from other stations, are not doubles, and are refused."""
    state = State(instance_from_problem(twin_fleet(seed)))
    fill(state)
    inst, tie = state.inst, state.inst.tie_weight()
    assert (inst.doubles() == 0).all()  # one station, one kind: every vehicle alike
    for a, b in ((0, 1), (2, 7), (5, 3)):
        by_trial = state.copy()
        trial = by_trial.trial({a: state.routes[b], b: state.routes[a]})
        quick = state.exchanged(a, b)
        assert quick.fits() == trial.fits()
        assert quick.objective(tie) == trial.objective(tie)  # bit for bit
        quick.accept()
        trial.accept()
        assert state.routes == by_trial.routes and (state.owner == by_trial.owner).all()
        assert state.travel_s == by_trial.travel_s and state.service_s == by_trial.service_s
        assert all((x == y).all() for x, y in zip(state._nodes, by_trial._nodes))
        assert state.objective(tie) == State(inst, state.routes).objective(tie)
    apart = State(instance_from_problem(random_problem(20, 3, seed)))
    assert len(set(apart.inst.doubles().tolist())) == 3  # different speeds: none alike
    # Identical vehicles meeting at one rendezvous from two stations: twins (any tail is
    # flown alike), not doubles (a whole route is not).
    rng = np.random.default_rng(seed)
    two = Problem.build("two stations", [
        Vehicle(f"v{i}", (0.0, 0.0, 0.0) if i < 2 else (300.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                3000.0, 1.0) for i in range(4)],
        [Task(100 + i, (*rng.uniform(-300, 300, 2), 0.0), 10.0, 20.0) for i in range(20)])
    split = State(instance_from_problem(two))
    assert split.inst.twins().tolist() == [0, 0, 0, 0]
    assert split.inst.doubles().tolist() == [0, 0, 2, 2]
    with pytest.raises(ValueError):
        split.exchanged(1, 2)
