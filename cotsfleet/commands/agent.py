"""`cotsfleet agent`: one vehicle's agent on board, against its live helm, in real time.

The mission (scenario, seed, run id, start) is loaded before the dive from a mission file
(`fleet_agent.mission_file`: `cotsfleet run` writes one in its run directory, `cotsfleet
credentials DIR --scenario S --start WHEN` one per vehicle), the fleet key from the agent
config, the credentials from their directory; there is no operator on the bus, the clock is
the vehicle's own real time (warp 1, `fleet_agent.onboard`), the peers are reached through
the vehicle's modem, and the agent journals as in every mission. docs/onboard.md.
"""

from __future__ import annotations

import argparse

HELP = "one vehicle's agent on board: its mission from a file, its helm, its modem"


def add_arguments(p: argparse.ArgumentParser) -> None:
    from fleet_agent.options import add_arguments as agent_arguments

    agent_arguments(p, on_board=True)


def run(args: argparse.Namespace) -> int:
    from fleet_agent.options import run as run_agent

    return run_agent(args)
