"""`cotsfleet report`: render a saved mission report (or a sweep's) for a person to read."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from cotsfleet.errors import UsageError

HELP = "render report.md and figures from a saved report.json (or sweep.md from a list)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("report", type=Path, metavar="REPORT.json",
                   help="a mission report (cotsfleet run/sim --report), or a list of them")
    p.add_argument("--events", type=Path, metavar="EVENTS.jsonl",
                   help="the mission's event log (default: events.jsonl next to the report "
                        "or in its run directory)")
    p.add_argument("--scenario", type=Path, metavar="SCENARIO.json",
                   help="the mission's scenario, for spot priorities and injection times "
                        "(default: scenario.json next to the report or in its run directory)")
    p.add_argument("-o", "--output", type=Path, metavar="DIR",
                   help="where to write (default: the report's directory)")


def beside(report_path: Path, report: dict[str, Any], name: str) -> Path | None:
    """``name`` next to the report, else in the run directory the report names, if any."""
    places = [report_path.parent / name]
    if isinstance(report.get("run_dir"), str):
        places.append(Path(report["run_dir"]) / name)
    return next((p for p in places if p.is_file()), None)


def run(args: argparse.Namespace) -> int:
    from cotsfleet.io import read_json
    from cotsfleet.reporting import read_events, write_report_bundle, write_sweep_summary

    doc = read_json(args.report)
    out = args.output or args.report.parent
    if out.exists() and not out.is_dir():
        raise UsageError(f"-o {out}: not a directory")
    if isinstance(doc, list):
        if not doc or not all(isinstance(r, dict) for r in doc):
            raise UsageError(f"{args.report}: expected a list of mission reports")
        print(f"wrote {write_sweep_summary(doc, out)}")
        return 0
    if not isinstance(doc, dict) or not isinstance(doc.get("fleet"), dict):
        raise UsageError(f"{args.report}: not a mission report (no 'fleet' section)")
    events_path = args.events or beside(args.report, doc, "events.jsonl")
    scenario_path = args.scenario or beside(args.report, doc, "scenario.json")
    events = None
    if events_path is not None:
        from cotsfleet.io import read_text

        read_text(events_path)  # a clean error for a missing or unreadable file
        try:
            events = read_events(events_path)
        except ValueError as exc:
            raise UsageError(str(exc)) from None
    scenario = read_json(scenario_path) if scenario_path is not None else None
    if scenario is not None and not isinstance(scenario, dict):
        raise UsageError(f"{scenario_path}: not a scenario document")
    try:
        paths = write_report_bundle(doc, out, events, scenario)
    except OSError as exc:
        raise UsageError(f"cannot write into {out}: {exc}") from None
    used = [f"events {events_path}" if events_path else "no event log",
            f"scenario {scenario_path}" if scenario_path else "no scenario"]
    print(f"wrote {', '.join(str(p) for p in paths)} ({'; '.join(used)})")
    return 0
