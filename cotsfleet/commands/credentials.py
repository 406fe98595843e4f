"""`cotsfleet credentials DIR`: a mission's credentials made beforehand, for hosts elsewhere.

`cotsfleet run` makes fresh credentials for each run by itself; a vehicle whose agent runs on
another host (``--remote``) needs its own before the mission starts. This writes them all,
for a TLS bus (`fleet_bus.credentials`): the key ring, a signing key per vehicle, the
operator's, the relay's and a remote ground station's (``ground``: `cotsfleet ctl --connect`,
order requests only), the mission's CA certificate and one TLS key and certificate per
process (no password anywhere), including a router for each vehicle's own host, and says
what to copy where. Make new ones for every mission: signatures bind its run id, and the
CA's key is gone once they are made.

It also writes the mission file an agent on board loads before the dive (`cotsfleet agent
--mission`, `fleet_agent.mission_file`: the scenario, the seed, the run id of these
credentials and, with ``--start``, mission time 0), in DIR and in each vehicle's directory.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from cotsfleet.commands.checks import output_dir
from cotsfleet.commands.mission_args import scenario_doc
from cotsfleet.errors import UsageError
from fleet_bus.credentials import (
    DEFAULT_VALID_DAYS,
    GROUND_ID,
    ROUTER_ID,
    CredentialsError,
    linked_router_id,
    write_run_credentials,
)

HELP = "make a mission's credentials beforehand (for --remote agents on other hosts)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("dir", type=Path, help="directory to create (must not exist)")
    p.add_argument("--scenario", type=Path, help="the mission's scenario (its vehicle ids)")
    p.add_argument("--vehicles", type=int, help="fleet size of the default scenario")
    p.add_argument("--seed", type=int, default=0, help="seed of the default scenario")
    p.add_argument("--hosts", nargs="+", default=[], metavar="HOST",
                   help="names or addresses other hosts reach this host's router at (its "
                   "certificate names them, and loopback)")
    p.add_argument("--valid-days", type=float, default=DEFAULT_VALID_DAYS, metavar="DAYS",
                   help=f"lifetime of the certificates (default {DEFAULT_VALID_DAYS:g})")
    p.add_argument("--start", metavar="WHEN",
                   help="mission time 0 for agents on board (unix seconds or ISO 8601 UTC), "
                   "written in the mission file (else given to `cotsfleet agent --start`)")


def run(args: argparse.Namespace) -> int:
    from fleet_agent.mission_file import write_mission_file
    from fleet_agent.options import parse_start
    from fleet_bus.mission import Mission

    if args.dir.exists():
        raise UsageError(f"{args.dir} exists; credentials are made fresh for each mission")
    output_dir(args.dir, "DIR")
    try:
        start = parse_start(args.start)
    except ValueError as exc:
        raise UsageError(f"--start: {exc}") from None
    doc = scenario_doc(args.scenario, args.vehicles, args.seed)
    ids = [str(v["id"]) for v in doc.get("vehicles", []) if isinstance(v, dict)]
    try:
        run_id = write_run_credentials(args.dir, ids, tls=True, hosts=args.hosts,
                                       linked_routers=ids, valid_days=args.valid_days)
    except CredentialsError as exc:
        raise UsageError(str(exc)) from None
    d = args.dir
    mission = Mission(doc, args.seed, run_id)
    for where in (d, *(d / vid for vid in ids)):
        write_mission_file(where / "mission.json", mission, start)
    names = ", ".join(["loopback", *args.hosts])
    print(f"credentials of run {run_id} in {d} (TLS; valid {args.valid_days:g} days):")
    print(f"  this host:   cotsfleet run --credentials {d} --listen 0.0.0.0:7447 --remote ID ..."
          f" (its router's certificate is for {names})")
    for vid in ids:
        print(f"  vehicle {vid}: copy {d / vid} and {d / linked_router_id(vid)} to its host; "
              f"there, python -m comms_sim.router --credentials {linked_router_id(vid)} "
              f"--listen tls/127.0.0.1:7447 --connect tls/HOST:7447 and python -m fleet_agent "
              f"--id {vid} --credentials {vid} --connect tls/127.0.0.1:7447 ...")
    print(f"  ground station: copy {d / GROUND_ID} to its host; there, cotsfleet ctl --connect "
          f"tls/HOST:7447 --credentials {GROUND_ID} ORDER (order requests only)")
    print(f"  on board: cotsfleet agent --id ID --mission {d}/ID/mission.json --credentials "
          f"{d}/ID --config AGENT.toml --helm moos|ros2 --modem micromodem:/dev/ttyUSB0"
          + ("" if start is not None else " --start WHEN"))
    if not args.hosts:
        print(f"  (no --hosts: a router elsewhere cannot dial {d / ROUTER_ID}'s router by "
              "name or address; name this host with --hosts)")
    return 0
