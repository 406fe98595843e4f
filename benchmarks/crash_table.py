"""The crash table: what a mission loses when one of its parts dies (issue 31, item 5).

``python -m benchmarks.crash_table [--seed N] [--warp W] [--cases a,b,...]``

Each case is the paper preset (seed 7 unless told) as real processes (`cotsfleet run`'s
launcher, `ProcessBackend`), with one crash at a fixed mission time, beside the same mission
without it:

- ``ground station killed``: SIGKILL of the ground station (recording to an .rrd) at 600 s;
- ``relay killed``: SIGKILL of the acoustic relay at 600 s;
- ``full disk``: the run dir on a 32 MiB tmpfs that another writer fills at 600 s (needs
  root to mount it; the case is skipped, saying so, without);
- ``empty journal``: auv2 killed at 900 s, its journal emptied, auv2 restarted at 1000 s;
- ``cut journal``: the same with its journal cut to a third.

In the journal cases the restarted agent learns the fleet's cleared set from its peers before
it acts (`fleet_agent.policies.rejoin`) and never claims work it did not do.
`crash_table` returns the rows and `main` writes the section ``crash_table`` of
benchmarks/RESULTS.md; `tests/integration/test_crashes.py` runs the same cases.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator

from benchmarks.results import markdown_table, write_section
from cotsfleet.mission.faults import Fault
from cotsfleet.mission.processes import ProcessBackend, ProcessOptions
from cotsfleet.mission.runner import run_mission
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import paper_preset_doc

CRASH_AT_S = 600.0
KILL_AT_S, RESTART_AT_S = 900.0, 1000.0
TMPFS_BYTES = 32 << 20
RUN_LIMIT_S = 600.0


@dataclass
class Case:
    """A crash: ``act(backend, run_dir)`` once mission time reaches ``at_s`` (and the
    faults the launcher applies itself)."""

    name: str
    at_s: float
    act: Callable[[ProcessBackend, Path], None]
    faults: tuple[Fault, ...] = ()
    station: bool = False  # start the ground station (recording to mission.rrd)
    tmpfs: bool = False  # the run dir on a small tmpfs


@dataclass
class Outcome:
    case: str
    report: dict[str, Any] | None
    run_dir: Path
    lines: list[str] = field(default_factory=list)  # what the launcher said
    skipped: str = ""
    events_on_disk: int = 0
    report_on_disk: bool = False


def _kill(name: str) -> Callable[[ProcessBackend, Path], None]:
    def act(backend: ProcessBackend, _: Path) -> None:
        child = backend.children[name]
        os.killpg(child.popen.pid, signal.SIGKILL)
    return act


def _fill(_: ProcessBackend, run_dir: Path) -> None:
    """Another writer takes every free byte of the run dir's file system."""
    chunk = bytes(1 << 16)
    with contextlib.suppress(OSError), open(run_dir / "filler", "wb") as fh:
        while True:
            fh.write(chunk)
            fh.flush()


def _journal(share: float) -> Callable[[ProcessBackend, Path], None]:
    def act(_: ProcessBackend, run_dir: Path) -> None:
        path = run_dir / "auv2.journal"
        size = path.stat().st_size if path.exists() else 0
        with open(path, "rb+") as fh:
            fh.truncate(int(size * share))
    return act


def _restart_faults() -> tuple[Fault, ...]:
    return (Fault("kill", KILL_AT_S, "auv2"), Fault("restart", RESTART_AT_S, "auv2"))


CASES = {
    "ground station killed": Case("ground station killed", CRASH_AT_S,
                                  _kill("ground_station"), station=True),
    "relay killed": Case("relay killed", CRASH_AT_S, _kill("relay")),
    "full disk": Case("full disk", CRASH_AT_S, _fill, tmpfs=True),
    "empty journal": Case("empty journal", (KILL_AT_S + RESTART_AT_S) / 2, _journal(0.0),
                          _restart_faults()),
    "cut journal": Case("cut journal", (KILL_AT_S + RESTART_AT_S) / 2, _journal(1 / 3),
                        _restart_faults()),
}


@contextlib.contextmanager
def _small_disk(path: Path) -> Iterator[str]:
    """``path`` as a `TMPFS_BYTES` tmpfs for the block; yields "" or why it could not be."""
    path.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={TMPFS_BYTES}", "tmpfs",
                           str(path)], capture_output=True, text=True)
    if done.returncode != 0:
        yield f"cannot mount a tmpfs (needs root): {done.stderr.strip() or done.returncode}"
        return
    try:
        yield ""
    finally:
        subprocess.run(["umount", "-l", str(path)], capture_output=True)


def run_case(case: Case | None, root: Path, seed: int = 7, warp: float = 60.0) -> Outcome:
    """The paper preset with ``case``'s crash (None: without one), in ``root``."""
    name = case.name if case else "no crash"
    run_dir = root / name.replace(" ", "_")
    with contextlib.ExitStack() as stack:
        if case is not None and case.tmpfs:
            why = stack.enter_context(_small_disk(run_dir))
            if why:
                return Outcome(name, None, run_dir, skipped=why)
        out = _run(case, run_dir, seed, warp)
        if case is not None and case.tmpfs:  # what the small disk held, before it goes
            kept = run_dir.with_name(run_dir.name + "_saved")
            shutil.copytree(run_dir, kept, ignore=shutil.ignore_patterns(
                "filler", ".disk-reserve", "credentials"))
            out.run_dir = kept
        return out


def _run(case: Case | None, run_dir: Path, seed: int, warp: float) -> Outcome:
    doc = paper_preset_doc(seed)
    problem = problem_from_dict(doc)
    out = Outcome(case.name if case else "no crash", None, run_dir)
    station = case is not None and case.station
    backend = ProcessBackend(problem, doc, seed, ProcessOptions(
        warp=warp, run_dir=run_dir, progress_every_s=0,
        rrd=run_dir / "mission.rrd" if station else None), out=out.lines.append)
    result: dict[str, Any] = {}
    thread = threading.Thread(target=lambda: result.update(report=run_mission(
        problem, backend, case.faults if case else (), seed=seed, step_s=warp * 0.25).report),
        daemon=True)
    thread.start()
    try:
        if case is not None:
            deadline = time.monotonic() + RUN_LIMIT_S
            while backend.now() < case.at_s and thread.is_alive() \
                    and time.monotonic() < deadline:
                time.sleep(0.02)
            if thread.is_alive():
                case.act(backend, run_dir)
        thread.join(RUN_LIMIT_S)
    finally:
        if thread.is_alive():  # last resort: leave nothing behind
            for child in backend.children.values():
                if child.popen.poll() is None:
                    os.killpg(child.popen.pid, signal.SIGKILL)
    report = result.get("report")
    if report is not None:  # what `cotsfleet run` would write, as it would
        from cotsfleet.commands.mission_args import write_reports

        with contextlib.redirect_stdout(open(os.devnull, "w")), \
                contextlib.redirect_stderr(open(os.devnull, "w")):
            write_reports(report, run_dir / "report.json", backend.ledger.events, doc)
        out.report = report.to_dict()  # the document, as report.json holds it
    out.report_on_disk = (run_dir / "report.json").exists() and _json_ok(run_dir / "report.json")
    events = run_dir / "events.jsonl"
    out.events_on_disk = len(events.read_text().splitlines()) if events.exists() else 0
    return out


def _json_ok(path: Path) -> bool:
    try:
        json.loads(path.read_text())
        return True
    except (OSError, ValueError):
        return False


HEADER = ["case", "spots", "priority", "vs no crash", "duplicates", "false alarms",
          "vehicles home", "crashes (action)", "events saved", "report", "lost"]


def row(outcome: Outcome, baseline: Outcome | None) -> list[object]:
    """One row of the table for ``outcome``, against ``baseline`` (the same seed, no crash)."""
    if outcome.report is None:
        return [outcome.case, "", "", "", "", "", "", "", "", "",
                outcome.skipped or "no report"]
    r, f = outcome.report, outcome.report["fleet"]
    base = baseline.report["fleet"]["priority"] if baseline and baseline.report else None
    crashes = ", ".join(f"{c['name']} ({c['action']})" for c in r.get("crashes", [])) or "-"
    saved = r.get("saved", {})
    return [outcome.case, f["spots_cleared"], round(f["priority"], 1),
            f"{f['priority'] / base:.2f}" if base else "", f["duplicate_treatments"],
            f["false_alarms"], f["vehicles_home"], crashes,
            f"{outcome.events_on_disk}/{saved.get('events_total', '?')}",
            "written" if outcome.report_on_disk else "LOST", lost(outcome, baseline)]


def lost(outcome: Outcome, baseline: Outcome | None) -> str:
    """In words: what this crash cost."""
    r = outcome.report or {}
    notes = []
    if baseline and baseline.report and r:
        gap = baseline.report["fleet"]["spots_cleared"] - r["fleet"]["spots_cleared"]
        if gap > 0:
            notes.append(f"{gap} spot(s)")
    for c in r.get("crashes", []):
        if c["name"] == "relay":
            notes.append("frames in flight and the first relay's link counters")
        elif c["name"] == "ground_station":
            notes.append("the dashboard for a moment; the recording goes on in a new .rrd")
        elif "disk is full" in c["why"]:
            notes.append(f"{c['name']} (disk full)")
    if r.get("failure"):
        notes.append(f"ended early: {r['failure'][:80]}")
    return "; ".join(notes) or "nothing"


def crash_table(seed: int = 7, warp: float = 60.0,
                names: tuple[str, ...] = tuple(CASES)) -> list[list[object]]:
    """Run the mission without a crash, then each case named; the table's rows."""
    with tempfile.TemporaryDirectory() as tmp:
        baseline = run_case(None, Path(tmp), seed, warp)
        rows = [row(baseline, baseline)]
        for name in names:
            outcome = run_case(CASES[name], Path(tmp), seed, warp)
            rows.append(row(outcome, baseline))
            print(" | ".join(str(x) for x in rows[-1]), flush=True)
    return rows


def main(seed: int, warp: float, names: tuple[str, ...]) -> None:
    rows = crash_table(seed, warp, names)
    write_section("crash_table", "Crash table: what a mission loses when a part dies",
                  markdown_table(HEADER, rows) + f"\n\nPaper preset, seed {seed}, warp "
                  f"{warp:g}, real processes; crashes at {CRASH_AT_S:g} s (journal cases: "
                  f"auv2 killed at {KILL_AT_S:g} s, journal damaged, restarted at "
                  f"{RESTART_AT_S:g} s). A restarted agent whose journal is empty or cut "
                  "keeps station until it has learned the fleet's cleared set from its peers "
                  "(`fleet_agent.policies.rejoin`): it treats nothing twice; what it lost is "
                  "the work it did not do while down and holding (the 'lost' column: spots the "
                  "mission without the crash treated and this one did not).")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--warp", type=float, default=60.0)
    parser.add_argument("--cases", default=",".join(CASES))
    args = parser.parse_args()
    main(args.seed, args.warp, tuple(c.strip() for c in args.cases.split(",") if c.strip()))
