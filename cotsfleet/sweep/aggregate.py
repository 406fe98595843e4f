"""A sweep's results as one aggregate: sorted by seed, the same whatever ran them.

Runs finish in any order on any number of workers; the aggregate sorts them by seed, and what
is summarised or compared leaves out the fields that depend on the machine (`MACHINE_FIELDS`:
wall times, tracebacks). The JSON keeps them, one entry per seed, failures included.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from cotsfleet.sweep.task import MACHINE_FIELDS

FOOTNOTE = ("Wall times are per run in the sweep's JSON; this summary leaves them out so that "
            "it is the same for the same seeds whatever ran them (one process, local workers "
            "or a cluster).")


def by_seed(results: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    return sorted((dict(r) for r in results), key=lambda r: r["seed"])


def comparable(result: Mapping[str, Any]) -> dict[str, Any]:
    """A run's result without the machine-dependent fields."""
    return {k: v for k, v in result.items() if k not in MACHINE_FIELDS}


def failed(result: Mapping[str, Any]) -> bool:
    return "error" in result


def write_outputs(results: Sequence[Mapping[str, Any]], json_path: Path) -> Path:
    """The JSON (every run, sorted by seed) at ``json_path``, and ``sweep.md``/``sweep.csv``
    beside it from the comparable view; returns the Markdown's path."""
    from cotsfleet.reporting import write_sweep_summary

    json_path.parent.mkdir(parents=True, exist_ok=True)
    json_path.write_text(json.dumps(by_seed(results), indent=2), encoding="utf-8")
    md = write_sweep_summary([comparable(r) for r in by_seed(results)], json_path.parent)
    with open(md, "a", encoding="utf-8") as fh:
        fh.write(f"\n{FOOTNOTE}\n")
    return md


def _row(report: Mapping[str, Any]) -> dict[str, float]:
    f, m = report["fleet"], report["messages"]
    delays = [d for row in f["detection_delay_s"].values() for d in row.values() if d is not None]
    return {"cleared": f["spots_cleared"], "priority": f["priority"],
            "duplicates": f["duplicate_treatments"], "home": f["vehicles_home"],
            "detect_s": max(delays) if delays else math.nan,
            "false_alarms": f["false_alarms"], "B/veh/min": m["bytes_per_vehicle_minute"],
            "oracle": report.get("oracle", {}).get("ratio", math.nan)}


STATISTICS = (("median", lambda v: float(np.median(v))),
              ("q1", lambda v: float(np.percentile(v, 25))),
              ("q3", lambda v: float(np.percentile(v, 75))),
              ("mean", lambda v: float(np.mean(v))),
              ("min", lambda v: float(np.min(v))),
              ("max", lambda v: float(np.max(v))))


def summary_table(results: Sequence[Mapping[str, Any]]) -> str:
    """The terminal table: per figure, median, quartiles, mean and range over the runs that
    succeeded, and a line for the failures."""
    ok = [r for r in results if not failed(r)]
    bad = [r for r in by_seed(results) if failed(r)]
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
    lines.append(f"failed: {len(bad)} of {len(results)} run(s)"
                 + (": " + ", ".join(f"seed {r['seed']} {r['error'][:80]}" for r in bad[:5])
                    + (", ..." if len(bad) > 5 else "") if bad else ""))
    return "\n".join(lines)
