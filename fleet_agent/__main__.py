"""``python -m fleet_agent --id auv2 [--config C.toml] [--connect ENDPOINT] [--helm H]
[--modem M] [--mission FILE]``: one AUV's agent.

On a mission bus (the default): connects to the Zenoh router (``--connect``), reads the
mission (scenario, seed) from the operator's ``fleet/mission`` record, computes the shared
initial plan, waits for the mission clock (``fleet/clock``), then runs until SIGTERM, SIGINT
or SIGHUP, or a ``stop`` command. On board (``--mission FILE``): the mission from the file,
the vehicle's own clock, its modem (docs/onboard.md). The vehicle is the simulated one or a
live helm (``--helm sim|moos|ros2``). The fleet key comes from the config file
(``fleet_key_hex``) or the environment (COTSFLEET_FLEET_KEY, hex); it never travels on the bus.
"""

from __future__ import annotations

import argparse

from fleet_agent.options import add_arguments, run

if __name__ == "__main__":
    parser = argparse.ArgumentParser(prog="python -m fleet_agent", description=__doc__)
    add_arguments(parser)
    raise SystemExit(run(parser.parse_args()))
