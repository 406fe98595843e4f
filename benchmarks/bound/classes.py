"""Vehicle classes and the relaxed route set each one prices over.

Vehicles with the same start, rendezvous, battery and travel times to, from and between all
tasks can fly exactly the same routes, so they share one pricing problem and one convexity row
(at most ``size`` of the class's routes in a plan).

The relaxed route set of a class holds every ng-route (`benchmarks.bound.ng`) start -> tasks ->
end whose time, summed leg by leg, is at most ``budget`` = battery + `FEASIBILITY_TOL_S` +
``slack``. ``slack`` (a millionth of a second per hour, and more if the travel times break the
triangle inequality, see `skip_slack`) absorbs the difference between two summation orders of
the same route, so every route `hfc_core.model.feasibility.fits` is in the set.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hfc_core.model.feasibility import FEASIBILITY_TOL_S
from hfc_core.model.problem import Problem

REL_SLACK = 1e-9  # relative: far above any rounding of a sum of a few thousand legs


@dataclass(frozen=True, eq=False)
class VehicleClass:
    """One class; node numbering: tasks ``0..n-1``, start ``n``, end ``n + 1``."""

    vehicles: tuple[int, ...]
    travel: np.ndarray  # (n + 2, n + 2) seconds
    service: np.ndarray  # (n,)
    battery: float
    budget: float  # battery + tolerance + slack: the relaxed limit
    reach: np.ndarray  # (n,) shortest time from the start to having served each task
    tail: np.ndarray  # (n,) shortest time from each task (served) to the end
    skip_ok: bool  # leaving a task out never makes a route longer (within the slack)

    @property
    def size(self) -> int:
        return len(self.vehicles)

    @property
    def n(self) -> int:
        return len(self.service)

    def route_time(self, route: list[int]) -> float:
        nodes = [self.n, *route, self.n + 1]
        return float(self.travel[nodes[:-1], nodes[1:]].sum() + self.service[route].sum())


def _local_travel(problem: Problem, v: int) -> np.ndarray:
    n = problem.n_tasks
    idx = np.r_[np.arange(n), problem.start_node(v), problem.end_node(v)]
    return np.asarray(problem.travel_s[v], dtype=float)[np.ix_(idx, idx)]


def shortest(cost: np.ndarray) -> np.ndarray:
    """All-pairs shortest paths (Floyd-Warshall) of a square cost matrix."""
    d = np.array(cost, dtype=float)
    for k in range(d.shape[0]):
        np.minimum(d, d[:, k : k + 1] + d[k : k + 1, :], out=d)
    return d


def skip_slack(travel: np.ndarray, service: np.ndarray) -> float:
    """Largest amount by which leaving one task ``b`` out of a leg ``a -> b -> c`` lengthens
    it: ``max(travel[a, c] - travel[a, b] - service[b] - travel[b, c])`` (<= 0 when the
    triangle inequality holds, as in still water)."""
    n = len(service)
    worst = -np.inf
    src = np.r_[np.arange(n), n]  # tasks and the start
    dst = np.r_[np.arange(n), n + 1]  # tasks and the end
    direct = travel[np.ix_(src, dst)]
    for b in range(n):
        via = travel[src, b][:, None] + service[b] + travel[b, dst][None, :]
        gap = direct - via
        gap[src == b, :] = -np.inf
        gap[:, dst == b] = -np.inf
        worst = max(worst, float(gap.max()))
    return worst


def vehicle_classes(problem: Problem) -> list[VehicleClass]:
    """Group the vehicles into classes (first vehicle of each class first)."""
    if problem.current is not None and not problem.current.steady:
        raise ValueError("upper bound: a time-dependent (tidal) current is not supported: its "
                         "routes are timed as flown, which the static matrices only bound above")
    n = problem.n_tasks
    service = np.asarray(problem.service_s, dtype=float)
    groups: list[tuple[np.ndarray, float, list[int]]] = []
    for v, vehicle in enumerate(problem.vehicles):
        travel = _local_travel(problem, v)
        for t, battery, members in groups:
            if battery == vehicle.battery_s and np.array_equal(t, travel):
                members.append(v)
                break
        else:
            groups.append((travel, vehicle.battery_s, [v]))
    out = []
    for travel, battery, members in groups:
        cost = travel[:n, :n] + service[None, :]
        np.fill_diagonal(cost, np.inf)
        between = shortest(cost)  # task a served -> task b served
        reach0 = travel[n, :n] + service
        reach = np.minimum(reach0, (reach0[:, None] + between).min(axis=0)) if n else reach0
        tail0 = travel[:n, n + 1]
        tail = np.minimum(tail0, (between + tail0[None, :]).min(axis=1)) if n else tail0
        slack = REL_SLACK * max(battery, 1.0)
        worst = skip_slack(travel, service) if n else 0.0
        skip_ok = worst <= slack / max(n, 1)
        budget = battery + FEASIBILITY_TOL_S + 2.0 * slack
        out.append(VehicleClass(tuple(members), travel, service, float(battery), budget,
                                reach, tail, skip_ok))
    return out
