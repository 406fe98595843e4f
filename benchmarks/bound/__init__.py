"""An upper bound on the priority any plan can collect: column generation on the set-packing
LP of the team orienteering problem (routes as columns), certified by a Lagrangian bound.

Why the bound is valid, for any task prices ``pi >= 0`` (not only LP-optimal duals): take any
feasible plan, one route ``r_v`` (maybe empty) per vehicle. Each task is served at most once
and ``pi >= 0``, so ``sum_v pi(r_v) <= sum_i pi_i``; hence

    collected = sum_v (p(r_v) - pi(r_v)) + sum_v pi(r_v)
             <= sum_classes size_c * max(0, V_c(pi)) + sum_i pi_i,

where ``V_c(pi)`` is any number at least the best reduced profit ``p(r) - pi(r)`` of an
elementary route of class ``c`` that fits the battery. `benchmarks.bound.pricing` computes such
a ``V_c`` exactly over a relaxation (ng-routes, a budget a hair above the battery) that holds
every route `hfc_core.model.feasibility.fits` accepts. So every exact pricing yields a valid bound;
the best one seen is reported, plus a margin for floating-point rounding. Nothing rests on
the LP solver's accuracy: its answers only choose ``pi``. The best such bound is the optimum
of the LP over the relaxed routes (LP duality); ``lp``, the restricted master's optimum, is
at most that.

The prices come from the restricted master's dual kept in a box around the best prices so far
(BoxStep stabilisation, `Master.box_dual`): the master's own duals jump between far-apart
vertices of a huge optimal face while it is degenerate (which it is from the start, when a
good plan is among its columns). The first centre prices every task by the time it takes
(`_time_prices`). A cheap heuristic pricing runs first at each step; the exact one only when
the heuristic leaves room for a better bound.

Not supported: a tidal (time-dependent) current, whose routes are timed as flown.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from benchmarks.bound.classes import VehicleClass, vehicle_classes
from benchmarks.bound.master import Master
from benchmarks.bound.pricing import Pricing
from hfc_core.model.problem import Problem

__all__ = ["Bound", "upper_bound"]

ROUND_MARGIN = 1e-9  # relative to the total priority: covers the rounding of every sum
REDUCED_EPS = 1e-6  # a column enters when its reduced profit beats the class dual by this
BOX_GROWTH = 2.0  # the box doubles after a better bound, halves otherwise
BOX_RANGE = (1 / 64, 8.0)  # box sizes allowed, relative to the first


@dataclass(frozen=True)
class Bound:
    """``upper``: no plan collects more priority. ``lp``: the last restricted master value (a
    plan-independent figure <= the LP optimum over the relaxed routes)."""

    upper: float
    lp: float
    columns: int
    iterations: int
    converged: bool  # the LP over all relaxed routes is solved (up to the pricing's slack)
    seconds: float
    history: tuple[tuple[int, float, float, float], ...] = ()  # (iteration, s, lp, upper)


def _seed(problem: Problem, classes: list[VehicleClass], master: Master,
          plans: Sequence[Sequence[Sequence[int]]] | None, heuristic_s: float,
          heuristic_runs: int) -> None:
    """Columns to start from: every single task, and the routes of good plans (``plans``, or
    `best`'s, ``heuristic_runs`` runs of ``heuristic_s`` seconds each)."""
    for c, cls in enumerate(classes):
        for i in range(problem.n_tasks):
            if cls.route_time([i]) <= cls.budget:
                master.add(c, (i,))
    if plans is None and heuristic_s > 0:
        from hfc_core.solve import solve

        plans = [[list(r) for r in solve(problem, "best", seed=s,
                                         time_limit_s=heuristic_s).plan.routes]
                 for s in range(heuristic_runs)]
    of_vehicle = {v: c for c, cls in enumerate(classes) for v in cls.vehicles}
    for plan in plans or ():
        for v, route in enumerate(plan):
            cls = classes[of_vehicle[v]]
            if route and cls.route_time(list(route)) <= cls.budget:
                master.add(of_vehicle[v], tuple(int(t) for t in route))


def upper_bound(problem: Problem, time_limit_s: float = 90.0, *,
                plans: Sequence[Sequence[Sequence[int]]] | None = None,
                heuristic_s: float = 1.0, heuristic_runs: int = 1, ng_size: int = 12,
                bound_ng: int = 4, box: float = 0.1, max_columns: int = 100,
                heuristic_pricing: int | None = 50, slack: float = 0.005, gap: float = 1e-4,
                timer: Callable[[], float] = time.perf_counter) -> Bound:
    """A valid upper bound on the priority of any plan of ``problem``.

    ``plans``: plans (routes per vehicle) to seed the LP with (default: `best`,
    ``heuristic_runs`` runs of ``heuristic_s`` seconds). ``ng_size``: neighbours of the
    ng-relaxation (more: closer to elementary, slower). ``bound_ng``: neighbours of the
    pricing's completion bound. ``box``: first half-width of the price box, as a share of the
    mean priority. ``heuristic_pricing``: labels per node and round of the heuristic pricing
    (None: exact pricing only). ``slack``: the exact pricing only proves that no route beats
    the heuristic's best by more than this share of the first box (costs at most that per
    vehicle on the bound, saves much time). Stops after ``time_limit_s`` (checked between
    iterations), when the LP over the relaxed routes is solved (up to the slack), or when the
    bound is within ``gap`` (relative) of the restricted LP."""
    started = timer()
    classes = vehicle_classes(problem)
    priority = np.asarray(problem.priority, dtype=float)
    margin = ROUND_MARGIN * (1.0 + float(np.abs(priority).sum()))
    master = Master(problem.n_tasks, [c.size for c in classes], priority)
    _seed(problem, classes, master, plans, heuristic_s, heuristic_runs)
    reachable = np.zeros(problem.n_tasks, dtype=bool)
    for cls in classes:
        reachable |= cls.reach + cls.tail <= cls.budget
    if not reachable.any():  # no route can serve a task
        return Bound(0.0, 0.0, 0, 0, True, timer() - started)
    best = math.fsum(priority[reachable]) + margin  # no plan collects more
    first = box * max(float(priority[reachable].mean()), 1e-9)
    delta = first
    center = _time_prices(classes, priority, margin, ng_size, bound_ng, heuristic_pricing)
    center_bound = math.inf
    history: list[tuple[int, float, float, float]] = []
    iteration, converged = 0, False
    while True:
        iteration += 1
        box_center, box_delta = center, delta
        pi, mu, model = master.box_dual(center, delta)
        bound, routes, exact = _price_all(classes, master, priority, pi, center_bound,
                                          margin, slack=slack * first, ng_size=ng_size,
                                          bound_ng=bound_ng, max_columns=max_columns,
                                          heuristic=heuristic_pricing)
        rp = priority - pi
        added = sum(master.add(c, route) for c, route in routes
                    if float(rp[list(route)].sum()) - mu[c] > REDUCED_EPS)
        if exact:
            best = min(best, bound)
        if exact and bound < center_bound:
            center, center_bound = pi, bound
            delta = min(delta * BOX_GROWTH, first * BOX_RANGE[1])
        else:
            delta = max(delta / BOX_GROWTH, first * BOX_RANGE[0])
        inside = _inside(pi, box_center, box_delta)
        lp = master.solve().value
        history.append((iteration, timer() - started, lp, best))
        if exact and added == 0 and inside:
            converged = True  # no column beyond the model and the box did not bind
            break
        if best - lp <= gap * abs(best) or timer() - started >= time_limit_s:
            break
    lp = master.solve(interior=False).value  # the exact vertex, not the interior estimate
    return Bound(upper=best, lp=lp, columns=len(master.columns), iterations=iteration,
                 converged=converged, seconds=timer() - started, history=tuple(history))


def _time_prices(classes: list[VehicleClass], priority: np.ndarray, margin: float,
                 ng_size: int, bound_ng: int, heuristic: int | None) -> np.ndarray:
    """First prices: a task is worth what the time it takes is worth. With ``w_i`` its service
    plus the mean of its two shortest legs in, prices ``max(0, p_i - beta * w_i)`` leave every
    task a reduced profit proportional to its time; the ``beta`` of the lowest (heuristically
    estimated) bound on a grid is taken. A start only: any prices give a valid bound."""
    n = len(priority)
    travel = classes[0].travel[:n, :n] + np.diag(np.full(n, np.inf))
    w = classes[0].service + np.sort(travel, axis=0)[: min(2, max(n - 1, 1))].mean(axis=0)
    best, prices = math.inf, np.zeros(n)
    rate = float(priority.mean()) / max(float(w[np.isfinite(w)].mean()) if np.isfinite(w).any()
                                        else 1.0, 1e-9)  # priority per second, on average
    for beta in np.linspace(0.2, 1.2, 9) * rate:
        pi = np.maximum(priority - beta * np.nan_to_num(w, posinf=0.0), 0.0)
        rp = priority - pi
        estimate = math.fsum(pi) + margin
        for cls in classes:
            pricing = Pricing(cls, rp, ng_size=ng_size, bound_ng=bound_ng)
            estimate += cls.size * max(0.0, pricing.run(0.0, exact=heuristic is None,
                                                        max_per_node=heuristic or 50).value)
        if estimate < best:
            best, prices = estimate, pi
    return prices


def _inside(pi: np.ndarray, center: np.ndarray, delta: float) -> bool:
    """Did the box leave the prices free (no price at a box side other than zero)?"""
    tol = 1e-7 + 1e-4 * delta
    lower = np.maximum(center - delta, 0.0)
    at_lower = (lower > 0.0) & (pi <= lower + tol)
    return not (at_lower.any() or (pi >= center + delta - tol).any())


def _price_all(classes: list[VehicleClass], master: Master, priority: np.ndarray,
               pi: np.ndarray, beat: float, margin: float, *, slack: float, ng_size: int,
               bound_ng: int, max_columns: int, heuristic: int | None
               ) -> tuple[float, list[tuple[int, tuple[int, ...]]], bool]:
    """Price every class at task prices ``pi``: (the Lagrangian bound they certify, or a
    lower estimate when the heuristic already shows it cannot beat ``beat``; the routes
    found; whether the figure is the certified bound)."""
    rp = priority - pi
    fixed = math.fsum(pi) + margin
    low, routes, pricings = [], [], []
    for c, cls in enumerate(classes):
        known = [float(rp[list(r)].sum()) for k, r in master.columns if k == c]
        low.append(max([0.0, *known]))
        pricing = Pricing(cls, rp, ng_size=ng_size, bound_ng=bound_ng)
        pricings.append(pricing)
        if heuristic is not None:
            found = pricing.run(low[c], exact=False, max_per_node=heuristic,
                                max_routes=max_columns)
            low[c] = found.value
            routes += [(c, r) for _, r in found.routes]
    estimate = fixed + sum(cls.size * v for cls, v in zip(classes, low))  # <= the bound
    if estimate >= beat:
        return estimate, routes, False
    total = fixed
    for c, (cls, pricing) in enumerate(zip(classes, pricings)):
        # Above low + slack: the search is much faster than at low, and its answer (at least
        # the threshold) is still at least every route's reduced profit.
        found = pricing.run(low[c] + slack, exact=True, max_routes=max_columns)
        routes += [(c, r) for _, r in found.routes]
        total += cls.size * max(0.0, found.value)
    return total, routes, True
