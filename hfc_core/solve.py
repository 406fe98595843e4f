"""`solve(problem, mode, ...)`: the one entry point to every planner mode.

The seed becomes the one `numpy.random.Generator` here, at the entry point (PyVRP's rule);
engines receive it explicitly and never touch global random state. A `Stop` carries the budget:
an iteration count (deterministic on every machine, which the fleet's agents rely on to agree
on a plan without messages) and/or a time limit (anytime use). The timer is injected so the
planner owns no clock.
"""

from __future__ import annotations

import importlib
import time
from dataclasses import dataclass, field, fields
from typing import Any, Callable, Protocol, TypeVar

import numpy as np

from hfc_core.plan import Plan
from hfc_core.problem import Problem, ScenarioError


@dataclass
class Stop:
    """When an engine must return its best plan so far."""

    time_limit_s: float | None = None
    max_iterations: int | None = None
    timer: Callable[[], float] = time.perf_counter

    def __post_init__(self) -> None:
        if self.time_limit_s is None and self.max_iterations is None:
            raise ValueError("Stop needs a time limit, an iteration budget, or both")
        if self.time_limit_s is not None and not self.time_limit_s > 0:
            raise ValueError(f"time limit must be positive, got {self.time_limit_s}")
        if self.max_iterations is not None and self.max_iterations < 0:
            raise ValueError(f"iteration budget must be >= 0, got {self.max_iterations}")
        self._started = self.timer()

    def elapsed_s(self) -> float:
        return self.timer() - self._started

    def done(self, iteration: int) -> bool:
        """True once ``iteration`` iterations are spent or time is up."""
        if self.max_iterations is not None and iteration >= self.max_iterations:
            return True
        return self.time_limit_s is not None and self.elapsed_s() >= self.time_limit_s


@dataclass(frozen=True)
class IterationRecord:
    """One point of the convergence history (the paper's Fig. 7-8): per-vehicle eq. 9 cost,
    violation (seconds overdue) and T_diff (eq. 12) of the best plan after ``iteration``."""

    iteration: int
    elapsed_s: float
    cost: tuple[float, ...]
    violation_s: tuple[float, ...]
    t_diff_s: tuple[float, ...]
    priority: float  # priority collected by the best plan


@dataclass
class SolveResult:
    plan: Plan
    mode: str
    seed: int
    iterations: int
    elapsed_s: float
    history: list[IterationRecord] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)  # engine-specific figures


class Engine(Protocol):
    def __call__(
        self, problem: Problem, stop: Stop, rng: np.random.Generator, **params: Any
    ) -> SolveResult: ...


P = TypeVar("P")


def engine_params(cls: type[P], params: dict[str, Any]) -> P:
    """``cls(**params)`` for an engine's parameter dataclass, refusing unknown names with
    the list of known ones (a typo must not silently fall back to a default)."""
    known = {f.name for f in fields(cls)}  # type: ignore[arg-type]
    unknown = set(params) - known
    if unknown:
        raise ValueError(f"unknown {cls.__name__} field(s) {sorted(unknown)}; known: {sorted(known)}")
    return cls(**params)


# mode -> "module:function"; imported lazily so one broken engine never hides the others.
MODES: dict[str, str] = {
    "hfc-ncm1": "hfc_core.hfc:solve_ncm1",
    "hfc-ncm2": "hfc_core.hfc:solve_ncm2",
    "hfc-cm": "hfc_core.hfc:solve_cm",
    "ga": "hfc_core.ga:solve_ga",
    "best": "hfc_core.best:solve_best",
}

# Modes whose plans may exceed the battery by design (NCM1 ignores the budget, paper IV-A).
BUDGET_FREE_MODES = frozenset({"hfc-ncm1"})


def engine(mode: str) -> Engine:
    if mode not in MODES:
        raise ScenarioError(f"unknown mode {mode!r}; choose from {', '.join(MODES)}")
    module, func = MODES[mode].split(":")
    return getattr(importlib.import_module(module), func)


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
