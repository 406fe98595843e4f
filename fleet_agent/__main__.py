"""``python -m fleet_agent --id auv2 --scenario S.json [--config C.toml]``: one AUV's agent.

Connects to the Zenoh router (``--connect``), computes the shared initial plan, waits for the
launcher's ``fleet/mission`` record (epoch, warp), then runs until SIGTERM/SIGINT. The fleet
key comes from the config file (``fleet_key_hex``) or the environment (COTSFLEET_FLEET_KEY,
hex); it never travels on the bus.
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import replace
from pathlib import Path

from comms_sim.router import stop_on_signals
from comms_sim.session import DEFAULT_ENDPOINT, client_config
from fleet_agent.config import AgentConfig, load_config
from fleet_agent.node import main

if __name__ == "__main__":
    parser = argparse.ArgumentParser(prog="python -m fleet_agent", description=__doc__)
    parser.add_argument("--id", required=True, help="vehicle id (from the scenario)")
    parser.add_argument("--scenario", required=True, type=Path, help="scenario JSON")
    parser.add_argument("--config", type=Path, help="agent settings (TOML)")
    parser.add_argument("--connect", action="append", metavar="ENDPOINT",
                        help=f"Zenoh router (repeatable; default {DEFAULT_ENDPOINT})")
    parser.add_argument("--journal", type=Path, help="journal file (default ./<id>.journal)")
    parser.add_argument("--seed", type=int,
                        help="mission seed (default: from fleet/mission); plans before the "
                             "mission record is served")
    parser.add_argument("--mission-timeout", type=float, default=120.0, metavar="S")
    args = parser.parse_args()
    try:
        config = load_config(args.config) if args.config else AgentConfig()
        env_key = os.environ.get("COTSFLEET_FLEET_KEY", "")
        if not config.fleet_key_hex and env_key:
            config = replace(config, fleet_key_hex=env_key)
        config.fleet_key  # noqa: B018 - fail early without a key
    except (OSError, ValueError) as exc:
        print(f"fleet_agent: {exc}", file=sys.stderr)
        raise SystemExit(2)
    raise SystemExit(main(client_config(args.connect or [DEFAULT_ENDPOINT]), args.id,
                          args.scenario, config, args.journal or Path(f"{args.id}.journal"),
                          stop_on_signals(), args.seed, args.mission_timeout))
