"""``sweep.md`` (and ``sweep.csv``): many missions summarised by medians and quartiles, with
one row per seed, failed runs included.

A run that failed is a `FailedRun` (its seed and error): it is counted, listed with its
error, and left out of the statistics. The Markdown shows each run's wall time (the only
figure that depends on the machine: `machine_free` leaves it out); the CSV holds only what
depends on the seed, so the same seeds give the same CSV whatever ran them.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from cotsfleet.mission.report_model import FailedRun, MissionReport, RunResult, drop_reasons


def _ratio(a: float | None, b: float | None) -> float:
    if a is None or b is None or not b > 0:
        return math.nan
    return float(a) / float(b)


def _value(x: float | int | None) -> float:
    return math.nan if x is None else float(x)


def _link(r: MissionReport, key: str) -> float | None:
    return None if r.messages.link is None else r.messages.link.get(key)


@dataclass(frozen=True)
class Metric:
    key: str
    label: str  # says what a ratio is a ratio to
    value: Callable[[MissionReport], float]
    digits: int = 0


METRICS = (
    Metric("spots_cleared", "spots treated (real spots in a dynamic mission)",
           lambda r: float(r.collected.spots)),
    Metric("spots_share", "spots treated / the scenario's spots (the real reef's)",
           lambda r: _ratio(r.collected.spots, r.collected.spots_of), 3),
    Metric("priority", "priority collected (real in a dynamic mission)",
           lambda r: r.collected.priority, 1),
    Metric("priority_share", "priority collected / the scenario's total (the real reef's)",
           lambda r: _ratio(r.collected.priority, r.collected.priority_of), 3),
    Metric("duplicates", "duplicate treatments (spots injected twice)",
           lambda r: float(r.collected.duplicates)),
    Metric("vehicles_home", "vehicles home", lambda r: float(r.fleet.vehicles_home)),
    Metric("detect_s", "slowest detection of a lost vehicle, s",
           lambda r: _value(r.slowest_detection_s), 1),
    Metric("false_alarms", "false alarms (live vehicles declared lost)",
           lambda r: float(r.fleet.false_alarms)),
    Metric("bytes_per_vehicle_minute", "bytes sent per vehicle per minute",
           lambda r: r.messages.bytes_per_vehicle_minute),
    Metric("delivered_share", "link deliveries / receptions",
           lambda r: _ratio(_link(r, "delivered"), _link(r, "sent")), 3),
    Metric("oracle_ratio", "survivors' priority after a kill / a perfect-information "
           "replan's (note 1)", lambda r: _value(r.oracle.ratio if r.oracle else None), 3),
    Metric("wall_s", "wall time of the mission on this machine, s",
           lambda r: _value(r.wall_s), 2),
)
MACHINE_METRICS = ("wall_s",)  # what depends on the machine, not on the seed


ORACLE_NOTE = (
    "Note 1: the priority the surviving vehicles collected after the kill, divided by the "
    "priority of a centralized replan of the survivors made at the kill time with perfect "
    "information (true positions, batteries, cleared spots). That replan is the heuristic "
    "planner with a fixed iteration budget, not an optimum, so a fleet that keeps improving "
    "its routes can beat it: ratios above 1 are possible and not an error.")


def failed(run: RunResult) -> bool:
    return isinstance(run, FailedRun)


def _fmt(value: float, digits: int) -> str:
    return "-" if math.isnan(value) else f"{value:,.{digits}f}"


def statistics_rows(reports: Sequence[MissionReport]) -> list[list[str]]:
    """Per metric: median, quartiles, min-max and how many runs had a value."""
    rows = []
    for m in METRICS:
        values = np.array([m.value(r) for r in reports], dtype=float)
        values = values[~np.isnan(values)]
        if not len(values):
            continue
        q1, med, q3 = np.percentile(values, [25, 50, 75])
        rows.append([m.label, _fmt(med, m.digits), f"{_fmt(q1, m.digits)} - {_fmt(q3, m.digits)}",
                     f"{_fmt(values.min(), m.digits)} - {_fmt(values.max(), m.digits)}",
                     str(len(values))])
    return rows


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return out + ["| " + " | ".join(str(c) for c in row) + " |" for row in rows] + [""]


def _seed_list(seeds: Sequence[Any]) -> str:
    return ", ".join(map(str, seeds)) if len(seeds) <= 12 else f"{seeds[0]} .. {seeds[-1]}"


def _csv_value(value: float) -> Any:
    if math.isnan(value):
        return ""
    return int(value) if float(value).is_integer() else value


def write_sweep_summary(runs: Sequence[RunResult], out_dir: Path, stem: str = "sweep") -> Path:
    """Write ``stem.md`` and ``stem.csv`` into ``out_dir``; return the Markdown's path."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    ok = [r for r in runs if isinstance(r, MissionReport)]
    bad = [r for r in runs if isinstance(r, FailedRun)]
    scenarios = sorted({r.scenario for r in ok})
    modes = sorted({r.mode for r in ok})
    lines = [f"# Sweep: {len(runs)} run(s)", "",
             f"- **Scenarios:** {', '.join(scenarios) or '-'}; mode {', '.join(modes) or '-'}",
             f"- **Seeds:** {_seed_list([r.seed for r in runs])}",
             f"- **Failed runs:** {len(bad)} of {len(runs)}"]
    faults = {(f.kind, f.vid, f.t_s) for r in ok for f in r.faults}
    if faults:
        lines.append("- **Faults:** " + ", ".join(f"{k} {v}@{t:g}".replace(" @", "@")
                                                  for k, v, t in sorted(faults, key=str)))
    lines.append("")
    lines += [f"## Over the {len(ok)} successful run(s)", ""]
    if ok:
        lines += ["Median, interquartile range (25th - 75th percentile) and range; the last "
                  "column counts the runs that had the figure (a detection delay needs a lost "
                  "vehicle, the oracle ratio a kill, a wall time a run that measured it).", ""]
        lines += _table(["figure", "median", "quartiles", "min - max", "runs"],
                        statistics_rows(ok))
        if any(r.oracle is not None for r in ok):
            lines += [ORACLE_NOTE, ""]
    else:
        lines += ["No run succeeded.", ""]
    lines += ["## Per seed", ""]
    rows = [_row(r) for r in runs]
    header = ["seed", "treated", "priority", "dup", "home", "detect s", "false alarms",
              "B/veh/min", "delivered", "oracle", "wall s", "error"]
    lines += _table(header, [[row[h] for h in header] for row in rows])
    lines += ["Columns: treated = spots treated of the scenario's (real spots of the real reef "
              "in a dynamic mission); priority = collected (share of the total); delivered = "
              "link deliveries / receptions; oracle = survivors' priority after a kill / a "
              "perfect-information replan's; wall s = the mission's wall time on the machine "
              "that ran it (the only figure that depends on the machine).", ""]
    md = out_dir / f"{stem}.md"
    md.write_text("\n".join(lines), encoding="utf-8")
    _write_csv(out_dir / f"{stem}.csv", runs)
    return md


def _row(r: RunResult) -> dict[str, str]:
    if isinstance(r, FailedRun):
        blank = dict.fromkeys(["treated", "priority", "dup", "home", "detect s",
                               "false alarms", "B/veh/min", "delivered", "oracle"], "-")
        error = r.error.replace("|", "/")
        return {"seed": str(r.seed), **blank, "wall s": "-",
                "error": (error.splitlines() or [""])[0][:160]}
    v = {m.key: m.value(r) for m in METRICS}
    c = r.collected
    return {"seed": str(r.seed),
            "treated": f"{c.spots}/{c.spots_of}" + (" real" if c.on_reef else ""),
            "priority": f"{_fmt(v['priority'], 0)} ({_fmt(100 * v['priority_share'], 0)} %)",
            "dup": _fmt(v["duplicates"], 0), "home": _fmt(v["vehicles_home"], 0),
            "detect s": _fmt(v["detect_s"], 1), "false alarms": _fmt(v["false_alarms"], 0),
            "B/veh/min": _fmt(v["bytes_per_vehicle_minute"], 0),
            "delivered": _fmt(v["delivered_share"], 3), "oracle": _fmt(v["oracle_ratio"], 3),
            "wall s": _fmt(v["wall_s"], 2), "error": ""}


def _write_csv(path: Path, runs: Sequence[RunResult]) -> None:
    metrics = [m for m in METRICS if m.key not in MACHINE_METRICS]
    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(["seed", "scenario", *[m.key for m in metrics], "drops", "error"])
        for r in runs:
            if isinstance(r, FailedRun):
                writer.writerow([r.seed, "", *[""] * len(metrics), "", r.error])
                continue
            drops = drop_reasons(r.messages.link or {})
            writer.writerow([r.seed, r.scenario, *[_csv_value(m.value(r)) for m in metrics],
                             ";".join(f"{k}={n}" for k, n in drops.items() if n), ""])


def machine_free(markdown: str) -> str:
    """A summary's Markdown without what depends on the machine (the wall-time row of the
    statistics and the ``wall s`` column of the per-seed table): the same for the same seeds
    whatever ran them."""
    wall = next(m.label for m in METRICS if m.key == "wall_s")
    out, column = [], None
    for line in markdown.splitlines():
        if line.startswith(f"| {wall} |"):
            continue
        cells = line.split(" | ")
        if line.startswith("| seed |") and "wall s" in cells:
            column = cells.index("wall s")
        if column is not None and line.startswith("|---"):
            line = line.replace("---|", "", 1)
        elif column is not None and line.startswith("|"):
            line = " | ".join(cells[:column] + cells[column + 1:])
        elif not line.startswith("|"):
            column = None
        out.append(line)
    return "\n".join(out)
