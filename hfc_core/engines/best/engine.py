"""Adaptive large neighbourhood search with record-to-record acceptance.

Each iteration ruins the current plan with one destroy operator (chosen by roulette over
adaptive weights), repairs it by greedy insertion, shortens the changed routes (2-opt, or-opt)
and inserts again into the time that frees. A candidate close to acceptance is polished by
moves between routes (tail exchange, relocate, swap) and searched again. A candidate is kept
if it is within a threshold of the best plan's objective; the threshold shrinks to zero as the
budget is spent, so the search wanders early and intensifies late. Acceptance uses no exp() or
pow(): with an iteration budget the search is a pure function of its inputs on every IEEE
machine.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from hfc_core.engines.best.exchange import replace_improve
from hfc_core.engines.best.insert import EXPONENTS, fill
from hfc_core.engines.best.inter import PairMemo, improve_between
from hfc_core.engines.best.intra import improve_route
from hfc_core.engines.best.ruin import RUIN_OPERATORS
from hfc_core.engines.best.state import State
from hfc_core.stop import Stop

# Operator scores by outcome: new best of the run, better than current, accepted, rejected.
OUTCOME_SCORES = (10.0, 5.0, 2.0, 0.0)


@dataclass(frozen=True)
class SearchParams:
    ruin_max: int = 30  # most tasks one destroy unassigns
    ruin_share: float = 0.5  # ... and at most this share of the routed tasks
    threshold: float = 0.01  # accept down to this share below the run's best, shrinking to 0
    # Repair variants: relative noise on insertion values, one chosen per iteration by the same
    # adaptive roulette as the destroy operators (TOP instances like ~0.5, the paper preset less).
    noise_levels: tuple[float, ...] = (0.2, 0.5)
    reaction: float = 0.2  # how fast operator weights follow their recent scores
    segment: int = 50  # iterations between weight updates
    restart: int = 300  # iterations without a better plan before a run ends
    explore: float = 0.7  # share of the budget in which a run ending starts a fresh one
    relocate: bool = True  # replace moves may move the task they take out to another route
    # Candidates within this share of the run's best below the acceptance line are polished
    # with inter-route moves (`inter`: 2-opt*, relocate, swap) and searched again; None: never.
    polish: float | None = 0.01

    def __post_init__(self) -> None:
        if self.ruin_max < 1:
            raise ValueError(f"ruin_max must be >= 1, got {self.ruin_max}")
        for name in ("ruin_share", "reaction"):
            if not 0 < getattr(self, name) <= 1:
                raise ValueError(f"{name} must be in (0, 1], got {getattr(self, name)}")
        for name in ("threshold", "explore"):
            if not 0 <= getattr(self, name) <= 1:
                raise ValueError(f"{name} must be in [0, 1], got {getattr(self, name)}")
        if not self.noise_levels or not all(0 <= x < 1 for x in self.noise_levels):
            raise ValueError(f"noise levels must be in [0, 1), got {self.noise_levels}")
        if self.segment < 1 or self.restart < 1:
            raise ValueError("segment and restart must be >= 1")
        if self.polish is not None and not 0 <= self.polish <= 1:
            raise ValueError(f"polish must be None or in [0, 1], got {self.polish}")


def shorten(state: State, vehicles: list[int]) -> bool:
    """2-opt/or-opt the given routes; True if any got shorter."""
    shorter = False
    for v in vehicles:
        if len(state.routes[v]) < 2:
            continue
        nodes = improve_route(state.inst.travel_s[v], state.nodes(v), state.inst.symmetric)
        route = [int(u) for u in nodes[1:-1]]
        if route != state.routes[v]:
            before, time = state.routes[v], state.time_s(v)
            state.set_route(v, route)
            if state.inst.clock is not None and not state.time_s(v) < time:
                state.set_route(v, before)  # shorter by the estimate only, not as flown
                continue
            shorter = True
    return shorter


def recreate(state: State, before: State, rng: np.random.Generator, noise: float,
             relocate: bool = False) -> State:
    """Greedy insertion (random criterion, noisy values), then `local_search`."""
    exponent = EXPONENTS[int(rng.integers(len(EXPONENTS)))]
    fill(state, rng, exponent=exponent, noise=noise)
    return local_search(state, before, rng, exponent, relocate=relocate)


def local_search(
    state: State, before: State, rng: np.random.Generator, exponent: float = 1.0, rounds: int = 3,
    relocate: bool = False,
) -> State:
    """Shorten the routes that differ from ``before``, swap in richer tasks, insert into the
    time that frees; repeat on what changed while anything changes."""
    k = state.inst.k
    changed = [v for v in range(k) if state.routes[v] != before.routes[v]]
    for _ in range(rounds):
        shorter = shorten(state, changed)
        snapshot = [list(r) for r in state.routes]
        if not (replace_improve(state, relocate=relocate) or shorter):
            break
        fill(state, rng, exponent=exponent)
        changed = [v for v in range(k) if state.routes[v] != snapshot[v]]
        if not changed:
            break
    return state


def polish(state: State, rng: np.random.Generator, relocate: bool = False,
           memo: PairMemo | None = None) -> State:
    """Inter-route moves (`inter`) and, if any changed a route, search again from there.
    ``memo``: the search's record of route pairs already evaluated (`inter.PairMemo`)."""
    before = state.copy()
    swapped = improve_between(state, memo=memo)
    if not swapped:
        return state
    shorten(state, swapped)
    fill(state, rng)
    return local_search(state, before, rng, relocate=relocate)


class _Roulette:
    """Adaptive operator weights (ALNS): picked in proportion to the weights, which follow each
    operator's mean outcome score over the last ``segment`` iterations."""

    def __init__(self, size: int, params: SearchParams) -> None:
        self.weights = np.ones(size)
        self.scores, self.uses = np.zeros(size), np.zeros(size)
        self.params = params

    def pick(self, rng: np.random.Generator) -> int:
        return int(rng.choice(len(self.weights), p=self.weights / self.weights.sum()))

    def score(self, op: int, outcome: int, iteration: int) -> None:
        self.scores[op] += OUTCOME_SCORES[outcome]
        self.uses[op] += 1
        if iteration % self.params.segment == 0:
            used = self.uses > 0
            recent = np.maximum(self.scores[used] / self.uses[used], 0.1)
            reaction = self.params.reaction
            self.weights[used] = (1 - reaction) * self.weights[used] + reaction * recent
            self.scores[:], self.uses[:] = 0.0, 0.0


def progress(stop: Stop, iteration: int) -> float:
    """Share of the budget spent, in [0, 1]."""
    spent = 0.0
    if stop.max_iterations:
        spent = iteration / stop.max_iterations
    if stop.time_limit_s is not None:
        spent = max(spent, stop.elapsed_s() / stop.time_limit_s)
    return min(spent, 1.0)


def search(
    start: State,
    rng: np.random.Generator,
    stop: Stop,
    params: SearchParams,
    on_best: Callable[[int, State], None] = lambda it, s: None,
    fresh: Callable[[], State] | None = None,
) -> tuple[State, int]:
    """Improve ``start`` until ``stop``; returns the best plan and the iterations run.

    The search is a sequence of runs. A run ends once ``params.restart`` iterations pass
    without beating the run's best; the next run starts from ``fresh()`` (a new construction)
    while less than ``params.explore`` of the budget is spent, and from the best plan after.
    (A route-based crossover of the runs' best plans as restart point was tried and dropped:
    no measurable gain on the TOP instances.)
    """
    tie = start.inst.tie_weight()
    current, current_obj = start, start.objective(tie)
    best, best_obj, run_obj = start.copy(), current_obj, current_obj
    ruins = _Roulette(len(RUIN_OPERATORS), params)
    noises = _Roulette(len(params.noise_levels), params)
    memo = PairMemo()  # route pairs already evaluated by the polish, across iterations
    iteration = stale = 0
    while not stop.done(iteration):
        op, level = ruins.pick(rng), noises.pick(rng)
        routed = int((current.owner >= 0).sum())
        # int(): Generator.integers truncates a float bound the same way (same draws)
        most = int(max(1, min(params.ruin_max, params.ruin_share * routed)) + 1)
        size = int(rng.integers(1, most))
        destroyed = RUIN_OPERATORS[op](current.copy(), rng, size)
        candidate = recreate(destroyed, current, rng, params.noise_levels[level], params.relocate)
        cand_obj = candidate.objective(tie)
        spent = progress(stop, iteration)
        line = run_obj - params.threshold * abs(run_obj) * (1.0 - spent)
        if params.polish is not None and cand_obj >= line - params.polish * abs(run_obj):
            candidate = polish(candidate, rng, params.relocate, memo)
            cand_obj = candidate.objective(tie)
        iteration, stale = iteration + 1, stale + 1
        if cand_obj > best_obj + 1e-12:
            best, best_obj = candidate.copy(), cand_obj
            on_best(iteration, best)
        if cand_obj > run_obj + 1e-12:
            outcome, run_obj, stale = 0, cand_obj, 0
        elif cand_obj > current_obj + 1e-12:
            outcome = 1
        elif cand_obj >= line:
            outcome = 2
        else:
            outcome = 3
        if outcome < 3:
            current, current_obj = candidate, cand_obj
        ruins.score(op, outcome, iteration)
        noises.score(level, outcome, iteration)
        if stale >= params.restart:
            current = fresh() if fresh is not None and spent < params.explore else best.copy()
            current_obj = run_obj = current.objective(tie)
            stale = 0
    return best, iteration

