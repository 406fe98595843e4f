"""`cotsfleet run`: an emulated mission, one OS process per vehicle, over Zenoh."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from cotsfleet.cli import UsageError
from cotsfleet.commands.mission_args import add_mission_arguments

HELP = "run an emulated mission: router, link emulator, one agent process per AUV, dashboard"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_mission_arguments(p, "the paper preset drawn with --seed")
    p.add_argument("--warp", type=float, default=60.0, help="simulated seconds per wall second")
    p.add_argument("--viewer", choices=("web", "native", "none"),
                   help="Rerun viewer (default: native with a display, else web)")
    p.add_argument("--rrd", type=Path, help="also record the mission to this .rrd file")
    p.add_argument("--web-port", type=int, default=9090, help="web viewer port")
    p.add_argument("--report", type=Path, help="mission report JSON (default: in the run dir)")
    p.add_argument("--run-dir", type=Path, help="journals, logs, report (default: a new "
                   "directory under $TMPDIR/cotsfleet-runs)")
    p.add_argument("--listen", metavar="ENDPOINT", help="router endpoint, e.g. tcp/0.0.0.0:7447 "
                   "so agents on other machines can join (default: a free loopback port)")
    p.add_argument("--remote", action="append", default=[], metavar="ID",
                   help="a vehicle whose agent runs elsewhere: not started here, waited for "
                   "(repeatable; needs fleet_key_hex in --config)")
    p.add_argument("--startup-timeout", type=float, default=90.0, metavar="S",
                   help="wall seconds to wait for every agent to be ready (default 90)")
    p.add_argument("--hold-viewer", action=argparse.BooleanOptionalAction,
                   help="keep the web dashboard up after the mission until Ctrl-C "
                   "(default: yes for --viewer web in an interactive terminal)")


def _faults(specs: list[str], what: str) -> tuple[tuple[str, float], ...]:
    from fleet_agent.sim import parse_at

    try:
        return tuple(parse_at(s) for s in specs)
    except ValueError as exc:
        raise UsageError(f"--{what}: {exc}") from None


def run(args: argparse.Namespace) -> int:
    from cotsfleet.launcher import LaunchOptions, run_mission, scenario_doc
    from fleet_agent.config import AgentConfig, load_config

    viewer = args.viewer
    if viewer is None:
        from ground_station.viewer import default_viewer

        viewer = default_viewer()
    hold = args.hold_viewer
    if hold is None:
        hold = viewer == "web" and sys.stdin.isatty()
    try:
        config = load_config(args.config) if args.config else AgentConfig()
        opts = LaunchOptions(
            scenario=scenario_doc(args.scenario, args.vehicles, args.seed), seed=args.seed,
            warp=args.warp, loss=args.loss, aborts=_faults(args.abort, "abort"),
            kills=_faults(args.kill, "kill"), restarts=_faults(args.restart, "restart"),
            viewer=viewer, rrd=args.rrd, web_port=args.web_port, run_dir=args.run_dir,
            report=args.report, agent_config=config, hold_viewer=hold,
            listen=args.listen, remote=tuple(args.remote),
            startup_timeout_s=args.startup_timeout)
        report = run_mission(opts)
    except (RuntimeError, TimeoutError) as exc:  # TimeoutError first: it is an OSError
        print(f"cotsfleet run: failed: {exc}")
        return 1
    except (ValueError, OSError) as exc:
        raise UsageError(str(exc)) from None
    return 130 if report.get("interrupted") else 0
