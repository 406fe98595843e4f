"""`cotsfleet water`: the emulated water alone, with a modem face other stacks' drivers use.

``--face micromodem`` serves one emulated WHOI Micro-Modem per scenario vehicle on TCP:
vehicle i (0-based, scenario order) on port P + i with modem address i + 1, placed at its
start until the fleet's truths (``--connect``) or its host (``$PCFLP``) move it, all at one
rate (``--rate``), on the mission clock (``--warp``; on a bus, the operator's). See
docs/modems.md.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from cotsfleet.errors import UsageError

HELP = "the emulated water with a Micro-Modem NMEA face on TCP (one modem per vehicle)"
FACES = ("micromodem",)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scenario", type=Path, required=True, help="scenario JSON or TOP file")
    p.add_argument("--face", choices=FACES, default="micromodem",
                   help="how hosts reach the water (default micromodem)")
    p.add_argument("--port", type=int, required=True, metavar="P",
                   help="vehicle i's modem listens on P + i")
    p.add_argument("--host", default="127.0.0.1", help="address to listen on")
    p.add_argument("--warp", type=float, default=1.0, help="mission seconds per wall second")
    p.add_argument("--seed", type=int, default=0, help="mission seed (the channel's stream)")
    p.add_argument("--rate", type=int, default=1, metavar="R",
                   help="Micro-Modem rate every modem runs (emulated: 0, 1, 5; default 1)")
    p.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                   help="a mission's Zenoh router: take truths and the clock, publish link "
                        "events and stats (repeatable)")
    p.add_argument("--credentials", type=Path, metavar="DIR",
                   help="the relay's credentials directory on an authenticated bus")
    p.add_argument("--heartbeat", type=float, default=60.0, metavar="S",
                   help="mission seconds between $CAREV of an idle modem (0: never)")


def run(args: argparse.Namespace) -> int:
    from comms_sim.micromodem.packet import emulated_rates
    from comms_sim.micromodem.run import run_water
    from cotsfleet.io import read_scenario
    from fleet_bus.process import process_stop

    if not (math.isfinite(args.warp) and args.warp > 0):
        raise UsageError(f"--warp must be a positive number, got {args.warp}")
    if args.rate not in emulated_rates():
        raise UsageError(f"--rate {args.rate} is not emulated; choose from "
                         f"{', '.join(map(str, emulated_rates()))}")
    if not (math.isfinite(args.heartbeat) and args.heartbeat >= 0):
        raise UsageError(f"--heartbeat must be >= 0, got {args.heartbeat}")
    if args.credentials is not None and not args.connect:
        raise UsageError("--credentials goes with --connect")
    problem, _ = read_scenario(args.scenario)
    vehicles = [(v.id, (float(v.start[0]), float(v.start[1]), float(v.start[2])))
                for v in problem.vehicles]
    if not (1 <= args.port and args.port + len(vehicles) - 1 <= 65535):
        raise UsageError(f"--port {args.port}: ports {args.port}-"
                         f"{args.port + len(vehicles) - 1} must lie in 1-65535")
    stop = process_stop()
    try:
        run_water(vehicles, args.host, args.port, args.rate, args.warp, args.seed, stop,
                  connect=args.connect, credentials=args.credentials,
                  heartbeat_s=args.heartbeat)
    except OSError as exc:
        raise UsageError(f"cannot serve the modems on {args.host}:{args.port}..: {exc}"
                         ) from None
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    return 0
