"""``python -m fleet_agent --id auv2 [--config C.toml] [--connect ENDPOINT] [--modem M]``: one
AUV's agent.

Connects to the Zenoh router (``--connect``), reads the mission (scenario, seed) from the
operator's ``fleet/mission`` record, computes the shared initial plan, waits for the mission
clock (``fleet/clock``), then runs until SIGTERM, SIGINT or SIGHUP, or a ``stop`` command.
The fleet key comes from the config file (``fleet_key_hex``) or the environment
(COTSFLEET_FLEET_KEY, hex); it never travels on the bus.
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import replace
from pathlib import Path

from fleet_agent.config import AgentConfig, load_config
from fleet_agent.node import ModemChoice, main
from fleet_bus.credentials import load_auth
from fleet_bus.process import process_stop
from fleet_bus.session import DEFAULT_ENDPOINT, client_config

if __name__ == "__main__":
    parser = argparse.ArgumentParser(prog="python -m fleet_agent", description=__doc__)
    parser.add_argument("--id", required=True, help="vehicle id (from the mission's scenario)")
    parser.add_argument("--config", type=Path, help="agent settings (TOML)")
    parser.add_argument("--connect", action="append", metavar="ENDPOINT",
                        help=f"Zenoh router (repeatable; default {DEFAULT_ENDPOINT})")
    parser.add_argument("--journal", type=Path, help="journal file (default ./<id>.journal)")
    parser.add_argument("--mission-timeout", type=float, default=120.0, metavar="S")
    parser.add_argument("--modem", default="water", metavar="M",
                        help="water (the emulated water over Zenoh, default) or "
                             "micromodem:LINK (a WHOI Micro-Modem on a serial device or "
                             "tcp:HOST:PORT; docs/modems.md)")
    parser.add_argument("--modem-rate", type=int, default=1, metavar="R",
                        help="the Micro-Modem's packet rate (default 1: 3 frames of 64 bytes)")
    parser.add_argument("--credentials", type=Path, metavar="DIR",
                        help="this vehicle's credentials directory (its own signing key, the "
                             "run's key ring, its Zenoh login; docs/security.md); without it "
                             "the bus is open: experiments only")
    args = parser.parse_args()
    try:
        auth = load_auth(args.credentials, args.id) if args.credentials else None
        config = load_config(args.config) if args.config else AgentConfig()
        env_key = os.environ.get("COTSFLEET_FLEET_KEY", "")
        if not config.fleet_key_hex and env_key:
            config = replace(config, fleet_key_hex=env_key)
        config.fleet_key  # noqa: B018 - fail early without a key
        modem = ModemChoice.parse(args.modem, args.modem_rate)
    except (OSError, ValueError) as exc:  # CredentialsError is a ValueError
        print(f"fleet_agent: {exc}", file=sys.stderr)
        raise SystemExit(2)
    raise SystemExit(main(client_config(args.connect or [DEFAULT_ENDPOINT],
                                        credentials=args.credentials), args.id, config,
                          args.journal or Path(f"{args.id}.journal"), process_stop(),
                          args.mission_timeout, auth, modem, args.credentials))
