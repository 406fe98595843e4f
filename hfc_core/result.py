"""What a planner run returns: the plan, its budget spent, and its convergence history."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from hfc_core.model.plan import Plan


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
