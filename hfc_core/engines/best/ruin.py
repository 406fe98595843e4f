"""Destroy operators: ``op(state, rng, size) -> state`` unassigns about ``size`` tasks
(`chain_planting` empties a route and seeds it with a chain of free spots instead).

Each works on the state it is given (the engine passes a copy). Tasks a vehicle is locked to
never appear in routes (they are folded into the vehicle's start, see `hfc_core.replan`), so
every routed task may be removed.
"""

from __future__ import annotations

import numpy as np

from hfc_core.engines.best.state import State


def _assigned(state: State) -> np.ndarray:
    return np.flatnonzero(state.owner >= 0)


def random_removal(state: State, rng: np.random.Generator, size: int) -> State:
    """Uniformly random tasks: plain diversification."""
    assigned = _assigned(state)
    if len(assigned):
        state.remove(list(rng.choice(assigned, size=min(size, len(assigned)), replace=False)))
    return state


def related_removal(state: State, rng: np.random.Generator, size: int) -> State:
    """The routed tasks nearest a random seed task (routed or not): frees a region, so the
    repair can re-cut it, or can make room for an unrouted rich task among them."""
    inst = state.inst
    seed = int(rng.integers(inst.n))
    order = np.argsort(inst.dist_m[seed, : inst.n], kind="stable")
    routed = order[state.owner[order] >= 0]
    state.remove(list(routed[:size]))
    return state


def string_removal(state: State, rng: np.random.Generator, size: int) -> State:
    """Consecutive runs of tasks in the routes passing near a seed (after SISR's strings):
    slack appears where routes are dense, and route tails can be swapped between vehicles."""
    assigned = _assigned(state)
    if not len(assigned):
        return state
    inst = state.inst
    seed = int(rng.choice(assigned))
    order = np.argsort(inst.dist_m[seed, : inst.n], kind="stable")
    routed = order[state.owner[order] >= 0]
    strings = int(rng.integers(1, inst.k + 1))
    per_string = max(1, size // strings)
    removed: list[int] = []
    done_routes: set[int] = set()
    for u in routed:
        v = int(state.owner[u])
        if v in done_routes:
            continue
        done_routes.add(v)
        route = state.routes[v]
        length = min(per_string, len(route))
        at = route.index(int(u))
        # A string of the given length containing u, at a random offset.
        first = int(rng.integers(max(0, at - length + 1), min(at, len(route) - length) + 1))
        removed += route[first : first + length]
        if len(done_routes) >= strings:
            break
    state.remove(removed)
    return state


def worst_removal(state: State, rng: np.random.Generator, size: int) -> State:
    """Tasks earning the least per second they cost their route (randomised by rank), so
    their time can go to better ones."""
    inst = state.inst
    tasks, ratio = [], []
    for v, route in enumerate(state.routes):
        if not route:
            continue
        nodes, time = state.nodes(v), inst.travel_s[v]
        saving_s = (
            time[nodes[:-2], nodes[1:-1]]
            + time[nodes[1:-1], nodes[2:]]
            - time[nodes[:-2], nodes[2:]]
            + inst.service_s[route]
        )
        tasks += route
        ratio += list(inst.value[v, route] / (saving_s + 1e-3 * float(inst.budget_s[v])))
    if not tasks:
        return state
    ranked = np.asarray(tasks)[np.argsort(ratio, kind="stable")]
    # Skewed random ranks: mostly the worst, sometimes a fairly good one.
    picks = np.unique((len(ranked) * rng.random(min(size, len(ranked))) ** 3).astype(int))
    state.remove(list(ranked[picks]))
    return state


def route_removal(state: State, rng: np.random.Generator, size: int) -> State:
    """Empty one route (or its first ``size`` tasks from a random point): lets the repair
    rebuild a whole vehicle's tour around different tasks."""
    busy = [v for v, r in enumerate(state.routes) if r]
    if busy:
        v = int(rng.choice(busy))
        route = state.routes[v]
        first = int(rng.integers(0, max(1, len(route) - size + 1)))
        state.remove(route[first : first + size])
    return state


CHAIN = 6  # a planted chain: the drawn spot and its five nearest free spots
CHAIN_SEEDS = 256  # at most this many spots are weighed as the chain's head (bounds the cost)


def chain_planting(state: State, rng: np.random.Generator, size: int) -> State:
    """Empty one route and plant in it a chain of nearby unrouted spots.

    Greedy repair inserts one spot at a time, so a rich cluster far from every route is never
    opened: each of its spots alone is a long detour (TOP p4.3.m: the 1025 local optimum and
    the best-known 1063 differ by one cluster of eight spots). Here the head is drawn among
    the free spots the vehicle may treat, with weight (priority of the spot and its
    ``CHAIN - 1`` nearest free spots) squared, and those spots go in first, each at its
    cheapest position while it fits; the repair fills the rest. ``size`` is unused: the whole
    route is the ruin. (docs/planner.md, fourth round, variant C.)
    """
    busy = [v for v, r in enumerate(state.routes) if r]
    if not busy:
        return state
    inst = state.inst
    v = int(rng.choice(busy))
    state.remove(list(state.routes[v]))
    free = np.flatnonzero((state.owner < 0) & inst.allowed[v] & (inst.value[v] > 0))
    if not len(free):
        return state
    heads = free
    if len(free) > CHAIN_SEEDS:
        heads = np.sort(rng.choice(free, size=CHAIN_SEEDS, replace=False))
    near = free[np.argsort(inst.dist_m[np.ix_(heads, free)], axis=1, kind="stable")[:, :CHAIN]]
    weight = inst.value[v, near].sum(axis=1)
    weight = weight * weight  # a product, not pow: agents on any machine draw alike
    chain = near[int(rng.choice(len(heads), p=weight / weight.sum()))]
    for u in chain:
        u = int(u)
        state.refresh_route(v)
        if state.ins_s[v, u] + inst.service_s[u] <= state.slack_s(v):
            state.try_insert(v, u)
    return state


RUIN_OPERATORS = (
    random_removal, related_removal, string_removal, worst_removal, route_removal, chain_planting,
)
