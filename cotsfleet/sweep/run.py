"""A sweep from start to end: pick where it runs, run every seed, keep what finished.

Whatever ends the sweep (the last seed, Ctrl-C, an error), the executor's ``with`` block has
stopped every worker process it started before `run_sweep` returns or raises; an interrupted
sweep still returns the runs that finished, marked ``interrupted``.
"""

from __future__ import annotations

import signal
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass
from typing import IO, Any, Iterator, Protocol, Self, Sequence

from cotsfleet.errors import UsageError
from cotsfleet.mission.report_model import FailedRun, RunResult
from cotsfleet.sweep.aggregate import by_seed
from cotsfleet.sweep.spec import SweepSpec

LOCAL_CLUSTER = "local"


class Executor(Protocol):
    @property
    def workers(self) -> int: ...

    @property
    def where(self) -> str: ...

    def results(self, spec: SweepSpec, seeds: Sequence[int]) -> Any: ...

    def __enter__(self) -> Self: ...

    def __exit__(self, exc_type: object, *exc: object) -> None: ...


def executor_for(runs: int, jobs: int | None, scheduler: str | None) -> Executor:
    """No scheduler: this process (``jobs`` 1) or ``jobs`` local worker processes (never more
    than ``runs``); ``scheduler`` ``local``: a Dask LocalCluster of ``jobs`` workers (default
    one per core); any other ``scheduler``: the Dask cluster at that address."""
    if jobs is not None and jobs < 1:
        raise UsageError(f"--jobs must be >= 1, got {jobs}")
    if scheduler is not None:
        from cotsfleet.sweep.cluster import DaskPool

        if scheduler == LOCAL_CLUSTER:
            return DaskPool(None, None if jobs is None else min(jobs, runs))
        return DaskPool(scheduler)
    if jobs is None or jobs == 1 or runs == 1:
        from cotsfleet.sweep.serial import Serial

        return Serial()
    from cotsfleet.sweep.local import LocalPool

    return LocalPool(min(jobs, runs))


@dataclass
class SweepOutcome:
    results: list[RunResult]  # sorted by seed
    seeds: int  # how many were asked for
    where: str
    wall_s: float
    interrupted: bool = False


def _note(result: RunResult) -> str:
    if isinstance(result, FailedRun):
        return f"failed: {result.error[:60]}"
    c = result.collected
    return f"{c.spots}/{c.spots_of} {c.spot_word}, priority {c.priority:.0f}"


@contextmanager
def _sigterm_as_interrupt() -> Iterator[None]:
    """SIGTERM (a batch system's time limit, ``kill``) ends the sweep as Ctrl-C does: workers
    stopped, finished runs written. Only the main thread may set handlers."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(*_: object) -> None:
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def run_sweep(spec: SweepSpec, seeds: Sequence[int], executor: Executor,
              stream: IO[str] | None = None) -> SweepOutcome:
    """Every seed through ``executor``, with a progress bar (ETA) as runs finish."""
    from cotsfleet.reporting.progress import Progress

    t0 = time.perf_counter()
    results: list[RunResult] = []
    interrupted = False
    where = "?"
    try:
        with _sigterm_as_interrupt(), executor:  # workers start here, before any bar thread
            where = executor.where
            with Progress(len(seeds), "sim", "run", stream=stream) as progress:
                progress.start(f"{len(seeds)} seeds on {where}")
                for result in executor.results(spec, seeds):
                    results.append(result)
                    progress.done(f"seed {result.seed}", _note(result))
    except KeyboardInterrupt:
        interrupted = True
    return SweepOutcome(by_seed(results), len(seeds), where, time.perf_counter() - t0,
                        interrupted)
