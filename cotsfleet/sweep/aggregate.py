"""A sweep's results as one aggregate: sorted by seed, the same whatever ran them.

Runs finish in any order on any number of workers; the aggregate sorts them by seed. What
depends on the machine and not on the seed (`MACHINE_FIELDS`: wall times, tracebacks) is
kept in the JSON and shown in the summary's ``wall s`` column only; `comparable` leaves it
out, so two sweeps of the same seeds compare equal whatever ran them.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Sequence

import msgspec
import numpy as np

from cotsfleet.mission.report_model import FailedRun, MissionReport, RunResult
from cotsfleet.sweep.task import MACHINE_FIELDS

FOOTNOTE = ("Every figure but the wall times depends only on the seeds: the same sweep on one "
            "process, local workers or a cluster gives the same summary but for the "
            "`wall s` column and row.")


def by_seed(results: Sequence[RunResult]) -> list[RunResult]:
    return sorted(results, key=lambda r: r.seed)


def comparable(result: RunResult) -> RunResult:
    """A run's result without the machine-dependent fields."""
    return msgspec.structs.replace(result, **{k: None for k in MACHINE_FIELDS
                                              if hasattr(result, k)})


def failed(result: RunResult) -> bool:
    return isinstance(result, FailedRun)


def summary_paths(json_path: Path) -> tuple[Path, Path]:
    """``X.json`` -> ``X.md`` and ``X.csv`` beside it."""
    return json_path.with_suffix(".md"), json_path.with_suffix(".csv")


def write_outputs(results: Sequence[RunResult], json_path: Path) -> Path:
    """The JSON (every run, sorted by seed) at ``json_path``, and ``X.md``/``X.csv`` beside
    it for ``X.json``; returns the Markdown's path."""
    from cotsfleet.reporting import write_sweep_summary

    json_path.parent.mkdir(parents=True, exist_ok=True)
    runs = by_seed(results)
    json_path.write_text(json.dumps([r.to_dict() for r in runs], indent=2), encoding="utf-8")
    md = write_sweep_summary(runs, json_path.parent, json_path.stem)
    with open(md, "a", encoding="utf-8") as fh:
        fh.write(f"\n{FOOTNOTE}\n")
    return md


def _row(report: MissionReport) -> dict[str, float]:
    c, f = report.collected, report.fleet
    slowest = report.slowest_detection_s
    return {"treated": c.spots, "priority": c.priority, "duplicates": c.duplicates,
            "home": f.vehicles_home, "detect_s": math.nan if slowest is None else slowest,
            "false_alarms": f.false_alarms,
            "B/veh/min": report.messages.bytes_per_vehicle_minute,
            "oracle": report.oracle.ratio if report.oracle else math.nan}


STATISTICS = (("median", lambda v: float(np.median(v))),
              ("q1", lambda v: float(np.percentile(v, 25))),
              ("q3", lambda v: float(np.percentile(v, 75))),
              ("mean", lambda v: float(np.mean(v))),
              ("min", lambda v: float(np.min(v))),
              ("max", lambda v: float(np.max(v))))


def summary_table(results: Sequence[RunResult]) -> str:
    """The terminal table: per figure, median, quartiles, mean and range over the runs that
    succeeded, and a line for the failures."""
    ok = [r for r in results if isinstance(r, MissionReport)]
    bad = [r for r in by_seed(results) if isinstance(r, FailedRun)]
    lines = []
    if ok:
        rows = [_row(r) for r in ok]
        keys = list(rows[0])
        lines.append(f"{'':<6}" + "".join(f"{k:>13}" for k in keys))
        for name, fn in STATISTICS:
            cells = []
            for k in keys:
                values = [r[k] for r in rows if r[k] == r[k]]  # drop NaN
                cells.append(f"{fn(values):>13.4g}" if values else f"{'-':>13}")
            lines.append(f"{name:<6}" + "".join(cells))
        if any(r.collected.on_reef for r in ok):
            lines.append("(treated and priority on the real reef of each dynamic mission)")
    lines.append(f"failed: {len(bad)} of {len(results)} run(s)"
                 + (": " + ", ".join(f"seed {r.seed} {r.error[:80]}" for r in bad[:5])
                    + (", ..." if len(bad) > 5 else "") if bad else ""))
    return "\n".join(lines)
