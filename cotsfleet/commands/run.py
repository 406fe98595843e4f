"""`cotsfleet run`: an emulated mission, one OS process per vehicle, over Zenoh."""

from __future__ import annotations

import argparse
import signal
import socket
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cotsfleet.commands.checks import json_output, output_dir, output_file
from cotsfleet.commands.mission_args import (add_mission_arguments, config_sets, mission_args,
                                             write_reports)
from cotsfleet.errors import UsageError
from cotsfleet.mission.faults import FaultError
from cotsfleet.mission.report_model import Clock, MissionReport

if TYPE_CHECKING:
    from fleet_agent.config import AgentConfig
    from hfc_core.model.problem import Problem

HELP = "run an emulated mission: router, link emulator, one agent process per AUV, dashboard"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_mission_arguments(p, "the paper preset drawn with --seed")
    p.add_argument("--warp", type=float, default=60.0, help="simulated seconds per wall second")
    p.add_argument("--viewer", choices=("web", "native", "none"),
                   help="Rerun viewer (default: native with a display, else web; native "
                   "without a display falls back to web, saying so)")
    p.add_argument("--rrd", type=Path, help="also record the mission to this .rrd file")
    p.add_argument("--web-port", type=int, default=9090, help="web viewer port")
    p.add_argument("--report", type=Path, help="mission report JSON, R.json: R.md and R-*.png "
                   "beside it (default: report.json in the run dir)")
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
    p.add_argument("--helm", choices=("sim", "moos", "ros2"), default="sim",
                   help="what each agent drives: the simulated vehicle (sim, default), a "
                   "MOOS-IvP community per vehicle (moos: MOOSDB, uSimMarineV22, pMarinePIDV22, "
                   "pHelmIvP from PATH) or the simulated vehicle as a ROS 2 node (ros2: needs "
                   "the ros2 extra); docs/onboard.md")
    p.add_argument("--modem", choices=("water", "micromodem"), default="water",
                   help="the water: the Zenoh relay (water, default) or emulated WHOI "
                   "Micro-Modems that each agent drives over NMEA (micromodem; docs/modems.md)")
    p.add_argument("--modem-rate", type=int, default=1, metavar="R",
                   help="--modem micromodem: the rate every modem runs (0, 1, 5; default 1)")
    p.add_argument("--hold-viewer", action=argparse.BooleanOptionalAction,
                   help="keep the web dashboard up after the mission until Ctrl-C "
                   "(default: yes for the web viewer when stdin is a terminal; a native "
                   "viewer is a window of its own and stays until closed)")


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
    from ground_station.viewer import resolve_viewer

    output_file(args.rrd, "--rrd")
    json_output(args.report, "--report")
    output_dir(args.run_dir, "--run-dir")
    viewer, note = resolve_viewer(args.viewer)
    if note:
        print(f"cotsfleet run: {note}", file=sys.stderr)
    hold = args.hold_viewer
    if hold is None:
        hold = viewer == "web" and sys.stdin.isatty()
    if args.listen:
        _check_listen(args.listen)
    m = mission_args(args)
    config, derived = m.config, False
    try:
        from cotsfleet.mission.modem_launch import ModemLaunch

        ModemLaunch(args.modem, args.modem_rate)  # an emulated rate, or said now
        if args.modem == "micromodem" and not config_sets(args.config, "slot_s"):
            config, derived = modem_slot(config, args.modem_rate, m.problem), True
        opts = ProcessOptions(warp=args.warp, loss=args.loss, viewer=viewer, rrd=args.rrd,
                              web_port=args.web_port, run_dir=args.run_dir,
                              agent_config=config, hold_viewer=hold, listen=args.listen,
                              remote=tuple(args.remote), startup_timeout_s=args.startup_timeout,
                              credentials=args.credentials, tls=args.tls, helm=args.helm,
                              modem=args.modem, modem_rate=args.modem_rate,
                              slot_from_modem=derived)
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
    if report.failure:
        print(f"cotsfleet run: the mission ended early: {report.failure}", file=sys.stderr)
    for line in run_warnings(report):
        print(f"cotsfleet run: warning: {line}", file=sys.stderr)
    backend.hold_viewer()
    if report.interrupted:
        return 130
    return 1 if report.failure else 0


def _number(value: object) -> float | None:
    """A clock figure, or None where the report has none (absent, or null)."""
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) \
        else None


def modem_slot(config: "AgentConfig", rate: int, problem: "Problem") -> "AgentConfig":
    """``config`` with the TDMA slot a Micro-Modem packet at ``rate`` needs across the
    scenario (`cotsfleet.mission.modem_launch.micromodem_slot_s`), said on the terminal."""
    from dataclasses import replace

    from cotsfleet.mission.modem_launch import micromodem_slot_s
    from fleet_agent.modems.micromodem import micromodem_spec

    spec = micromodem_spec(rate)
    slot = micromodem_slot_s(spec, problem)
    print(f"cotsfleet run: --modem micromodem rate {rate} ({spec.frames_per_packet} x "
          f"{spec.max_frame_bytes} B at {spec.bit_rate_bps:g} bps): TDMA slot {slot:g} s "
          f"(set slot_s in --config to choose another)")
    return replace(config, slot_s=slot)


def run_warnings(report: MissionReport) -> list[str]:
    """What an operator must not miss in a finished run: false alarms (a vehicle declared
    lost that was alive: its spots were taken, maybe twice), a clock that had to slow
    down (the machine could not keep up with the warp asked for), hosts whose wall clock
    stepped, holds that ran out, processes that died and what was done, and an event log
    a full disk cut short."""
    out = []
    false = report.fleet.false_alarms
    if false:
        out.append(f"{false} false alarm(s): a vehicle was declared lost while alive "
                   f"({report.collected.duplicates} duplicate treatment(s))")
    clock = report.clock
    if clock is not None:
        out += _clock_warnings(clock)
    done = {"restart": "started again", "vehicle": "its vehicle was lost to the fleet",
            "report": "not started again", "end": "the mission ended"}
    for c in report.crashes or ():
        out.append(f"t={c.t_s:g} s: {c.why} ({done.get(c.action, c.action)})")
    saved = report.saved
    if saved is not None and isinstance(saved.events_error, str):
        out.append(f"events.jsonl holds {saved.events} of {saved.events_total} events: "
                   f"{saved.events_error}")
    if clock is not None and isinstance(clock.slots_late, int) and clock.slots_late:
        out.append(f"{clock.slots_late} frame(s) left a host after their TDMA slot; they "
                   "were dated at the slot and the relay placed them there")
    return out


def _clock_warnings(clock: Clock) -> list[str]:
    out = []
    if isinstance(clock.slowdowns, list) and clock.slowdowns:
        slowest = min(s.warp for s in clock.slowdowns)
        final = _number(clock.final_warp)
        back = (f", back up to {final:g} once every host kept up"
                if isinstance(clock.speedups, list) and clock.speedups and final is not None
                else "")
        out.append(f"the machine could not keep up with warp {clock.warp:g}: the clock "
                   f"slowed to {slowest:g}{back} (effective {_number(clock.effective_warp)}); "
                   f"worst lag {_number(clock.max_lag_s)} s")
    for step_host, steps in (clock.wall_steps if isinstance(clock.wall_steps, dict)
                             else {}).items():
        out.append(f"the wall clock of {step_host}'s host stepped {steps} time(s); mission "
                   "time runs on the monotonic clock and did not move")
    if isinstance(clock.holds_expired, dict) and clock.holds_expired:
        refused = clock.holds_refused if isinstance(clock.holds_refused, dict) else {}
        out.append(f"planning holds ran out of their allowance: {clock.holds_expired} "
                   f"(busy flags refused meanwhile: {refused})")
    return out
