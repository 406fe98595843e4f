"""``python -m comms_sim``: the acoustic relay (see `comms_sim.relay`).

Embedded by default: without ``--connect`` it is itself the Zenoh router, listening on
``--listen`` (default tcp/127.0.0.1:7447). Clock: ``--epoch-unix``/``--warp``, or
``--mission-from-bus`` to take the seed and roster from the operator's ``fleet/mission``
record and the clock from ``fleet/clock``; with neither, simulation time starts now at
warp 1.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

from comms_sim.config import PRESETS, load_config
from comms_sim.relay import main
from fleet_bus.credentials import RELAY_ID, CredentialsError, load_auth
from fleet_bus.process import process_stop
from fleet_bus.session import DEFAULT_ENDPOINT, client_config, router_config

if __name__ == "__main__":
    parser = argparse.ArgumentParser(prog="python -m comms_sim", description=__doc__)
    net = parser.add_mutually_exclusive_group()
    net.add_argument("--connect", action="append", metavar="ENDPOINT",
                     help="router to connect to (repeatable)")
    net.add_argument("--listen", action="append", metavar="ENDPOINT",
                     help=f"be the router, listening here (default {DEFAULT_ENDPOINT})")
    clock = parser.add_mutually_exclusive_group()
    clock.add_argument("--epoch-unix", type=float, help="wall time of simulation t=0")
    clock.add_argument("--mission-from-bus", action="store_true",
                       help="read epoch, warp, seed and roster from fleet/mission")
    parser.add_argument("--warp", type=float, default=1.0, help="simulated s per wall s")
    parser.add_argument("--seed", type=int, help="channel seed (default: mission's, else 0)")
    parser.add_argument("--config", help="channel settings file (.toml or .json)")
    parser.add_argument("--preset", choices=sorted(PRESETS), help="named modem (no --config)")
    parser.add_argument("--loss", type=float, help="extra uniform loss 0..1 (overrides)")
    parser.add_argument("--vehicles", help="comma-separated roster; others are dropped")
    parser.add_argument("--tdma", action="store_true",
                        help="one slot per roster vehicle (needs --vehicles or the mission)")
    parser.add_argument("--mission-timeout", type=float, default=30.0, metavar="S")
    parser.add_argument("--credentials", type=Path, metavar="DIR",
                        help="the relay's credentials directory (signing key, key ring, Zenoh "
                             "login); without it the bus is open: experiments only")
    args = parser.parse_args()
    try:
        auth = load_auth(args.credentials, RELAY_ID) if args.credentials else None
    except CredentialsError as exc:
        print(f"comms_sim: {exc}", file=sys.stderr)
        raise SystemExit(2)

    config = load_config(args.config) if args.config else PRESETS[args.preset or "psk_1k"]
    if args.loss is not None:
        config = replace(config, extra_loss=args.loss)
    conf = (client_config(args.connect, credentials=args.credentials) if args.connect
            else router_config(args.listen or [DEFAULT_ENDPOINT]))
    epoch = None if args.mission_from_bus else (
        args.epoch_unix if args.epoch_unix is not None else time.time())
    vehicles = tuple(v for v in args.vehicles.split(",") if v) if args.vehicles else None
    relay = main(conf, config, process_stop(), epoch_unix=epoch,
                 warp=None if args.mission_from_bus else args.warp, seed=args.seed,
                 vehicles=vehicles, mission_timeout_s=args.mission_timeout, tdma=args.tdma,
                 auth=auth)
    raise SystemExit(0 if relay is not None or not args.mission_from_bus else 3)
