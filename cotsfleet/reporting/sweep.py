"""``sweep.md`` (and ``sweep.csv``): many missions summarised by medians and quartiles, with
one row per seed, failed runs included.

A run that failed is a dict with its ``seed`` and an ``error`` (and no ``fleet``); it is
counted, listed with its error, and left out of the statistics.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from cotsfleet.reporting.plots import drop_reasons


def _ratio(a: Any, b: Any) -> float:
    try:
        a, b = float(a), float(b)
    except (TypeError, ValueError):
        return math.nan
    return a / b if b > 0 else math.nan


def _slowest_detection(r: Mapping[str, Any]) -> float:
    rows = (r.get("fleet", {}).get("detection_delay_s") or {}).values()
    delays = [d for row in rows for d in row.values() if d is not None]
    return max(delays) if delays else math.nan


def _get(*path: str) -> Callable[[Mapping[str, Any]], float]:
    def get(r: Mapping[str, Any]) -> float:
        value: Any = r
        for key in path:
            value = value.get(key) if isinstance(value, Mapping) else None
        return float(value) if isinstance(value, (int, float)) else math.nan
    return get


@dataclass(frozen=True)
class Metric:
    key: str
    label: str  # says what a ratio is a ratio to
    value: Callable[[Mapping[str, Any]], float]
    digits: int = 0


METRICS = (
    Metric("spots_cleared", "spots cleared", _get("fleet", "spots_cleared")),
    Metric("spots_share", "spots cleared / the scenario's spots",
           lambda r: _ratio(_get("fleet", "spots_cleared")(r), _get("fleet", "spots_total")(r)),
           3),
    Metric("priority", "priority collected", _get("fleet", "priority"), 1),
    Metric("priority_share", "priority collected / the scenario's total priority",
           lambda r: _ratio(_get("fleet", "priority")(r), _get("fleet", "priority_total")(r)),
           3),
    Metric("duplicates", "duplicate treatments (spots injected twice)",
           _get("fleet", "duplicate_treatments")),
    Metric("vehicles_home", "vehicles home", _get("fleet", "vehicles_home")),
    Metric("detect_s", "slowest detection of a lost vehicle, s", _slowest_detection, 1),
    Metric("false_alarms", "false alarms (live vehicles declared lost)",
           _get("fleet", "false_alarms")),
    Metric("bytes_per_vehicle_minute", "bytes sent per vehicle per minute",
           _get("messages", "bytes_per_vehicle_minute")),
    Metric("delivered_share", "link deliveries / receptions",
           lambda r: _ratio(_get("messages", "link", "delivered")(r),
                            _get("messages", "link", "sent")(r)), 3),
    Metric("oracle_ratio", "survivors' priority after a kill / a perfect-information "
           "replan's (note 1)", _get("oracle", "ratio"), 3),
    Metric("wall_s", "wall time, s", _get("wall_s"), 2),
)


ORACLE_NOTE = (
    "Note 1: the priority the surviving vehicles collected after the kill, divided by the "
    "priority of a centralized replan of the survivors made at the kill time with perfect "
    "information (true positions, batteries, cleared spots). That replan is the heuristic "
    "planner with a fixed iteration budget, not an optimum, so a fleet that keeps improving "
    "its routes can beat it: ratios above 1 are possible and not an error.")


def failed(report: Mapping[str, Any]) -> bool:
    return "error" in report or not isinstance(report.get("fleet"), Mapping)


def _fmt(value: float, digits: int) -> str:
    return "-" if math.isnan(value) else f"{value:,.{digits}f}"


def statistics_rows(reports: Sequence[Mapping[str, Any]]) -> list[list[str]]:
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


def _seed(r: Mapping[str, Any]) -> Any:
    return r.get("seed", "-")


def _seed_list(seeds: Sequence[Any]) -> str:
    return ", ".join(map(str, seeds)) if len(seeds) <= 12 else f"{seeds[0]} .. {seeds[-1]}"


def _csv_value(value: float) -> Any:
    if math.isnan(value):
        return ""
    return int(value) if float(value).is_integer() else value


def write_sweep_summary(reports: Sequence[Mapping[str, Any]], out_dir: Path) -> Path:
    """Write ``sweep.md`` and ``sweep.csv`` into ``out_dir``; return the Markdown's path."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    ok = [r for r in reports if not failed(r)]
    bad = [r for r in reports if failed(r)]
    scenarios = sorted({str(r.get("scenario")) for r in ok if r.get("scenario")})
    modes = sorted({str(r.get("mode")) for r in ok if r.get("mode")})
    seeds = [_seed(r) for r in reports]
    lines = [f"# Sweep: {len(reports)} run(s)", "",
             f"- **Scenarios:** {', '.join(scenarios) or '-'}; mode {', '.join(modes) or '-'}",
             f"- **Seeds:** {_seed_list(seeds)}",
             f"- **Failed runs:** {len(bad)} of {len(reports)}"]
    faults = {(f.get("kind"), f.get("vid"), f.get("t_s")) for r in ok for f in r.get("faults", [])}
    if faults:
        lines.append("- **Faults:** " + ", ".join(f"{k} {v or ''}@{t:g}".replace(" @", "@")
                                                  for k, v, t in sorted(faults, key=str)))
    lines.append("")
    lines += [f"## Over the {len(ok)} successful run(s)", ""]
    if ok:
        lines += ["Median, interquartile range (25th - 75th percentile) and range; the last "
                  "column counts the runs that had the figure (a detection delay needs a lost "
                  "vehicle, the oracle ratio a kill).", ""]
        lines += _table(["figure", "median", "quartiles", "min - max", "runs"],
                        statistics_rows(ok))
        if any(not math.isnan(_get("oracle", "ratio")(r)) for r in ok):
            lines += [ORACLE_NOTE, ""]
    else:
        lines += ["No run succeeded.", ""]
    lines += ["## Per seed", ""]
    rows = [_row(r) for r in reports]
    header = ["seed", "cleared", "priority", "dup", "home", "detect s", "false alarms",
              "B/veh/min", "delivered", "oracle", "wall s", "error"]
    lines += _table(header, [[row[h] for h in header] for row in rows])
    lines += ["Columns: cleared = spots cleared of the scenario's; priority = collected "
              "(share of the scenario's total); delivered = link deliveries / receptions; "
              "oracle = survivors' priority after a kill / a perfect-information replan's.", ""]
    md = out_dir / "sweep.md"
    md.write_text("\n".join(lines), encoding="utf-8")
    _write_csv(out_dir / "sweep.csv", reports)
    return md


def _row(r: Mapping[str, Any]) -> dict[str, str]:
    if failed(r):
        blank = dict.fromkeys(["cleared", "priority", "dup", "home", "detect s", "false alarms",
                               "B/veh/min", "delivered", "oracle", "wall s"], "-")
        error = str(r.get("error", "no fleet figures in the report")).replace("|", "/")
        return {"seed": str(_seed(r)), **blank, "error": error.splitlines()[0][:160]}
    v = {m.key: m.value(r) for m in METRICS}
    return {"seed": str(_seed(r)),
            "cleared": f"{_fmt(v['spots_cleared'], 0)}/{_fmt(_get('fleet', 'spots_total')(r), 0)}",
            "priority": f"{_fmt(v['priority'], 0)} ({_fmt(100 * v['priority_share'], 0)} %)",
            "dup": _fmt(v["duplicates"], 0), "home": _fmt(v["vehicles_home"], 0),
            "detect s": _fmt(v["detect_s"], 1), "false alarms": _fmt(v["false_alarms"], 0),
            "B/veh/min": _fmt(v["bytes_per_vehicle_minute"], 0),
            "delivered": _fmt(v["delivered_share"], 3), "oracle": _fmt(v["oracle_ratio"], 3),
            "wall s": _fmt(v["wall_s"], 2), "error": ""}


def _write_csv(path: Path, reports: Sequence[Mapping[str, Any]]) -> None:
    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(["seed", "scenario", *[m.key for m in METRICS], "drops", "error"])
        for r in reports:
            if failed(r):
                writer.writerow([_seed(r), r.get("scenario", ""), *[""] * len(METRICS), "",
                                 r.get("error", "")])
                continue
            drops = drop_reasons(r.get("messages", {}).get("link") or {})
            writer.writerow([_seed(r), r.get("scenario", ""),
                             *[_csv_value(m.value(r)) for m in METRICS],
                             ";".join(f"{k}={n}" for k, n in drops.items() if n), ""])
