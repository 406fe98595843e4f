"""Mode ``best``: the paper's operators as construction, then adaptive ruin-and-recreate with
strong local search; anytime under a time limit, reproducible under an iteration budget.

Layout: `instance` (the arrays searched), `state` (routes, cached lengths and insertions),
`construct` (clustering, ordering, screening, cooperation), `insert` (greedy repair),
`intra` (2-opt, or-opt), `ruin` (destroy operators), `engine` (the search loop).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hfc_core.best.construct import construct
from hfc_core.best.engine import SearchParams, search
from hfc_core.best.instance import Instance, instance_from_problem
from hfc_core.best.state import State
from hfc_core.cost import CostWeights, RouteModel
from hfc_core.operators.clustering import METHODS, clusters_of_vehicles
from hfc_core.plan import Plan
from hfc_core.problem import Problem
from hfc_core.solve import IterationRecord, SolveResult, Stop

__all__ = ["SearchParams", "solve_best", "Instance", "State", "instance_from_problem"]


def _record(
    model: RouteModel, weights: CostWeights, routes: list[list[int]], iteration: int,
    elapsed_s: float,
) -> IterationRecord:
    """A convergence point in the faithful modes' terms (eq. 9 cost, violation, T_diff)."""
    times = model.times_s(routes)
    return IterationRecord(
        iteration=iteration,
        elapsed_s=elapsed_s,
        cost=tuple(model.costs(routes, weights).tolist()),
        violation_s=tuple(np.maximum(0.0, times - model.battery_s).tolist()),
        t_diff_s=tuple((model.battery_s - times).tolist()),
        priority=float(model.priorities(routes).sum()),
    )


def paper_clusters(problem: Problem, rng: np.random.Generator, method: str) -> np.ndarray:
    """Vehicle label per task from the paper's clustering operator (``method``)."""
    labels = np.full(problem.n_tasks, -1, dtype=np.int64)
    for v, members in enumerate(clusters_of_vehicles(RouteModel(problem), rng, method=method)):
        labels[members] = v
    return labels


def solve_best(
    problem: Problem,
    stop: Stop,
    rng: np.random.Generator,
    *,
    clustering: str = "kmeans",
    **params: Any,
) -> SolveResult:
    """Plan ``problem``: construct from the paper's clusters (``clustering``: one of
    `hfc_core.operators.clustering.METHODS`, or ``"medoids"`` for k-medoids on the travel
    metric), then search. ``params`` are `SearchParams` fields."""
    if clustering not in (*METHODS, "medoids"):
        raise ValueError(f"unknown clustering {clustering!r}")
    search_params = SearchParams(**params)
    inst = instance_from_problem(problem)
    model, weights = RouteModel(problem), CostWeights().scaled_to(problem)
    history: list[IterationRecord] = []

    def on_best(iteration: int, state: State) -> None:
        history.append(_record(model, weights, state.routes, iteration, stop.elapsed_s()))

    def fresh() -> State:
        labels = None if clustering == "medoids" else paper_clusters(problem, rng, clustering)
        return construct(inst, rng, labels)

    start = fresh()
    on_best(0, start)
    best, iterations = search(start, rng, stop, search_params, on_best, fresh)
    return SolveResult(
        plan=Plan.of(best.routes),
        mode="best",
        seed=-1,
        iterations=iterations,
        elapsed_s=stop.elapsed_s(),
        history=history,
        extra={"construction_priority": history[0].priority},
    )
