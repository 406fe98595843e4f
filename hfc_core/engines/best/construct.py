"""Construction after the paper's operators: clustering, ordering, screening, cooperation.

- clustering: one group of tasks per vehicle (the paper's k-means/FCM of
  `hfc_core.engines.operators.clustering` when the caller passes its labels; otherwise k-medoids on
  the travel metric, which also respects land);
- ordering: a nearest-neighbour tour through the cluster, shortened by 2-opt and or-opt;
- screening: drop the task earning least per second it costs until the route fits the battery;
- cooperation: vehicles with time left take abandoned tasks (`insert.fill`).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from hfc_core.engines.best.insert import fill
from hfc_core.engines.best.instance import Instance
from hfc_core.engines.best.intra import improve_route
from hfc_core.engines.best.state import State
from hfc_core.model.feasibility import fits


def medoid_clusters(inst: Instance, rng: np.random.Generator, rounds: int = 10) -> np.ndarray:
    """Cluster label 0..k-1 per plannable task (-1 for tasks no vehicle may take)."""
    n, k = inst.n, inst.k
    pool = np.flatnonzero(inst.allowed.any(axis=0) & (inst.value.max(axis=0) > 0))
    labels = np.full(n, -1, dtype=np.int64)
    if not len(pool):
        return labels
    d = inst.dist_m[np.ix_(pool, pool)]
    # Farthest-point seeding from a random task: spread, deterministic given the rng.
    medoids = [int(rng.integers(len(pool)))]
    while len(medoids) < min(k, len(pool)):
        medoids.append(int(d[medoids].min(axis=0).argmax()))
    for _ in range(rounds):
        assign = d[medoids].argmin(axis=0)
        new = []
        for c in range(len(medoids)):
            members = np.flatnonzero(assign == c)
            new.append(int(members[d[np.ix_(members, members)].sum(axis=0).argmin()]))
        if new == medoids:
            break
        medoids = new
    assign = d[medoids].argmin(axis=0)
    labels[pool] = assign
    return labels


def match_clusters(inst: Instance, labels: np.ndarray) -> np.ndarray:
    """Relabel clusters so each goes to the vehicle whose start and end are nearest to it."""
    k = inst.k
    cost = np.zeros((k, k))
    for c in range(k):
        members = np.flatnonzero(labels == c)
        if len(members):
            cost[:, c] = (
                inst.dist_m[inst.start][:, members].mean(axis=1)
                + inst.dist_m[inst.end][:, members].mean(axis=1)
            )
    vehicle_of = np.empty(k, dtype=np.int64)
    rows, cols = linear_sum_assignment(cost)
    vehicle_of[cols] = rows
    out = labels.copy()
    out[labels >= 0] = vehicle_of[labels[labels >= 0]]
    return out


def order(inst: Instance, v: int, tasks: list[int]) -> list[int]:
    """Nearest-neighbour tour (in travel time) from ``v``'s start, then 2-opt/or-opt."""
    dist = inst.travel_s[v]
    left = list(tasks)
    at, route = int(inst.start[v]), []
    while left:
        nxt = left[int(dist[at, left].argmin())]
        route.append(nxt)
        left.remove(nxt)
        at = nxt
    nodes = np.array([inst.start[v], *route, inst.end[v]], dtype=np.int64)
    return [int(u) for u in improve_route(dist, nodes, inst.symmetric)[1:-1]]


def screen(inst: Instance, v: int, route: list[int]) -> list[int]:
    """Drop the task with the least value per second saved until the route fits."""
    time = inst.travel_s[v]
    route = list(route)
    while route and not fits(inst.route_time_s(v, route), float(inst.budget_s[v])):
        nodes = np.array([inst.start[v], *route, inst.end[v]], dtype=np.int64)
        prev, cur, nxt = nodes[:-2], nodes[1:-1], nodes[2:]
        saving = time[prev, cur] + time[cur, nxt] - time[prev, nxt]
        saving_s = saving + inst.service_s[route] + 1e-9
        route.pop(int((inst.value[v, route] / saving_s).argmin()))
    return route


def construct(inst: Instance, rng: np.random.Generator, labels: np.ndarray | None = None) -> State:
    """A feasible plan from clusters: ``labels`` gives each task's vehicle (-1 = none);
    without it, k-medoids clusters matched to the vehicles."""
    if labels is None:
        labels = match_clusters(inst, medoid_clusters(inst, rng))
    routes = []
    for v in range(inst.k):
        members = [
            int(u) for u in np.flatnonzero(labels == v)
            if inst.allowed[v, u] and inst.value[v, u] > 0
        ]
        route = screen(inst, v, order(inst, v, members))
        nodes = np.array([inst.start[v], *route, inst.end[v]], dtype=np.int64)
        better = [int(u) for u in improve_route(inst.travel_s[v], nodes, inst.symmetric)[1:-1]]
        if inst.clock is not None and not inst.route_time_s(v, better) < inst.route_time_s(
                v, route):
            better = route  # shorter by the estimate only, not as flown through the tide
        routes.append(better)
    state = State(inst, routes)
    return fill(state)
