"""The `best` engine: feasibility, optimality on tiny cases, reproducibility, its moves."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from hfc_core.engines.best import SearchParams
from hfc_core.engines.best.exchange import replace_improve
from hfc_core.engines.best.insert import fill
from hfc_core.engines.best.instance import instance_from_problem
from hfc_core.engines.best.intra import improve_route, or_opt_step, two_opt_step
from hfc_core.engines.best.ruin import CHAIN, CHAIN_SEEDS, RUIN_OPERATORS, chain_planting
from hfc_core.engines.best.state import State
from hfc_core.formats.top import parse_top
from hfc_core.model.problem import Problem, Task, Vehicle
from hfc_core.solve import solve


def random_problem(n: int, k: int, seed: int, battery_s: float = 900.0) -> Problem:
    rng = np.random.default_rng(seed)
    vehicles = [
        Vehicle(f"v{i}", (0.0, 0.0, 0.0), (400.0, 0.0, 0.0), battery_s, 1.0 + 0.25 * i)
        for i in range(k)
    ]
    tasks = [
        Task(100 + i, (*rng.uniform(-100, 500, 2), -rng.uniform(0, 20)),
             float(rng.integers(1, 101)), float(rng.uniform(10, 30)))
        for i in range(n)
    ]
    return Problem.build("random", vehicles, tasks)


def route_length(dist: np.ndarray, nodes: np.ndarray) -> float:
    return float(dist[nodes[:-1], nodes[1:]].sum())


def optimum_one_vehicle(problem: Problem) -> float:
    """Brute force: the richest subset that some visiting order fits into the battery."""
    best = 0.0
    n = problem.n_tasks
    for size in range(1, n + 1):
        for subset in itertools.combinations(range(n), size):
            value = problem.route_priority(subset)
            if value <= best:
                continue
            if any(problem.route_time_s(0, p) <= problem.vehicles[0].battery_s
                   for p in itertools.permutations(subset)):
                best = value
    return best


@pytest.mark.parametrize("seed", range(4))
def test_best_finds_the_optimum_of_tiny_instances(seed):
    problem = random_problem(7, 1, seed, battery_s=700.0)
    result = solve(problem, "best", max_iterations=60, seed=seed)
    got = problem.route_priority(result.plan.routes[0])
    assert got == pytest.approx(optimum_one_vehicle(problem))


def test_best_is_reproducible_and_improves_on_its_construction():
    problem = random_problem(60, 3, 7)
    a = solve(problem, "best", max_iterations=150, seed=3)
    b = solve(problem, "best", max_iterations=150, seed=3)
    assert a.plan == b.plan
    assert a.iterations == 150
    priorities = [h.priority for h in a.history]
    assert priorities == sorted(priorities)
    assert priorities[-1] > a.extra["construction_priority"]
    assert a.history[-1].priority == pytest.approx(
        sum(problem.route_priority(r) for r in a.plan.routes)
    )


def test_best_reaches_the_best_known_scores_of_small_top_instances(top_dir):
    for name, bks in (("p2.3.g", 145), ("p1.3.l", 155)):
        problem = parse_top((top_dir / f"{name}.txt").read_text(), name)
        result = solve(problem, "best", max_iterations=1000, seed=0)
        assert sum(problem.route_priority(r) for r in result.plan.routes) == bks


def test_best_keeps_every_route_within_budget_under_a_time_limit():
    problem = random_problem(120, 4, 11)
    result = solve(problem, "best", time_limit_s=0.3, seed=1)  # the autouse fixture checks
    assert result.iterations > 0


@pytest.mark.parametrize("bad", [{"ruin_max": 0}, {"threshold": 1.5}, {"noise_levels": (-0.1,)},
                                 {"restart": 0}, {"ruin_share": 0.0}, {"polish": -0.1}])
def test_search_params_validate_themselves(bad):
    with pytest.raises(ValueError):
        SearchParams(**bad)


def test_two_opt_and_or_opt_shorten_without_changing_content():
    rng = np.random.default_rng(0)
    for _ in range(50):
        m = int(rng.integers(5, 30))
        pts = rng.random((m, 2))
        dist = np.hypot(*(pts[:, None] - pts[None]).transpose(2, 0, 1))
        nodes = np.array([0, *rng.permutation(np.arange(1, m - 1)), m - 1])
        for step in (two_opt_step, or_opt_step, improve_route):
            out = step(dist, nodes)
            if out is None:
                continue
            assert out[0] == 0 and out[-1] == m - 1
            assert sorted(out) == sorted(nodes)
            assert route_length(dist, out) < route_length(dist, nodes)
        final = improve_route(dist, nodes)
        assert two_opt_step(dist, final) is None and or_opt_step(dist, final) is None


def test_improve_route_untangles_a_crossing():
    pts = np.array([[0, 0], [2, 1], [1, -1], [1, 1], [2, -1], [3, 0]], dtype=float)
    dist = np.hypot(*(pts[:, None] - pts[None]).transpose(2, 0, 1))
    out = improve_route(dist, np.array([0, 1, 2, 3, 4, 5]))  # zig-zags across itself
    optimum = min(
        route_length(dist, np.array([0, *p, 5])) for p in itertools.permutations(range(1, 5))
    )
    assert route_length(dist, out) == pytest.approx(optimum)


def test_fill_respects_budgets_and_who_may_take_what():
    problem = random_problem(50, 3, 5)
    inst = instance_from_problem(problem)
    allowed = np.ones((3, 50), dtype=bool)
    allowed[0, :25] = False  # vehicle 0 may not take the first half
    inst = type(inst)(**{**inst.__dict__, "allowed": allowed})
    state = fill(State(inst))
    assert state.feasible()
    assert not set(state.routes[0]) & set(range(25))
    for v in range(3):
        assert state.time_s(v) == pytest.approx(inst.route_time_s(v, state.routes[v]))
    # Nothing left out would still fit anywhere.
    extra = state.insertion_time_s()
    for u in np.flatnonzero(state.owner < 0):
        for v in range(3):
            assert not (allowed[v, u] and extra[v, u] <= state.slack_s(v))


def test_replace_swaps_in_a_richer_task_that_fits():
    vehicles = [Vehicle("a", (0, 0, 0), (10, 0, 0), 20.0, 1.0)]
    tasks = [Task(1, (5, 3, 0), 1.0, 0.0), Task(2, (5, -3, 0), 50.0, 0.0)]
    problem = Problem.build("swap", vehicles, tasks)
    state = State(instance_from_problem(problem), [[0]])  # only one of the two fits
    assert replace_improve(state)
    assert state.routes == [[1]] and state.feasible()


def test_replace_can_move_the_task_it_takes_out_to_a_route_with_slack():
    """a holds the rich task 1 and has no room for task 3 beside it; b has room for task 1
    but not for task 3. Plain replace would lose 50 for 10 (no move); with relocation task 1
    moves to b and task 3 takes its place in a (an ejection chain: +10)."""
    vehicles = [Vehicle("a", (0, 0, 0), (10, 0, 0), 15.0, 1.0),
                Vehicle("b", (0, 10, 0), (10, 10, 0), 21.0, 1.0)]
    tasks = [Task(1, (5, 3, 0), 50.0, 0.0), Task(2, (5, 10, 0), 1.0, 0.0),
             Task(3, (5, -3, 0), 10.0, 0.0)]
    problem = Problem.build("chain", vehicles, tasks)
    inst = instance_from_problem(problem)
    plain = State(inst, [[0], [1]])
    assert not replace_improve(plain) and plain.routes == [[0], [1]]
    chained = State(inst, [[0], [1]])
    assert replace_improve(chained, relocate=True)
    assert chained.routes[0] == [2] and sorted(chained.routes[1]) == [0, 1]
    assert chained.feasible() and chained.value() == 61.0


REMOVALS = [op for op in RUIN_OPERATORS if op is not chain_planting]


@pytest.mark.parametrize("op", REMOVALS, ids=lambda f: f.__name__)
def test_ruin_operators_only_unassign(op):
    problem = random_problem(60, 3, 2)
    state = fill(State(instance_from_problem(problem)))
    before = [list(r) for r in state.routes]
    out = op(state.copy(), np.random.default_rng(0), 6)
    removed = {u for r in before for u in r} - {u for r in out.routes for u in r}
    assert 1 <= len(removed) <= 6
    for old, new in zip(before, out.routes):
        assert new == [u for u in old if u not in removed]  # order kept
    assert set(np.flatnonzero(out.owner < 0)) >= removed


@pytest.mark.parametrize("seed", range(6))
def test_chain_planting_refills_one_route_with_a_chain_of_nearby_free_spots(seed):
    problem = random_problem(60, 3, seed)
    inst = instance_from_problem(problem)
    state = fill(State(inst))
    before = [list(r) for r in state.routes]
    out = chain_planting(state.copy(), np.random.default_rng(seed), 6)
    emptied = [v for v in range(3) if out.routes[v] != before[v]]
    # Exactly one route changed: a plant identical to the emptied route would prove nothing.
    assert len(emptied) == 1 and out.feasible()
    planted = out.routes[emptied[0]]
    free = [u for u in range(inst.n) if u not in {w for r in out.routes for w in r} - set(planted)]
    # Every planted spot is among the CHAIN nearest free spots of one of them (the head).
    assert planted and any(
        set(planted) <= set(sorted(free, key=lambda u: inst.dist_m[h, u])[:CHAIN])
        for h in planted + [u for u in free if u not in planted]
    )


def test_chain_planting_opens_a_rich_cluster_no_single_insertion_would():
    """Six rich spots far out, each alone a detour past the battery's use for the cheap spots
    by the way: greedy repair never opens the cluster; a planted chain takes all six."""
    vehicles = [Vehicle("a", (0, 0, 0), (0, 0, 0), 330.0, 1.0)]
    near = [Task(i, (20.0 + 10 * i, 0, 0), 30.0, 0.0) for i in range(5)]
    cluster = [Task(10 + i, (0, 150.0 + 3 * i, 0), 30.0, 0.0) for i in range(6)]
    problem = Problem.build("cluster", vehicles, near + cluster)
    inst = instance_from_problem(problem)
    greedy = fill(State(inst))
    assert sorted(greedy.routes[0]) == [0, 1, 2, 3, 4]  # 150, one cluster spot no longer fits
    out = chain_planting(greedy.copy(), np.random.default_rng(0), 3)
    out = fill(out)
    assert sorted(out.routes[0]) == list(range(5, 11)) and out.feasible()
    assert out.value() == 180.0 > greedy.value()


def test_chain_planting_weighs_a_bounded_number_of_heads():
    """More free spots than `CHAIN_SEEDS`: a sample of heads is weighed, the plant still fits
    and leaves the other route alone."""
    problem = random_problem(CHAIN_SEEDS + 100, 2, 3, battery_s=700.0)
    state = fill(State(instance_from_problem(problem)))
    assert (state.owner < 0).sum() > CHAIN_SEEDS
    planted = 0
    for seed in range(4):
        out = chain_planting(state.copy(), np.random.default_rng(seed), 4)
        kept = [v for v in range(2) if out.routes[v] == state.routes[v]]
        assert out.feasible() and len(kept) >= 1
        planted += sum(len(out.routes[v]) for v in range(2) if v not in kept)
    assert planted > 0


@pytest.mark.parametrize("seed", [0, 1, 3, 4])  # seed 2: no route has a move
def test_each_routes_best_replace_is_the_brute_force_best(seed):
    """`best_replaces` gives, for each route, the richest replace move (a routed task out, an
    unrouted one in, into the gap or at its cached cheapest position) whose route still fits,
    as a brute force over every pair finds it; no route without one is named. The pairs that
    gain no value are dropped before any time is computed: this is what checks that none
    that could move is dropped with them."""
    from hfc_core.engines.best.exchange import best_replaces
    from hfc_core.model.feasibility import fits

    state = fill(State(instance_from_problem(random_problem(40, 3, seed, battery_s=700.0))))
    inst = state.inst
    state.refresh()
    free = [int(u) for u in np.flatnonzero(state.owner < 0)]
    assert free  # oversubscribed: the move has something to take
    best: dict[int, float] = {}
    for v in range(inst.k):
        route = state.routes[v]
        for i, out in enumerate(route):
            rest = route[:i] + route[i + 1:]
            for w in free:
                gain = float(inst.value[v, w] - inst.value[v, out])
                if gain <= 0 or not inst.allowed[v, w]:
                    continue
                pos = int(state.ins_pos[v, w])
                places = {i} if pos in (i, i + 1) else {i, pos - (1 if pos > i else 0)}
                if any(fits(inst.route_time_s(v, rest[:at] + [w] + rest[at:]),
                            float(inst.budget_s[v])) for at in places):
                    best[v] = max(best.get(v, -np.inf), gain)
    assert best  # the case this test is about
    moves = best_replaces(state)
    assert {m[1]: m[0] for m in moves} == pytest.approx(best)


@pytest.mark.parametrize("relocate", [False, True])
def test_the_replace_moves_kept_for_unchanged_routes_are_the_ones_computed_afresh(relocate):
    """`best_replaces` keeps its last answer with the routes it was for: asked again of the
    same routes (a copy of the state too) it gives the same moves; after any change of a
    route (a move applied, a task removed) it gives what a fresh evaluation gives."""
    from hfc_core.engines.best.exchange import best_replaces

    state = fill(State(instance_from_problem(random_problem(40, 3, 1, battery_s=700.0))))
    rng = np.random.default_rng(5)
    applied = removed = 0
    for _ in range(12):
        moves = best_replaces(state, relocate)
        assert best_replaces(state.copy(), relocate) == moves  # the kept answer
        state.inst.__dict__.pop("_replaces", None)
        assert best_replaces(state.copy(), relocate) == moves  # computed afresh
        if moves:  # apply the richest, as `replace_improve` does
            _, v, i, task, at, dest, dest_at = moves[0]
            route = list(state.routes[v])
            out = route.pop(i)
            route.insert(at, task)
            state.set_route(v, route)
            if dest >= 0:
                state.insert(dest, out, dest_at)
            applied += 1
        else:  # make one: drop a routed task
            routed = [u for r in state.routes for u in r]
            state.remove([int(rng.choice(routed))])
            removed += 1
    assert applied and removed  # both kinds of change were asked about
