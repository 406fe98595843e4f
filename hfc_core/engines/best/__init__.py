"""Mode ``best``: the paper's operators as construction, then adaptive ruin-and-recreate with
strong local search; anytime under a time limit, reproducible under an iteration budget.

Layout: `instance` (the arrays searched), `state` (routes, cached lengths and insertions),
`construct` (clustering, ordering, screening, cooperation), `insert` (greedy repair),
`intra` (2-opt, or-opt), `ruin` (destroy operators), `engine` (the search loop).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hfc_core.engines.best.construct import construct
from hfc_core.engines.best.engine import SearchParams, search
from hfc_core.engines.best.instance import Instance, instance_from_problem
from hfc_core.engines.best.state import State
from hfc_core.engines.history import record
from hfc_core.engines.operators.clustering import (
    METHODS,
    clusters_of_vehicles,
    lloyd,
    vehicle_of_cluster,
)
from hfc_core.engines.params import engine_params
from hfc_core.model.cost import CostWeights, RouteModel
from hfc_core.model.plan import Plan
from hfc_core.model.problem import Problem
from hfc_core.result import IterationRecord, SolveResult
from hfc_core.stop import Stop

__all__ = ["SearchParams", "solve_best", "Instance", "State", "instance_from_problem"]


# Later runs of the search restart from these, in turn: one k-means++ seeding (not the best of
# several, which would give the same clusters every time), fuzzy clusters drawn by membership,
# and k-medoids on the travel metric. Diverse starts are what the restarts are for.
RESTART_CLUSTERINGS = ("lloyd", "fcm-roulette", "medoids")


def cluster_vehicle(problem: Problem, rng: np.random.Generator, method: str) -> np.ndarray | None:
    """Vehicle label per task from the paper's clustering operator (``method``: one of its
    `METHODS`, ``"lloyd"`` for a single k-means++ run), or None for k-medoids."""
    if method == "medoids":
        return None
    model = RouteModel(problem)
    if method == "lloyd":
        labels = lloyd(np.asarray(problem.xyz[: problem.n_tasks]), problem.n_vehicles, rng)[0]
        return vehicle_of_cluster(labels, model)[labels]
    out = np.full(problem.n_tasks, -1, dtype=np.int64)
    for v, members in enumerate(clusters_of_vehicles(model, rng, method=method)):
        out[members] = v
    return out


def solve_best(
    problem: Problem,
    stop: Stop,
    rng: np.random.Generator,
    *,
    clustering: str = "kmeans",
    **params: Any,
) -> SolveResult:
    """Plan ``problem``: construct from the paper's clusters (``clustering``: one of
    `hfc_core.engines.operators.clustering.METHODS`, or ``"medoids"`` for k-medoids on the travel
    metric), then search. ``params`` are `SearchParams` fields."""
    if clustering not in (*METHODS, "medoids"):
        raise ValueError(f"unknown clustering {clustering!r}")
    search_params = engine_params(SearchParams, params)
    inst = instance_from_problem(problem)
    model, weights = RouteModel(problem), CostWeights().scaled_to(problem)
    history: list[IterationRecord] = []

    def on_best(iteration: int, state: State) -> None:
        history.append(record(model, state.routes, weights, iteration, stop.elapsed_s()))

    restarts = 0

    def fresh() -> State:
        nonlocal restarts
        restarts += 1
        method = RESTART_CLUSTERINGS[(restarts - 1) % len(RESTART_CLUSTERINGS)]
        return construct(inst, rng, cluster_vehicle(problem, rng, method))

    start = construct(inst, rng, cluster_vehicle(problem, rng, clustering))
    on_best(0, start)
    best, iterations = search(start, rng, stop, search_params, on_best, fresh)
    return SolveResult(
        plan=Plan.of(best.routes),
        mode="best",
        seed=-1,
        iterations=iterations,
        elapsed_s=stop.elapsed_s(),
        history=history,
        extra={"construction_priority": history[0].priority, "restarts": restarts},
    )
