"""`cotsfleet sim`: the same agents in one process, on the deterministic transport and clock."""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path
from typing import Any

from cotsfleet.cli import UsageError
from cotsfleet.commands.mission_args import add_mission_arguments, mission_args

HELP = "simulate missions in-process (deterministic, seeded; --runs N for Monte Carlo)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_mission_arguments(p, "the paper preset, drawn anew for each run's seed")
    p.add_argument("--runs", type=int, default=1, help="Monte Carlo runs (seeds seed..)")
    p.add_argument("--report", type=Path, help="write the report(s) here (JSON)")


def _row(report: dict[str, Any]) -> dict[str, float]:
    f, m = report["fleet"], report["messages"]
    delays = [d for row in f["detection_delay_s"].values() for d in row.values() if d is not None]
    return {"cleared": f["spots_cleared"], "priority": f["priority"],
            "duplicates": f["duplicate_treatments"], "home": f["vehicles_home"],
            "detect_s": max(delays) if delays else float("nan"),
            "false_alarms": f["false_alarms"], "B/veh/min": m["bytes_per_vehicle_minute"],
            "oracle": report.get("oracle", {}).get("ratio", float("nan"))}


def summary_table(rows: list[dict[str, float]]) -> str:
    keys = list(rows[0])
    lines = [f"{'':<6}" + "".join(f"{k:>13}" for k in keys)]
    for name, fn in (("mean", statistics.fmean), ("min", min), ("max", max)):
        cells = []
        for k in keys:
            vals = [r[k] for r in rows if r[k] == r[k]]  # drop NaN
            cells.append(f"{fn(vals):>13.4g}" if vals else f"{'-':>13}")
        lines.append(f"{name:<6}" + "".join(cells))
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from cotsfleet.mission.inprocess import simulate
    from cotsfleet.mission.report import format_report

    if args.runs < 1:
        raise UsageError("--runs must be >= 1")
    reports, rows = [], []
    for i in range(args.runs):
        m = mission_args(args, seed=args.seed + i)
        result = simulate(m.problem, m.config, seed=m.seed, loss=m.loss, faults=m.faults)
        reports.append({**result.report, "wall_s": round(result.wall_s, 3)})
        rows.append(_row(result.report))
        if args.runs == 1:
            print(format_report(result.report))
            print(f"wall {result.wall_s:.2f} s")
        else:
            done = int(30 * (i + 1) / args.runs)
            print(f"\r[{'#' * done}{'.' * (30 - done)}] {i + 1}/{args.runs} runs",
                  end="" if sys.stderr.isatty() else "\n", file=sys.stderr, flush=True)
    if args.runs > 1:
        print(file=sys.stderr)
        print(summary_table(rows))
    if args.report is not None:
        args.report.parent.mkdir(parents=True, exist_ok=True)
        args.report.write_text(json.dumps(reports[0] if args.runs == 1 else reports, indent=2),
                               encoding="utf-8")
    return 0
