"""Pricing: the best route of a vehicle class for given task prices, over the relaxed set.

Three labellings (`benchmarks.bound.labels`), each pruning the next:

1. Forwards, every walk (no memory), unpruned: ``prefix(j, t)`` is at least the reduced
   profit of every walk from the start through ``j`` that leaves time ``t`` after ``j``.
2. Backwards, ng-paths with ``bound_ng`` neighbours, for routes above a ``floor``: a path
   ``j -> ... -> end`` whose profit plus ``prefix`` cannot beat the floor is dropped. For a
   route above the floor, its prefix is a walk, so none of its suffixes is dropped:
   ``completion(j, t)`` (`profile`) is at least the profit of every elementary completion
   of such a route after a label at ``j`` at time ``t``.
3. Forwards, ng-paths with ``ng_size`` neighbours, from the start, for routes above a
   ``threshold >= floor``: a label whose profit plus ``completion`` cannot beat the threshold
   is dropped, and the threshold rises to the best route found so far. Every kept label may
   end (go straight to the end); the routes above the threshold are the answer.

Why the answer bounds every elementary route ``r`` of the class: if ``value(r)`` is above
the threshold, follow ``r`` from the start. Each prefix of ``r`` is a label, or is dominated
by a kept label at the same node (no later, no less profit, memory forbidding no more), and
the rest of ``r`` is an elementary completion of that label: it fits after it, and label plus
rest is an ng-route at least as good as ``r``. No such label is dropped by step 3, since its
profit plus ``completion`` is at least that value; so the label of ``r``'s last task (or its
dominator) ends, and a route at least as good is found. Hence ``max(threshold, best found)
>= max over elementary routes``: the value the Lagrangian bound needs. Steps 1-2 only make
step 3 fast; they never make it miss ``r``.

Tasks whose reduced profit is not positive are left out when the class's travel times let any
task be skipped without lengthening a route (`VehicleClass.skip_ok`): dropping them from any
route gives a route in the set that is at least as good.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from benchmarks.bound.classes import VehicleClass
from benchmarks.bound.labels import Completion, Direction, Labels, label
from benchmarks.bound.ng import ng_sets

PROFILE_CELLS = 4096  # time grid of the completion bound
PER_END = 4  # routes returned per last task (diverse columns)


@dataclass(frozen=True)
class Priced:
    """What one pricing found: ``value`` >= the best reduced profit of any elementary route
    when ``exact`` (the threshold if nothing beat it), and routes that beat the threshold
    (best first, as task indices)."""

    value: float
    exact: bool
    routes: tuple[tuple[float, tuple[int, ...]], ...]
    labels: int


def candidates(cls: VehicleClass, rp: np.ndarray) -> np.ndarray:
    """Tasks the pricing must consider."""
    live = cls.reach + cls.tail <= cls.budget
    if cls.skip_ok:
        live &= rp > 0.0
    return np.flatnonzero(live)


def directions(cls: VehicleClass, rp: np.ndarray, cand: np.ndarray
               ) -> Callable[[bool, int], Direction]:
    """``make(forward, k)``: the forward or backward walk over the tasks ``cand`` with ``k``
    ng-neighbours (``k`` = 0: every walk)."""
    n = cls.n
    tr, sv = cls.travel, cls.service[cand]
    arc = tr[np.ix_(cand, cand)] + sv[None, :]
    np.fill_diagonal(arc, np.inf)
    closeness = tr[np.ix_(cand, cand)] + tr[np.ix_(cand, cand)].T
    p = rp[cand]
    zero = np.zeros(len(cand))

    def make(forward: bool, k: int) -> Direction:
        ng = ng_sets(closeness, k)
        if forward:
            return Direction(arc=arc, gain_from=zero, gain_to=p, init_t=tr[n, cand] + sv,
                             init_p=p, rest=cls.tail[cand], budget=cls.budget, ng=ng)
        return Direction(arc=arc.T.copy(), gain_from=p, gain_to=zero, init_t=tr[cand, n + 1],
                         init_p=zero, rest=cls.reach[cand], budget=cls.budget, ng=ng)

    return make


def profile(labels: Labels, budget: float) -> Completion:
    """``f(j, t)`` >= the profit of every kept label at ``j`` whose time is at most
    ``budget - t`` (read off a time grid rounded so that no such label is missed)."""
    cell = budget / PROFILE_CELLS if budget > 0 else 1.0
    cells = PROFILE_CELLS + 4
    prof = np.full((len(labels.by_node), cells), -np.inf)
    ids = np.concatenate(labels.by_node) if labels.by_node else np.empty(0, dtype=np.int64)
    at = np.minimum(np.ceil(labels.t[ids] / cell), cells - 1).astype(np.int64)
    np.maximum.at(prof, (labels.node[ids], at), labels.p[ids])
    prof = np.maximum.accumulate(prof, axis=1)

    def bound(nodes: np.ndarray, times: np.ndarray) -> np.ndarray:
        # a label of time <= r sits in a cell <= ceil(r / cell) <= floor(r / cell) + 1; one
        # more cell absorbs the rounding of budget - t and of the divisions
        idx = np.floor((budget - times) / cell) + 2
        return prof[nodes, np.clip(idx, 0, cells - 1).astype(np.int64)]

    return bound


class Pricing:
    """One class at one set of task prices ``rp``.

    Completion bounds (`profile` of backward labels) serve a fast heuristic search and the
    exact one. Every forward walk (no memory) gives, once, a bound on the profit of reaching
    each task in a given time. For a search above ``floor``, backward ng-paths (``bound_ng``
    neighbours) that even with the best such prefix cannot beat ``floor`` are dropped: no
    route above ``floor`` ends that way. The rest bound every completion of every route above
    ``floor``, which is all a search above ``floor`` needs (one bound per floor, cached)."""

    def __init__(self, cls: VehicleClass, rp: np.ndarray, *, ng_size: int = 12,
                 bound_ng: int = 4) -> None:
        self.cls, self.rp, self.bound_ng = cls, rp, bound_ng
        self.cand = candidates(cls, rp)
        self.fwd: Direction | None = None
        self.labels = 0
        self._bounds: dict[tuple[int, float], Completion] = {}
        if self.cand.size:
            self._make = directions(cls, rp, self.cand)
            walks = label(self._make(True, 0), cls.budget, True)
            self._prefix = profile(walks, cls.budget)
            self.labels = walks.kept
            self.fwd = self._make(True, ng_size)
            self.finish = cls.travel[self.cand, cls.n + 1]

    def completion(self, floor: float, k: int) -> Completion:
        """A completion bound for searches above ``floor`` from backward ng-paths with ``k``
        neighbours (or a cached one of as many neighbours, built for a floor no higher)."""
        usable = [f for (kk, f) in self._bounds if kk == k and f <= floor]
        if usable:
            return self._bounds[(k, max(usable))]
        back = label(self._make(False, k), self.cls.budget, True, completion=self._prefix,
                     threshold=floor)
        self.labels += back.kept
        self._bounds[(k, floor)] = profile(back, self.cls.budget)
        return self._bounds[(k, floor)]

    def run(self, threshold: float, *, exact: bool = True, max_per_node: int = 50,
            max_routes: int = 30) -> Priced:
        """Routes of reduced profit above ``threshold`` (at most ``max_routes``, best first, at
        most `PER_END` ending at the same task but for the best). Exact: ``value`` is at
        least the best reduced profit of every elementary route (``threshold`` if none beats
        it). Heuristic (memories ignored in dominance, ``max_per_node`` labels per node and
        round): ``value`` is the best route found (a lower figure)."""
        cls = self.cls
        if self.fwd is None:
            return Priced(threshold, exact, (), 0)
        front = label(self.fwd, cls.budget, exact, max_per_node=None if exact else max_per_node,
                      completion=self.completion(threshold, self.bound_ng if exact else 0),
                      threshold=threshold,
                      finish=self.finish)
        ids = np.concatenate(front.by_node)
        value = np.where(front.t[ids] + self.finish[front.node[ids]] <= cls.budget,
                         front.p[ids], -math.inf)
        good = ids[value > threshold]
        good = good[np.argsort(-front.p[good], kind="stable")]
        routes: list[tuple[float, tuple[int, ...]]] = []
        per_end = np.zeros(len(self.cand), dtype=np.int64)
        for i in good:
            j = int(front.node[i])
            if routes and per_end[j] >= PER_END:
                continue
            per_end[j] += 1
            routes.append((float(front.p[i]),
                           tuple(int(self.cand[x]) for x in front.path(int(i)))))
            if len(routes) >= max_routes:
                break
        best = max(threshold, routes[0][0]) if routes else threshold
        self.labels += front.kept
        return Priced(best, exact, tuple(routes), self.labels)


def price(cls: VehicleClass, rp: np.ndarray, threshold: float, *, exact: bool = True,
          ng_size: int = 12, bound_ng: int = 4, max_per_node: int = 50,
          max_routes: int = 30) -> Priced:
    """`Pricing.run` in one call."""
    return Pricing(cls, rp, ng_size=ng_size, bound_ng=bound_ng).run(
        threshold, exact=exact, max_per_node=max_per_node, max_routes=max_routes)
