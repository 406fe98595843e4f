"""`Stop`: when an engine must return its best plan so far.

A budget is an iteration count (deterministic on every machine, which the fleet's agents rely
on to agree on a plan without messages) and/or a time limit (anytime use). The timer is
injected so the planner owns no clock. Every engine and the replanner take one; `solve` builds
it from its arguments.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable


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
