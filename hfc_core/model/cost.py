"""Mission time (eq. 8) and mission cost (eq. 9) of routes, as the HFC operators evaluate them.

Eq. (9), per vehicle i with mission time T^M, battery T^B and collected priority P::

    Cost_i = l1 |T^M - T^B| + l2 / P + l3 * eps * max(0, T^M - T^B)

The paper does not publish its weights. Table I constrains them roughly: NCM1's V2 (13 spots,
806 s to spare, no violation) costs 0.317e5 and NCM2's V1 (19 spots, 13 s to spare) 0.227e5,
which with P ~ 50 per spot gives l2 ~ 2e7; NCM1's V1 (41 spots, 2002 s overdue) costs 1.053e5,
which then gives l1 + l3 * eps ~ 45 per second, and V2's 806 s spare give l1 ~ 5. We use
l1 = 5 /s, l2 = 2e7, l3 = 1, eps = 40 /s. Table I is not reproducible term by term (CM's V1,
21 spots, costs half of NCM2's V1 with 19), so we match magnitudes, not digits.

The weights carry units (seconds, priority points), so `CostWeights.scaled_to` rescales l2 to
a problem's time and priority scales (the TOP instances have budgets of ~30 and scores of ~10):
the screening operator then trades seconds against priority as it does in the paper's setting.
An empty route's priority sum is 0, so P is floored at ``priority_floor``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Sequence

import numpy as np

from hfc_core.model.errors import ScenarioError
from hfc_core.model.feasibility import fits
from hfc_core.model.problem import Problem

PAPER_BATTERY_S = 3600.0
PAPER_TOTAL_PRIORITY = 90 * 50.5  # 90 spots, rho ~ U(1, 100)


@dataclass(frozen=True)
class CostWeights:
    """lambda_1..3 and epsilon of eq. (9)."""

    lambda1_per_s: float = 5.0
    lambda2: float = 2.0e7
    lambda3: float = 1.0
    epsilon_per_s: float = 40.0
    priority_floor: float = 1.0

    def __post_init__(self) -> None:
        for name in ("lambda1_per_s", "lambda2", "lambda3", "epsilon_per_s", "priority_floor"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")
        if self.priority_floor <= 0:
            raise ValueError("priority_floor must be positive")
        if self.lambda3 * self.epsilon_per_s <= 0:
            raise ValueError("lambda3 * epsilon must be positive, or violation costs nothing")

    def scaled_to(self, problem: Problem) -> "CostWeights":
        """These weights with l2 moved from the paper's scales (3600 s batteries, 90 spots of
        mean priority 50.5) to ``problem``'s, keeping the seconds-vs-priority trade-off."""
        time_scale = float(np.mean([v.battery_s for v in problem.vehicles])) / PAPER_BATTERY_S
        total = float(problem.priority.sum())
        priority_scale = total / PAPER_TOTAL_PRIORITY if total > 0 else 1.0
        return replace(self, lambda2=self.lambda2 * time_scale * priority_scale)


def eq9_cost(
    time_s: np.ndarray | float, battery_s: np.ndarray | float, priority: np.ndarray | float,
    weights: CostWeights,
) -> np.ndarray:
    """Eq. (9), vectorised over routes (or over candidate removals of one route)."""
    time_s, battery_s = np.asarray(time_s, dtype=float), np.asarray(battery_s, dtype=float)
    over = np.maximum(0.0, time_s - battery_s)
    return (
        weights.lambda1_per_s * np.abs(time_s - battery_s)
        + weights.lambda2 / np.maximum(np.asarray(priority, dtype=float), weights.priority_floor)
        + weights.lambda3 * weights.epsilon_per_s * over
    )


class RouteModel:
    """What the operators need from a `Problem`, laid out for speed: each vehicle's travel
    times (eq. 8; through the current if the scenario has one) both as an array (vectorised
    evaluations) and as nested lists (the O(1) move deltas), and the 3-D metric of eq. 7."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        self.n = problem.n_tasks
        self.k = problem.n_vehicles
        self.dist_m = problem.dist_m
        self.travel_s = problem.travel_s
        self.symmetric = problem.symmetric
        self.service_s = problem.service_s
        self.priority = problem.priority
        self.start = [problem.start_node(v) for v in range(self.k)]
        self.end = [problem.end_node(v) for v in range(self.k)]
        self.speed_mps = np.array([v.speed_mps for v in problem.vehicles])
        self.battery_s = np.array([v.battery_s for v in problem.vehicles])
        self.xyz = problem.xyz

    @cached_property
    def dist_rows(self) -> list[list[float]]:
        return self.dist_m.tolist()

    @cached_property
    def time_rows(self) -> list[list[list[float]]]:
        """Per vehicle, its travel times as nested lists (one list per distinct array)."""
        rows: dict[int, list[list[float]]] = {}
        for t in self.travel_s:
            if id(t) not in rows:
                rows[id(t)] = t.tolist()
        return [rows[id(t)] for t in self.travel_s]

    def length_m(self, v: int, route: Sequence[int]) -> float:
        nodes = np.fromiter((self.start[v], *route, self.end[v]), dtype=np.intp)
        return float(self.dist_m[nodes[:-1], nodes[1:]].sum())

    def travel_time_s(self, v: int, route: Sequence[int]) -> float:
        nodes = np.fromiter((self.start[v], *route, self.end[v]), dtype=np.intp)
        return float(self.travel_s[v][nodes[:-1], nodes[1:]].sum())

    def time_s(self, v: int, route: Sequence[int]) -> float:
        """Eq. (8): travel at the vehicle's speed plus each spot's injection time once."""
        service = float(self.service_s[list(route)].sum()) if route else 0.0
        return self.travel_time_s(v, route) + service

    def cost(self, v: int, route: Sequence[int], weights: CostWeights) -> float:
        """Eq. (9) cost of vehicle ``v`` on ``route``."""
        priority = float(self.priority[list(route)].sum()) if route else 0.0
        return float(eq9_cost(self.time_s(v, route), self.battery_s[v], priority, weights))

    def times_s(self, routes: Sequence[Sequence[int]]) -> np.ndarray:
        return np.array([self.time_s(v, r) for v, r in enumerate(routes)])

    def priorities(self, routes: Sequence[Sequence[int]]) -> np.ndarray:
        return np.array([float(self.priority[list(r)].sum()) if r else 0.0 for r in routes])

    def costs(self, routes: Sequence[Sequence[int]], weights: CostWeights) -> np.ndarray:
        """Per-vehicle eq. (9) cost of a fleet plan; their sum is Cost_total."""
        return eq9_cost(self.times_s(routes), self.battery_s, self.priorities(routes), weights)

    def violation_s(self, routes: Sequence[Sequence[int]]) -> np.ndarray:
        return np.maximum(0.0, self.times_s(routes) - self.battery_s)

    def require_reachable(self) -> None:
        """A budgeted mode cannot return a feasible plan if a vehicle cannot even go straight
        from its start to its rendezvous: that is a scenario error, not a planner failure."""
        for v in range(self.k):
            if not fits(self.time_s(v, []), self.battery_s[v]):
                vid = self.problem.vehicles[v].id
                raise ScenarioError(
                    f"vehicle {vid}: start to rendezvous takes {self.time_s(v, []):.1f} s, "
                    f"more than its battery of {self.battery_s[v]:.1f} s"
                )
