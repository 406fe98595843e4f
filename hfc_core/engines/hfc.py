"""Heuristic Fleet Cooperation (paper section III, Algorithm 4) and its modes (section IV-A).

- NCM1: ordering only; every clustered spot is kept and the battery is ignored by design.
- NCM2: ordering + screening.
- CM:   ordering + screening + cooperation.

An individual is a whole fleet plan (one route per vehicle). Each iteration orders every route
of every individual (Algorithm 1), screens ``screened`` (nSc) randomly sampled individuals
(Algorithm 2), and, in CM, lets every vehicle with time to spare take abandoned spots
(Algorithm 3). The best individual is the one with the lowest Cost_total (eq. 9); its
per-vehicle cost, violation and T_diff after every iteration form the history of Fig. 7-8.

Screening removes spots until a route fits, and the paper warns that a high screening rate
converges prematurely (nSc <= 0.01 N): an individual screened early, while its routes are still
long, abandons more spots than one screened after ordering has shortened them. The population
thus keeps individuals screened at different stages and the best of them wins.

Feasibility of the returned plan (NCM2, CM): the lowest-cost individual that fits every battery
is returned. If none does (a budget too small to screen anything), the lowest-cost individual is
screened until it fits (a final repair, reported as ``extra["repaired"]``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from hfc_core.engines.history import record
from hfc_core.engines.operators import cooperate, initial_routes, order, screen
from hfc_core.engines.operators.clustering import METHODS, clusters_of_vehicles
from hfc_core.engines.operators.screening import screen_route
from hfc_core.engines.params import engine_params
from hfc_core.model.cost import CostWeights, RouteModel
from hfc_core.model.feasibility import fits
from hfc_core.model.plan import Plan
from hfc_core.model.problem import Problem
from hfc_core.result import IterationRecord, SolveResult
from hfc_core.stop import Stop

Routes = list[list[int]]


@dataclass(frozen=True)
class HFCParams:
    """Algorithm 4's inputs besides the problem: N, nSc, the clustering and eq. (9)'s weights
    (None: the paper-fitted weights of `hfc_core.model.cost`, scaled to the problem)."""

    population: int = 100  # N
    screened: int = 1  # nSc, "not more than one percent of the population size"
    clustering: str = "kmeans"
    fuzzifier: float = 2.0  # m of eq. (11), for the fuzzy c-means clusterings
    weights: CostWeights | None = None

    def __post_init__(self) -> None:
        if self.population < 1:
            raise ValueError(f"population must be >= 1, got {self.population}")
        if not 1 <= self.screened <= self.population:
            raise ValueError(f"screened must be in 1..population, got {self.screened}")
        if self.clustering not in METHODS:
            raise ValueError(f"clustering must be one of {METHODS}, got {self.clustering!r}")
        if not self.fuzzifier > 1:
            raise ValueError(f"fuzzifier must be > 1, got {self.fuzzifier}")



def _fits(model: RouteModel, routes: Routes) -> bool:
    return bool(np.all(fits(model.times_s(routes), model.battery_s)))


def run_hfc(
    problem: Problem, stop: Stop, rng: np.random.Generator, *, screening: bool,
    cooperation: bool, mode: str, params: HFCParams,
) -> SolveResult:
    """Algorithm 4 with the given operators switched on."""
    model = RouteModel(problem)
    if screening:
        model.require_reachable()
    weights = params.weights or CostWeights().scaled_to(problem)
    clusters = clusters_of_vehicles(
        model, rng, method=params.clustering, fuzzifier=params.fuzzifier
    )
    population = [initial_routes(clusters, rng) for _ in range(params.population)]
    history: list[IterationRecord] = []
    iteration = 0
    while not stop.done(iteration):
        population = [order(ind, rng, model=model) for ind in population]
        if screening:
            for i in rng.choice(len(population), size=params.screened, replace=False):
                population[i] = screen(population[i], rng, model=model, weights=weights)
        if cooperation:
            population = [cooperate(ind, rng, model=model) for ind in population]
        iteration += 1
        best = min(population, key=lambda ind: model.costs(ind, weights).sum())
        history.append(record(model, best, weights, iteration, stop.elapsed_s()))

    total = [float(model.costs(ind, weights).sum()) for ind in population]
    ranked = sorted(range(len(population)), key=total.__getitem__)
    repaired = False
    if screening:
        feasible = [i for i in ranked if _fits(model, population[i])]
        if feasible:
            chosen = population[feasible[0]]
        else:  # the final repair: screen the best until every route fits
            repaired = True
            chosen = [screen_route(r, model=model, v=v, weights=weights)
                      for v, r in enumerate(population[ranked[0]])]
    else:
        chosen = population[ranked[0]]
    return SolveResult(
        plan=Plan.of(chosen),
        mode=mode,
        seed=0,
        iterations=iteration,
        elapsed_s=stop.elapsed_s(),
        history=history,
        extra={
            "population": params.population,
            "screened": params.screened,
            "clustering": params.clustering,
            "weights": weights,
            "cost_total": float(model.costs(chosen, weights).sum()),
            "repaired": repaired,
        },
    )


def solve_ncm1(
    problem: Problem, stop: Stop, rng: np.random.Generator, **params: Any
) -> SolveResult:
    """NCM1: ordering only (battery ignored by design)."""
    return run_hfc(problem, stop, rng, screening=False, cooperation=False, mode="hfc-ncm1",
                   params=engine_params(HFCParams, params))


def solve_ncm2(
    problem: Problem, stop: Stop, rng: np.random.Generator, **params: Any
) -> SolveResult:
    """NCM2: ordering and screening, no cooperation."""
    return run_hfc(problem, stop, rng, screening=True, cooperation=False, mode="hfc-ncm2",
                   params=engine_params(HFCParams, params))


def solve_cm(
    problem: Problem, stop: Stop, rng: np.random.Generator, **params: Any
) -> SolveResult:
    """CM: ordering, screening and cooperation (the full HFC)."""
    return run_hfc(problem, stop, rng, screening=True, cooperation=True, mode="hfc-cm",
                   params=engine_params(HFCParams, params))
