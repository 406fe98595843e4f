"""The agent's command line, shared by ``python -m fleet_agent`` and ``cotsfleet agent``.

Two ways to run: on a mission bus (``--connect``: the operator serves the mission and the
clock, `fleet_agent.node`), or on board (``--mission FILE``: the mission loaded before the
dive, the vehicle's own clock, `fleet_agent.onboard`). Either way: the vehicle's helm
(``--helm`` and its options, `fleet_agent.helms.choice`), its modem (``--modem``), the
journal, the agent config, the credentials.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import sys
from dataclasses import replace
from pathlib import Path

from fleet_agent.config import AgentConfig, load_config
from fleet_agent.helms.choice import HELMS, HelmChoice
from fleet_agent.modems.choice import ModemChoice


def add_arguments(p: argparse.ArgumentParser, on_board: bool = False) -> None:
    """The agent's options; ``on_board`` makes ``--mission`` required (`cotsfleet agent`)."""
    p.add_argument("--id", required=True, help="vehicle id (from the mission's scenario)")
    p.add_argument("--config", type=Path, help="agent settings (TOML)")
    p.add_argument("--connect", action="append", metavar="ENDPOINT",
                   help="Zenoh router (repeatable). On a mission bus: the operator's (default "
                        "tcp/127.0.0.1:7447); on board: the vehicle's own, for telemetry only")
    p.add_argument("--journal", type=Path, help="journal file (default ./<id>.journal)")
    p.add_argument("--mission", type=Path, required=on_board, metavar="FILE",
                   help="on board: the mission file (scenario, seed, run id, start) loaded "
                        "before the dive; no operator, the vehicle's own clock at warp 1")
    p.add_argument("--start", metavar="WHEN",
                   help="on board: mission time 0 (unix seconds or ISO 8601 UTC), if the "
                        "mission file does not say")
    p.add_argument("--mission-timeout", type=float, default=120.0, metavar="S",
                   help="on a mission bus: wall seconds to wait for the mission and clock")
    p.add_argument("--modem", default="water", metavar="M",
                   help="water (the emulated water over Zenoh, default on a bus) or "
                        "micromodem:LINK (a WHOI Micro-Modem on a serial device or "
                        "tcp:HOST:PORT; docs/modems.md)")
    p.add_argument("--modem-rate", type=int, default=1, metavar="R",
                   help="the Micro-Modem's packet rate (default 1: 3 frames of 64 bytes)")
    p.add_argument("--credentials", type=Path, metavar="DIR",
                   help="this vehicle's credentials directory (its own signing key, the "
                        "run's key ring, its Zenoh identity; docs/security.md); without it "
                        "the bus is open: experiments only")
    h = p.add_argument_group("the vehicle's helm (docs/onboard.md)")
    h.add_argument("--helm", choices=HELMS, default="sim",
                   help="sim (the simulated vehicle, default), moos (a MOOS-IvP vehicle's "
                        "MOOSDB) or ros2 (a ROS 2 vehicle; needs the ros2 extra)")
    h.add_argument("--moos-host", default="localhost", help="the vehicle's MOOSDB host")
    h.add_argument("--moos-port", type=int, default=9000, help="the vehicle's MOOSDB port")
    h.add_argument("--moos-warp", type=float, metavar="W",
                   help="the community's MOOSTimeWarp (default: the mission clock's warp)")
    h.add_argument("--ros-namespace", default="", metavar="NS",
                   help="the ROS 2 vehicle's namespace (default /<id>)")
    h.add_argument("--emulation", action="store_true",
                   help="the helm drives a simulator: publish its true pose on fleet/truth "
                        "and look with the scenario's hidden reef (the mission launcher)")
    h.add_argument("--helm-timeout", type=float, default=30.0, metavar="S",
                   help="wall seconds for a live helm's first fix (default 30)")


def parse_start(text: str | None) -> float | None:
    """``--start``: unix seconds or an ISO 8601 time (UTC unless it says); ValueError."""
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        pass
    when = dt.datetime.fromisoformat(text)
    if when.tzinfo is None:
        when = when.replace(tzinfo=dt.timezone.utc)
    return when.timestamp()


def agent_config(path: Path | None) -> AgentConfig:
    """The config file (or the defaults), with the fleet key from COTSFLEET_FLEET_KEY if the
    file has none; ValueError without a key."""
    config = load_config(path) if path else AgentConfig()
    env_key = os.environ.get("COTSFLEET_FLEET_KEY", "")
    if not config.fleet_key_hex and env_key:
        config = replace(config, fleet_key_hex=env_key)
    config.fleet_key  # fail early without a key
    return config


def helm_choice(args: argparse.Namespace) -> HelmChoice:
    return HelmChoice(args.helm, args.moos_host, args.moos_port, args.moos_warp,
                      args.ros_namespace, emulated=args.emulation or args.helm == "sim",
                      ready_timeout_s=args.helm_timeout)


def run(args: argparse.Namespace) -> int:
    """Run the agent the arguments describe (exit code: 2 for bad arguments, said in one
    line on stderr)."""
    from fleet_bus.credentials import load_auth
    from fleet_bus.process import process_stop
    from fleet_bus.session import DEFAULT_ENDPOINT, client_config

    try:
        auth = load_auth(args.credentials, args.id) if args.credentials else None
        config = agent_config(args.config)
        modem = ModemChoice.parse(args.modem, args.modem_rate)
        helm = helm_choice(args)
        start = parse_start(args.start)
    except (OSError, ValueError) as exc:  # CredentialsError is a ValueError
        print(f"fleet_agent: {exc}", file=sys.stderr)
        return 2
    journal = args.journal or Path(f"{args.id}.journal")
    stop = process_stop()
    if args.mission is not None:
        from fleet_agent import onboard

        conf = client_config(args.connect, credentials=args.credentials) \
            if args.connect else None
        return onboard.main(args.id, config, journal, stop, args.mission, start_unix=start,
                            modem=modem, helm=helm, conf=conf, auth=auth,
                            credentials=args.credentials)
    from fleet_agent import node

    return node.main(client_config(args.connect or [DEFAULT_ENDPOINT],
                                   credentials=args.credentials), args.id, config, journal,
                     stop, args.mission_timeout, auth, modem, args.credentials, helm)
