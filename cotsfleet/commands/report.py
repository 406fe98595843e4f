"""`cotsfleet report`: render a saved mission report (or a sweep's) for a person to read."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from cotsfleet.commands.checks import output_dir
from cotsfleet.errors import UsageError

HELP = "render a saved report.json as Markdown and figures beside it (a list: a sweep summary)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("report", type=Path, metavar="REPORT.json",
                   help="a mission report (cotsfleet run/sim --report), or a list of them "
                        "(sim --runs N); R.json gives R.md and R-*.png (a list: R.md, R.csv)")
    p.add_argument("--events", type=Path, metavar="EVENTS.jsonl",
                   help="the mission's event log (default: R-events.jsonl or events.jsonl "
                        "next to R.json, or events.jsonl in its run directory)")
    p.add_argument("--scenario", type=Path, metavar="SCENARIO.json",
                   help="the mission's scenario, for spot priorities, the real reef and "
                        "injection times (default: R-scenario.json or scenario.json next to "
                        "R.json, or scenario.json in its run directory)")
    p.add_argument("-o", "--output", type=Path, metavar="DIR",
                   help="where to write (default: the report's directory)")


def beside(report_path: Path, run_dir: str | None, name: str) -> Path | None:
    """``R-name`` next to ``R.json`` (what `cotsfleet sim` writes), else ``name`` next to it,
    else in the run directory the report names (what `cotsfleet run` writes), if any."""
    places = [report_path.parent / f"{report_path.stem}-{name}", report_path.parent / name]
    if run_dir:
        places.append(Path(run_dir) / name)
    return next((p for p in places if p.is_file()), None)


def run(args: argparse.Namespace) -> int:
    from cotsfleet.io import read_json, read_text
    from cotsfleet.mission.report_model import MissionReport, ReportError, runs_from_list
    from cotsfleet.reporting import read_events, write_report_bundle, write_sweep_summary
    from hfc_core.model.errors import ScenarioError

    doc = read_json(args.report)
    out = output_dir(args.output, "-o") or args.report.parent
    stem = args.report.stem
    try:
        if isinstance(doc, list):
            runs = runs_from_list(doc, str(args.report))
            print(f"wrote {write_sweep_summary(runs, out, stem)}")
            return 0
        report = MissionReport.from_dict(doc, str(args.report))
    except ReportError as exc:
        raise UsageError(str(exc)) from None
    events_path = args.events or beside(args.report, report.run_dir, "events.jsonl")
    scenario_path = args.scenario or beside(args.report, report.run_dir, "scenario.json")
    events = None
    if events_path is not None:
        read_text(events_path)  # a clean error for a missing or unreadable file
        try:
            events = read_events(events_path)
        except ValueError as exc:
            raise UsageError(str(exc)) from None
    scenario: Any = read_json(scenario_path) if scenario_path is not None else None
    if scenario is not None and not isinstance(scenario, dict):
        raise UsageError(f"{scenario_path}: not a scenario document")
    try:
        paths = write_report_bundle(report, out, events, scenario, stem=stem)
    except ScenarioError as exc:
        raise UsageError(f"{scenario_path}: {exc}") from None
    except OSError as exc:
        raise UsageError(f"cannot write into {out}: {exc}") from None
    used = [f"events {events_path}" if events_path else "no event log",
            f"scenario {scenario_path}" if scenario_path else "no scenario"]
    print(f"wrote {', '.join(str(p) for p in paths)} ({'; '.join(used)})")
    return 0
