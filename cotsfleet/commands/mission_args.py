"""Options shared by `cotsfleet run` and `cotsfleet sim`: the same mission, the same faults,
whether the fleet runs as processes or in one process."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_mission_arguments(p: argparse.ArgumentParser, scenario_default: str) -> None:
    p.add_argument("--scenario", type=Path,
                   help=f"scenario JSON or TOP file (default: {scenario_default})")
    p.add_argument("--vehicles", type=int, help="fleet size of the default scenario")
    p.add_argument("--seed", type=int, default=0, help="mission seed (plans, channel)")
    p.add_argument("--loss", type=float, default=0.0, help="extra uniform link loss 0..1")
    p.add_argument("--abort", action="append", default=[], metavar="ID@S",
                   help="vehicle announces an abort at sim time S (repeatable)")
    p.add_argument("--kill", action="append", default=[], metavar="ID@S",
                   help="the vehicle's agent dies silently at sim time S (repeatable)")
    p.add_argument("--restart", action="append", default=[], metavar="ID@S",
                   help="start a killed agent again from its journal at S (repeatable)")
    p.add_argument("--config", type=Path, help="agent settings TOML (fleet_agent.config)")
