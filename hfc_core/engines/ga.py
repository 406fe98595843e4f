"""The GA baseline of the paper's section IV-C (its ref. [24]).

The field is split by k-means, one cluster per vehicle, and a genetic algorithm minimises each
vehicle's route length over the permutations of its cluster: tournament selection, partially
mapped crossover (PMX, Goldberg & Lingle 1985), and a mutation that is one of the ordering
moves (swap, insertion, reversion: "the mutation term played a role analogous to the ordering
operator"), with elitism. The battery is met "by leaving the last ordered task in each
iteration": while the best route of a vehicle overruns, the last spot of that route is dropped
from the vehicle's spot set (from every individual). Spots are thus abandoned at the far end
of the route, and the GA has no cooperation. If the iteration budget ends before every route
fits, the same rule finishes the job (``extra["repaired"]``).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Any, Callable, Sequence

import numpy as np

from hfc_core.engines.history import record
from hfc_core.engines.operators.clustering import clusters_of_vehicles
from hfc_core.engines.operators.ordering import MOVES, order_route
from hfc_core.engines.params import engine_params
from hfc_core.model.cost import CostWeights, RouteModel
from hfc_core.model.feasibility import fits
from hfc_core.model.plan import Plan
from hfc_core.model.problem import Problem
from hfc_core.result import IterationRecord, SolveResult
from hfc_core.stop import Stop


@dataclass(frozen=True)
class GAParams:
    population: int = 100
    crossover_rate: float = 0.9
    mutation_rate: float = 0.3
    elite: int = 2
    tournament: int = 3
    mutation: str = "ordering"  # "ordering": Algorithm 1 on the child; "move": one random move
    weights: CostWeights | None = None  # only for the reported eq. (9) history

    def __post_init__(self) -> None:
        if self.population < 2:
            raise ValueError(f"population must be >= 2, got {self.population}")
        for name in ("crossover_rate", "mutation_rate"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must be in [0, 1]")
        if not 0 <= self.elite < self.population:
            raise ValueError("elite must be in 0..population-1")
        if self.tournament < 1:
            raise ValueError("tournament must be >= 1")
        if self.mutation not in ("ordering", "move"):
            raise ValueError(f"mutation must be 'ordering' or 'move', got {self.mutation!r}")



def pmx(parent1: Sequence[int], parent2: Sequence[int], rng: np.random.Generator) -> list[int]:
    """Partially mapped crossover: the child keeps a slice of ``parent1`` in place and takes
    the rest from ``parent2``, resolving clashes through the slice's gene mapping."""
    n = len(parent1)
    if n < 2:
        return list(parent1)
    a, b = sorted(rng.choice(n + 1, size=2, replace=False).tolist())
    child: list[int | None] = [None] * n
    child[a:b] = parent1[a:b]
    where2 = {gene: i for i, gene in enumerate(parent2)}
    kept = set(parent1[a:b])
    for i in range(a, b):
        gene = parent2[i]
        if gene in kept:
            continue
        pos = i
        while a <= pos < b:  # follow the mapping out of the slice
            pos = where2[parent1[pos]]
        child[pos] = gene
    return [parent2[i] if g is None else g for i, g in enumerate(child)]


def mutate(route: list[int], rng: np.random.Generator) -> list[int]:
    """One random swap, insertion or reversion."""
    n = len(route)
    if n < 2:
        return route
    i, j = rng.choice(n, size=2, replace=False).tolist()
    return MOVES[int(rng.integers(3))](route, i, j)


def mutate_ordering(
    route: list[int], rng: np.random.Generator, *, model: RouteModel, v: int
) -> list[int]:
    """The mutation as the ordering operator: len(route) random moves, each kept if shorter."""
    return order_route(route, rng, model=model, v=v)


def lengths_s(model: RouteModel, v: int, population: list[list[int]]) -> np.ndarray:
    """Route travel time of every individual at once (all are permutations of one spot set):
    the route length over the speed in still water (eq. 7-8)."""
    pop = np.array(population, dtype=np.intp)
    d = model.travel_s[v]
    if pop.shape[1] == 0:
        return np.full(len(population), d[model.start[v], model.end[v]])
    inner = d[pop[:, :-1], pop[:, 1:]].sum(axis=1)
    return d[model.start[v], pop[:, 0]] + inner + d[pop[:, -1], model.end[v]]


def _tournament(fitness: np.ndarray, size: int, rng: np.random.Generator) -> int:
    entrants = rng.integers(0, len(fitness), size=size)
    return int(entrants[np.argmin(fitness[entrants])])


def next_generation(
    population: list[list[int]], length: np.ndarray, params: GAParams, rng: np.random.Generator,
    mutation: Callable[[list[int], np.random.Generator], list[int]] = mutate,
) -> list[list[int]]:
    """Elites, then children of tournament-selected parents by PMX and mutation."""
    ranked = np.argsort(length, kind="stable")
    out = [list(population[i]) for i in ranked[: params.elite]]
    while len(out) < len(population):
        p1 = population[_tournament(length, params.tournament, rng)]
        p2 = population[_tournament(length, params.tournament, rng)]
        child = pmx(p1, p2, rng) if rng.random() < params.crossover_rate else list(p1)
        if rng.random() < params.mutation_rate:
            child = mutation(child, rng)
        out.append(child)
    return out


def _drop_last_if_overdue(
    model: RouteModel, v: int, population: list[list[int]], best: list[int]
) -> list[list[int]]:
    """Leave the last ordered spot of the best route if that route overruns the battery."""
    if not best or fits(model.time_s(v, best), model.battery_s[v]):
        return population
    last = best[-1]
    return [[t for t in ind if t != last] for ind in population]


def solve_ga(problem: Problem, stop: Stop, rng: np.random.Generator, **raw: Any) -> SolveResult:
    """k-means + one GA per cluster, dropping last spots until each route fits (section IV-C)."""
    params = engine_params(GAParams, raw)
    model = RouteModel(problem)
    model.require_reachable()
    weights = params.weights or CostWeights().scaled_to(problem)
    clusters = clusters_of_vehicles(model, rng, method="kmeans")
    pops = [[rng.permutation(c).tolist() for _ in range(params.population)] for c in clusters]
    history: list[IterationRecord] = []
    best: list[list[int]] = [list(p[0]) for p in pops]
    generation = 0
    while not stop.done(generation):
        for v in range(model.k):
            length = lengths_s(model, v, pops[v])
            best[v] = list(pops[v][int(np.argmin(length))])
            pops[v] = _drop_last_if_overdue(model, v, pops[v], best[v])
            length = lengths_s(model, v, pops[v])
            mutation = (mutate if params.mutation == "move"
                        else partial(mutate_ordering, model=model, v=v))
            pops[v] = next_generation(pops[v], length, params, rng, mutation)
        generation += 1
        best = [list(p[int(np.argmin(lengths_s(model, v, p)))]) for v, p in enumerate(pops)]
        history.append(record(model, best, weights, generation, stop.elapsed_s()))
    repaired = False
    for v, route in enumerate(best):
        while route and not fits(model.time_s(v, route), model.battery_s[v]):
            route = route[:-1]
            repaired = True
        best[v] = route
    return SolveResult(
        plan=Plan.of(best),
        mode="ga",
        seed=0,
        iterations=generation,
        elapsed_s=stop.elapsed_s(),
        history=history,
        extra={"population": params.population, "weights": weights, "repaired": repaired,
               "cost_total": float(model.costs(best, weights).sum())},
    )
