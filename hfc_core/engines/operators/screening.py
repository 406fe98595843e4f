"""Screening operator (paper section III-3, Algorithm 2; Algorithm 4 lines 24-38).

Reading of Algorithm 2: while the route overruns its battery, the eq. (9) cost of the route
without each one of its tasks is evaluated ("the cost value of the candidate is sequentially
evaluated in the absence of only one task") and the task whose absence gives the lowest cost is
abandoned ("the lowest cost value decides which task to be abandoned"). The removal does not
depend on where a task lies on the route, so spots are dropped from the whole cluster, not
from its far end (the contrast the paper draws with the GA of section IV-C). Algorithm 4 then
keeps the screened route only if its cost is lower (lines 30-33).

All single-task removals of a route are evaluated in one numpy shot.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from hfc_core.model.cost import CostWeights, RouteModel, eq9_cost
from hfc_core.model.feasibility import fits


def removal_costs(
    route: Sequence[int], *, model: RouteModel, v: int, weights: CostWeights
) -> tuple[np.ndarray, np.ndarray]:
    """(eq. 9 cost, mission time) of ``route`` without its i-th task, for every i."""
    nodes = np.fromiter((model.start[v], *route, model.end[v]), dtype=np.intp)
    d = model.travel_s[v]
    prev, cur, nxt = nodes[:-2], nodes[1:-1], nodes[2:]
    saved_s = d[prev, cur] + d[cur, nxt] - d[prev, nxt]
    time_s = model.time_s(v, route)
    new_time_s = time_s - saved_s - model.service_s[cur]
    new_priority = float(model.priority[cur].sum()) - model.priority[cur]
    return eq9_cost(new_time_s, model.battery_s[v], new_priority, weights), new_time_s


def screen_route(
    route: Sequence[int], *, model: RouteModel, v: int, weights: CostWeights
) -> list[int]:
    """Algorithm 2 on one route: abandon the cheapest-to-lose task until the route fits."""
    out = list(route)
    while out and not fits(model.time_s(v, out), model.battery_s[v]):
        costs, _ = removal_costs(out, model=model, v=v, weights=weights)
        del out[int(np.argmin(costs))]
    return out


def screen(
    routes: Sequence[Sequence[int]], rng: np.random.Generator, *, model: RouteModel,
    weights: CostWeights,
) -> list[list[int]]:
    """Algorithm 4 lines 27-36 for one individual: screen each overdue route, keep the screened
    version if it costs less. (Deterministic; ``rng`` keeps the operator signature.)"""
    out = [list(r) for r in routes]
    for v, route in enumerate(out):
        if fits(model.time_s(v, route), model.battery_s[v]):
            continue
        screened = screen_route(route, model=model, v=v, weights=weights)
        if model.cost(v, screened, weights) < model.cost(v, route, weights):
            out[v] = screened
    return out
