"""The sweep in this process, one seed after another (``--jobs 1``, no scheduler)."""

from __future__ import annotations

from typing import Iterator, Sequence

from cotsfleet.mission.report_model import RunResult
from cotsfleet.sweep.spec import SweepSpec
from cotsfleet.sweep.task import run_seed


class Serial:
    """Runs every seed here, in seed order: no process to start, none to clean up."""

    workers = 1
    where = "this process"

    def results(self, spec: SweepSpec, seeds: Sequence[int]) -> Iterator[RunResult]:
        for seed in seeds:
            yield run_seed(spec, seed)

    def __enter__(self) -> "Serial":
        return self

    def __exit__(self, *exc: object) -> None:
        pass
