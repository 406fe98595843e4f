"""Route-based crossover of two good plans, the restart point of later search runs.

Plans from different runs often hold complementary routes (one run got the north right,
another the south). The child takes whole routes from either parent: repeatedly the route that
brings the most value not yet covered, given to a free vehicle it fits (same start, end, speed
and battery as its own: in the TOP every vehicle is alike), with spots already taken cut out.
The repair then fills what is left.
"""

from __future__ import annotations

import numpy as np

from hfc_core.best.instance import Instance
from hfc_core.best.state import State


def compatible(inst: Instance) -> np.ndarray:
    """(k, k) bool: can vehicle w drive vehicle v's route (same terminals, speed, battery)."""
    d = inst.dist_m
    same_start = d[inst.start[:, None], inst.start[None, :]] == 0
    same_end = d[inst.end[:, None], inst.end[None, :]] == 0
    same_speed = inst.speed_mps[:, None] == inst.speed_mps[None, :]
    same_budget = inst.budget_s[:, None] == inst.budget_s[None, :]
    same_allowed = (inst.allowed[:, None, :] == inst.allowed[None, :, :]).all(axis=2)
    same_value = (inst.value[:, None, :] == inst.value[None, :, :]).all(axis=2)
    fits = same_start & same_end & same_speed & same_budget & same_allowed & same_value
    return fits | np.eye(inst.k, dtype=bool)


def route_crossover(a: State, b: State, rng: np.random.Generator) -> State:
    """A child made of the parents' routes (see module doc); it may leave vehicles empty."""
    inst = a.inst
    fits = compatible(inst)
    pool = [(v, r) for parent in (a, b) for v, r in enumerate(parent.routes) if r]
    taken = np.zeros(inst.n, dtype=bool)
    routes: list[list[int]] = [[] for _ in range(inst.k)]
    free = set(range(inst.k))
    while pool and free:
        best = None
        for i, (v, route) in enumerate(pool):
            rest = [u for u in route if not taken[u]]
            gain = float(inst.value[v, rest].sum()) if rest else 0.0
            gain *= 1.0 + 0.1 * rng.random()  # mild noise: different children from one pair
            if best is None or gain > best[0]:
                best = (gain, i, rest)
        gain, i, rest = best
        v, _ = pool.pop(i)
        if gain <= 0:
            break
        owners = [w for w in sorted(free) if fits[v, w]]
        if not owners:
            continue
        w = v if v in owners else owners[0]
        routes[w] = rest
        free.discard(w)
        taken[rest] = True
    child = State(inst, routes)
    # Cutting spots out can lengthen a leg where the metric is not quite a metric (land
    # clearance): drop from the end until each route fits again.
    for v in range(inst.k):
        while child.routes[v] and child.slack_s(v) < 0:
            child.set_route(v, child.routes[v][:-1])
    return child
