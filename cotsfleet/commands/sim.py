"""`cotsfleet sim`: the same agents in one process, on the deterministic transport and clock."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import Any, Callable, Sequence, TextIO

import msgspec

from cotsfleet.commands.checks import json_output, output_dir
from cotsfleet.commands.mission_args import add_mission_arguments, mission_args, write_reports
from cotsfleet.errors import UsageError
from cotsfleet.mission.report_model import FailedRun
from fleet_bus.telemetry import Event

HELP = "simulate missions in-process (deterministic, seeded; --runs N for Monte Carlo)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_mission_arguments(p, "the paper preset, drawn anew for each run's seed")
    p.add_argument("--runs", type=int, default=1, help="Monte Carlo runs (seeds seed..)")
    p.add_argument("--jobs", "-j", type=int, metavar="K",
                   help="run K seeds at a time in worker processes on this machine (default "
                        "1: in this process); with --scheduler local, the local cluster's "
                        "workers (default: one per core)")
    p.add_argument("--scheduler", nargs="?", const="local", metavar="ADDRESS",
                   help="run the sweep on a Dask cluster: tcp://HOST:8786 names one; alone "
                        "(or 'local') starts a local cluster for the sweep (needs the "
                        "'cluster' extra)")
    p.add_argument("--report", type=Path, help="report JSON, R.json: R.md and R-*.png beside it "
                   "(default: report.json, or sweep.json for several runs, in --out)")
    p.add_argument("--out", type=Path, help="where the JSON, Markdown and figures go unless "
                   "--report says (default: a new directory under $TMPDIR/cotsfleet-runs)")


def _out_dir(args: argparse.Namespace) -> Path:
    if args.out is not None:
        return args.out
    run_id = time.strftime("%Y%m%d-%H%M%S") + f"-sim{args.seed}"
    return Path(os.environ.get("TMPDIR", "/tmp")) / "cotsfleet-runs" / run_id


def run(args: argparse.Namespace) -> int:
    from cotsfleet.mission.faults import FaultError
    from cotsfleet.mission.inprocess import simulate
    from reef_sim.navigation import navigation_from_doc

    if args.runs < 1:
        raise UsageError("--runs must be >= 1")
    json_output(args.report, "--report")
    output_dir(args.out, "--out")
    out = _out_dir(args)
    if args.runs == 1:
        if args.jobs is not None or args.scheduler is not None:
            print("note: one run is simulated here; --jobs and --scheduler are for sweeps "
                  "(--runs N)", file=sys.stderr)
        m = mission_args(args)
        progress = SimProgress(m.problem.n_tasks)
        print(f"planning the fleet: {m.problem.n_vehicles} vehicles, {m.problem.n_tasks} "
              "spots", file=sys.stderr, flush=True)
        try:
            result = simulate(m.problem, m.config, seed=m.seed, loss=m.loss, faults=m.faults,
                              reef=m.reef, navigation=navigation_from_doc(m.scenario),
                              progress=progress)
        except FaultError as exc:  # a fault the simulation cannot make (`backend.check`)
            raise UsageError(str(exc)) from None
        progress.close()
        report = msgspec.structs.replace(result.report, wall_s=round(result.wall_s, 3))
        path = args.report or out / "report.json"
        write_reports(report, path, result.events, m.scenario)
        save_inputs(path, result.events, m.scenario)
        print(f"wall {result.wall_s:.2f} s")
        return 0
    return sweep(args, out)


class SimProgress:
    """A line on stderr every ``every_s`` wall seconds during a simulated mission: mission
    time, spots cleared, wall time and an ETA (a tqdm-style line; a long `sim` of a hundred
    vehicles says where it is instead of nothing for minutes)."""

    def __init__(self, n_tasks: int, every_s: float = 5.0, stream: TextIO | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.n_tasks, self.every_s = n_tasks, every_s
        self.stream = stream if stream is not None else sys.stderr
        self.clock = clock
        self.t0 = clock()
        self._next = self.t0
        self._ledger: Any = None
        self._horizon_s = 0.0
        self._started: float | None = None

    def bind(self, ledger: Any, horizon_s: float) -> None:
        """The mission is planned and starts: what to count, and until when."""
        self._ledger, self._horizon_s = ledger, horizon_s
        self._started = self.clock()
        print(f"planned in {self._started - self.t0:.1f} s; simulating {horizon_s:.0f} "
              "mission seconds", file=self.stream, flush=True)

    def __call__(self, t_s: float) -> None:
        now = self.clock()
        if now < self._next or self._started is None:
            return
        self._next = now + self.every_s
        done = len(self._ledger.cleared) if self._ledger is not None else 0
        wall = now - self._started
        share = t_s / self._horizon_s if self._horizon_s > 0 else 1.0
        eta = wall * (1.0 - share) / share if share > 0 else 0.0
        print(f"sim: t={t_s:6.0f}/{self._horizon_s:.0f} s  cleared {done}/{self.n_tasks}  "
              f"wall {_clock(wall)}  ETA {_clock(eta)} (at most: the mission may end sooner)",
              file=self.stream, flush=True)

    def close(self) -> None:
        if self._started is not None:
            print(f"simulated in {_clock(self.clock() - self._started)}", file=self.stream,
                  flush=True)


def _clock(s: float) -> str:
    m, s = divmod(int(round(s)), 60)
    return f"{m}:{s:02d}"


def save_inputs(path: Path, events: Sequence[Event], scenario: dict[str, Any]) -> None:
    """``R-events.jsonl`` and ``R-scenario.json`` beside ``R.json``: what `cotsfleet report`
    needs to draw the report again (a run keeps them in its run directory)."""
    stem = path.parent / path.stem
    with open(f"{stem}-events.jsonl", "w", encoding="utf-8") as fh:
        for e in events:
            fh.write(json.dumps(e.to_dict()) + "\n")
    Path(f"{stem}-scenario.json").write_text(json.dumps(scenario), encoding="utf-8")


def sweep(args: argparse.Namespace, out: Path) -> int:
    """``--runs N``: seeds seed..seed+N-1 here, on local workers or on a Dask cluster; one
    JSON and sweep.md, the same for the same seeds whatever ran them (docs/sweeps.md).
    Exit 0 when every run succeeded, 1 when some failed (all are written), 130 on Ctrl-C."""
    from cotsfleet.sweep import SweepSpec
    from cotsfleet.sweep.aggregate import summary_table, write_outputs
    from cotsfleet.sweep.run import executor_for, run_sweep

    if args.jobs is not None and args.scheduler not in (None, "local"):
        print(f"note: --jobs sizes a local pool; the workers of {args.scheduler} run the "
              "sweep", file=sys.stderr)
    spec = SweepSpec.from_args(args)  # bad files or faults stop here, before any worker
    seeds = range(args.seed, args.seed + args.runs)
    outcome = run_sweep(spec, seeds, executor_for(args.runs, args.jobs, args.scheduler))
    if outcome.results:
        print(summary_table(outcome.results))
        path = args.report or out / "sweep.json"
        summary = write_outputs(outcome.results, path)
        print(f"reports: {path} and {summary}")
    print(f"{len(outcome.results)} of {outcome.seeds} run(s) in {outcome.wall_s:.1f} s wall "
          f"on {outcome.where}" + (" (interrupted)" if outcome.interrupted else ""))
    if outcome.interrupted:
        return 130
    return 1 if any(isinstance(r, FailedRun) for r in outcome.results) else 0
