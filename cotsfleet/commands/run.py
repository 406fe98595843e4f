"""`cotsfleet run`: an emulated mission, one OS process per vehicle, over Zenoh."""

from __future__ import annotations

import argparse
import signal
import socket
import sys
from pathlib import Path
from typing import Any

from cotsfleet.commands.mission_args import add_mission_arguments, mission_args, write_reports
from cotsfleet.errors import UsageError
from cotsfleet.mission.faults import FaultError

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
    p.add_argument("--listen", metavar="ENDPOINT", help="router endpoint, e.g. 0.0.0.0:7447 "
                   "so agents on other machines can join, over TLS (default: a free loopback "
                   "port, plain TCP)")
    p.add_argument("--tls", action="store_true",
                   help="TLS on loopback too (off loopback, or with credentials made by "
                   "`cotsfleet credentials`, the bus is always TLS)")
    p.add_argument("--remote", action="append", default=[], metavar="ID",
                   help="a vehicle whose agent runs elsewhere: not started here, waited for "
                   "(repeatable; needs fleet_key_hex in --config and --credentials)")
    p.add_argument("--credentials", type=Path, metavar="DIR",
                   help="credentials made beforehand with `cotsfleet credentials DIR` "
                   "(default: fresh ones in the run dir)")
    p.add_argument("--startup-timeout", type=float, metavar="S",
                   help="wall seconds to wait for every agent to be ready (default: by fleet "
                   "size, 90 s up to 6 vehicles, 146 s for 12, 406 s for 24)")
    p.add_argument("--hold-viewer", action=argparse.BooleanOptionalAction,
                   help="keep the web dashboard up after the mission until Ctrl-C "
                   "(default: yes for --viewer web in an interactive terminal)")


def _interrupt(*_: Any) -> None:
    raise KeyboardInterrupt  # SIGTERM and SIGHUP end the mission like Ctrl-C: cleanly


def _check_listen(endpoint: str) -> None:
    """A busy router port is a usage error now, not a dead router later."""
    from fleet_bus.session import split_endpoint

    proto, host, port = split_endpoint(endpoint)
    if proto not in ("", "tcp", "tls") or not host or not port.isdigit():
        raise UsageError(f"--listen: expected HOST:PORT (or tls/HOST:PORT, tcp/HOST:PORT), "
                         f"got {endpoint!r}")
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET) as s:
        try:
            s.bind((host, int(port)))
        except OSError as exc:
            raise UsageError(f"--listen {endpoint}: {exc.strerror or exc}") from None


def run(args: argparse.Namespace) -> int:
    from cotsfleet.mission.processes import ProcessBackend, ProcessOptions
    from cotsfleet.mission.runner import run_mission

    viewer = args.viewer
    if viewer is None:
        from ground_station.viewer import default_viewer

        viewer = default_viewer()
    hold = args.hold_viewer
    if hold is None:
        hold = viewer == "web" and sys.stdin.isatty()
    if args.listen:
        _check_listen(args.listen)
    m = mission_args(args)
    try:
        opts = ProcessOptions(warp=args.warp, loss=args.loss, viewer=viewer, rrd=args.rrd,
                              web_port=args.web_port, run_dir=args.run_dir,
                              agent_config=m.config, hold_viewer=hold, listen=args.listen,
                              remote=tuple(args.remote), startup_timeout_s=args.startup_timeout,
                              credentials=args.credentials, tls=args.tls)
        backend = ProcessBackend(m.problem, m.scenario, m.seed, opts)
    except ValueError as exc:  # a CredentialsError too
        raise UsageError(str(exc)) from None
    for sig in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, _interrupt)
    try:
        outcome = run_mission(m.problem, backend, m.faults, seed=m.seed,
                              step_s=args.warp * 0.25, reef=m.reef)
    except FaultError as exc:
        raise UsageError(str(exc)) from None
    except (TimeoutError, RuntimeError, OSError) as exc:
        print(f"cotsfleet run: failed: {exc}", file=sys.stderr)
        return 1
    finally:
        for sig in (signal.SIGTERM, signal.SIGHUP):
            signal.signal(sig, signal.SIG_DFL)
    report = outcome.report
    path = args.report or backend.run_dir / "report.json"
    write_reports(report, path, backend.ledger.events, m.scenario)
    if report.get("failure"):
        print(f"cotsfleet run: the mission ended early: {report['failure']}", file=sys.stderr)
    for line in run_warnings(report):
        print(f"cotsfleet run: warning: {line}", file=sys.stderr)
    backend.hold_viewer()
    if report.get("interrupted"):
        return 130
    return 1 if report.get("failure") else 0


def run_warnings(report: dict) -> list[str]:
    """What an operator must not miss in a finished run: false alarms (a vehicle declared
    lost that was alive: its spots were taken, maybe twice), a clock that had to slow
    down (the machine could not keep up with the warp asked for), hosts whose wall clock
    stepped, holds that ran out, processes that died and what was done, and an event log
    a full disk cut short."""
    out = []
    false = report.get("fleet", {}).get("false_alarms", 0)
    if false:
        out.append(f"{false} false alarm(s): a vehicle was declared lost while alive "
                   f"({report['fleet'].get('duplicate_treatments', 0)} duplicate treatment(s))")
    clock = report.get("clock") or {}
    if clock.get("slowdowns"):
        slowest = min(s["warp"] for s in clock["slowdowns"])
        back = (f", back up to {clock['final_warp']:g} once every host kept up"
                if clock.get("speedups") else "")
        out.append(f"the machine could not keep up with warp {clock['warp']:g}: the clock "
                   f"slowed to {slowest:g}{back} (effective {clock['effective_warp']}); "
                   f"worst lag {clock['max_lag_s']} s")
    for step_host, steps in (clock.get("wall_steps") or {}).items():
        out.append(f"the wall clock of {step_host}'s host stepped {steps} time(s); mission "
                   "time runs on the monotonic clock and did not move")
    if clock.get("holds_expired"):
        out.append(f"planning holds ran out of their allowance: {clock['holds_expired']} "
                   f"(busy flags refused meanwhile: {clock.get('holds_refused', {})})")
    done = {"restart": "started again", "vehicle": "its vehicle was lost to the fleet",
            "report": "not started again", "end": "the mission ended"}
    for c in report.get("crashes") or ():
        out.append(f"t={c['t_s']:g} s: {c['why']} ({done.get(c['action'], c['action'])})")
    saved = report.get("saved") or {}
    if saved.get("events_error"):
        out.append(f"events.jsonl holds {saved['events']} of {saved['events_total']} events: "
                   f"{saved['events_error']}")
    if clock.get("slots_late"):
        out.append(f"{clock['slots_late']} frame(s) left a host after their TDMA slot; they "
                   "were dated at the slot and the relay placed them there")
    return out
