"""`cotsfleet sim`: the same agents in one process, on the deterministic transport and clock."""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from pathlib import Path
from typing import Any

from cotsfleet.cli import UsageError
from cotsfleet.commands.mission_args import add_mission_arguments, mission_args, write_reports

HELP = "simulate missions in-process (deterministic, seeded; --runs N for Monte Carlo)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_mission_arguments(p, "the paper preset, drawn anew for each run's seed")
    p.add_argument("--runs", type=int, default=1, help="Monte Carlo runs (seeds seed..)")
    p.add_argument("--report", type=Path, help="report JSON (default: report.json, or "
                   "runs.json for several runs, in --out)")
    p.add_argument("--out", type=Path, help="where report.md, figures and JSON go (default: a "
                   "new directory under $TMPDIR/cotsfleet-runs)")


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
    for name, fn in (("median", statistics.median), ("mean", statistics.fmean), ("min", min),
                     ("max", max)):
        cells = []
        for k in keys:
            vals = [r[k] for r in rows if r[k] == r[k]]  # drop NaN
            cells.append(f"{fn(vals):>13.4g}" if vals else f"{'-':>13}")
        lines.append(f"{name:<6}" + "".join(cells))
    return "\n".join(lines)


def _out_dir(args: argparse.Namespace) -> Path:
    if args.out is not None:
        return args.out
    run_id = time.strftime("%Y%m%d-%H%M%S") + f"-sim{args.seed}"
    return Path(os.environ.get("TMPDIR", "/tmp")) / "cotsfleet-runs" / run_id


def run(args: argparse.Namespace) -> int:
    from cotsfleet.mission.inprocess import simulate
    from cotsfleet.reporting import write_sweep_summary
    from cotsfleet.reporting.progress import Progress

    if args.runs < 1:
        raise UsageError("--runs must be >= 1")
    out = _out_dir(args)
    if args.runs == 1:
        m = mission_args(args)
        result = simulate(m.problem, m.config, seed=m.seed, loss=m.loss, faults=m.faults)
        report = {**result.report, "wall_s": round(result.wall_s, 3)}
        write_reports(report, args.report or out / "report.json", result.events, m.scenario)
        print(f"wall {result.wall_s:.2f} s")
        return 0
    reports, rows = [], []
    with Progress(args.runs, "sim", "run") as progress:
        for i in range(args.runs):
            seed = args.seed + i
            progress.start(f"seed {seed}")
            m = mission_args(args, seed=seed)
            result = simulate(m.problem, m.config, seed=m.seed, loss=m.loss, faults=m.faults)
            reports.append({**result.report, "wall_s": round(result.wall_s, 3)})
            rows.append(_row(result.report))
            f = result.report["fleet"]
            progress.done(f"seed {seed}", f"{f['spots_cleared']}/{f['spots_total']} spots")
    print(summary_table(rows))
    path = args.report or out / "runs.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(reports, indent=2), encoding="utf-8")
    summary = write_sweep_summary(reports, path.parent)
    print(f"reports: {path} and {summary}")
    return 0
