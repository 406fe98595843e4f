"""One run of a sweep, the function every executor calls (in this process, in a worker
process, on a Dask worker): a pure function of (spec, seed) but for its wall time."""

from __future__ import annotations

import time
import traceback

import msgspec

from cotsfleet.mission.report_model import FailedRun, RunResult
from cotsfleet.sweep.spec import SweepSpec

TRACEBACK_CHARS = 4000  # enough for the innermost frames; a sweep's JSON must stay readable

# Fields of a run's result that depend on the machine, not on the seed: kept in the JSON,
# left out of anything compared or summarised (`cotsfleet.sweep.aggregate.comparable`).
MACHINE_FIELDS = ("wall_s", "run_s", "traceback")


def run_seed(spec: SweepSpec, seed: int) -> RunResult:
    """The report of ``seed``'s mission with its ``wall_s`` (the mission, as a single `sim`
    reports it) and ``run_s`` (the whole run: scenario, every agent's initial plan, mission),
    or, if anything in the run raised, a `FailedRun` with the error, its traceback and
    ``run_s``: one failed run is a row of the sweep, never its end."""
    t0 = time.perf_counter()
    try:
        from cotsfleet.mission.inprocess import simulate
        from cotsfleet.sweep.spec import build_mission

        m = build_mission(spec, seed)
        result = simulate(m.problem, m.config, seed=m.seed, loss=m.loss, faults=m.faults,
                          reef=m.reef)
    except Exception as exc:  # whatever a run raises is that run's result
        text = "".join(traceback.format_exception(exc))
        return FailedRun(seed=seed, error=repr(exc), traceback=text[-TRACEBACK_CHARS:],
                         run_s=round(time.perf_counter() - t0, 3))
    return msgspec.structs.replace(result.report, wall_s=round(result.wall_s, 3),
                                   run_s=round(time.perf_counter() - t0, 3))
