"""`solve(problem, mode, ...)`: the one entry point to every planner mode.

The seed becomes the one `numpy.random.Generator` here, at the entry point (PyVRP's rule);
engines receive it explicitly and never touch global random state. The budget becomes a
`hfc_core.stop.Stop`; the engine returns a `hfc_core.result.SolveResult`.
"""

from __future__ import annotations

import time
from typing import Any, Callable, Protocol

import numpy as np

from hfc_core.engines.best import solve_best
from hfc_core.engines.ga import solve_ga
from hfc_core.engines.hfc import solve_cm, solve_ncm1, solve_ncm2
from hfc_core.model.errors import ScenarioError
from hfc_core.model.problem import Problem
from hfc_core.result import SolveResult
from hfc_core.stop import Stop


class Engine(Protocol):
    def __call__(
        self, problem: Problem, stop: Stop, rng: np.random.Generator, **params: Any
    ) -> SolveResult: ...


MODES: dict[str, Engine] = {
    "hfc-ncm1": solve_ncm1,
    "hfc-ncm2": solve_ncm2,
    "hfc-cm": solve_cm,
    "ga": solve_ga,
    "best": solve_best,
}

# Modes whose plans may exceed the battery by design (NCM1 ignores the budget, paper IV-A).
BUDGET_FREE_MODES = frozenset({"hfc-ncm1"})


def engine(mode: str) -> Engine:
    if mode not in MODES:
        raise ScenarioError(f"unknown mode {mode!r}; choose from {', '.join(MODES)}")
    return MODES[mode]


def solve(
    problem: Problem,
    mode: str = "best",
    *,
    time_limit_s: float | None = None,
    max_iterations: int | None = None,
    seed: int = 0,
    timer: Callable[[], float] = time.perf_counter,
    **params: Any,
) -> SolveResult:
    """Plan ``problem`` with ``mode`` under the given budget, seeded and reproducible."""
    run = engine(mode)
    stop = Stop(time_limit_s=time_limit_s, max_iterations=max_iterations, timer=timer)
    rng = np.random.default_rng(seed)
    result = run(problem, stop, rng, **params)
    result.seed = seed
    return result
