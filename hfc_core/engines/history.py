"""The convergence history every engine reports: the paper's Fig. 7-8 figures of a plan."""

from __future__ import annotations

import numpy as np

from hfc_core.model.cost import CostWeights, RouteModel
from hfc_core.result import IterationRecord

Routes = list[list[int]]


def record(
    model: RouteModel, routes: Routes, weights: CostWeights, iteration: int, elapsed_s: float
) -> IterationRecord:
    """The Fig. 7-8 figures of ``routes`` after ``iteration``."""
    times = model.times_s(routes)
    return IterationRecord(
        iteration=iteration,
        elapsed_s=elapsed_s,
        cost=tuple(model.costs(routes, weights).tolist()),
        violation_s=tuple(np.maximum(0.0, times - model.battery_s).tolist()),
        t_diff_s=tuple((model.battery_s - times).tolist()),
        priority=float(model.priorities(routes).sum()),
    )
