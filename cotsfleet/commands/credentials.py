"""`cotsfleet credentials DIR`: a mission's credentials made beforehand, for agents elsewhere.

`cotsfleet run` makes fresh credentials for each run by itself; a vehicle whose agent runs on
another host (``--remote``) needs its own before the mission starts. This writes them all
(`fleet_bus.credentials`: key ring, one signing key per vehicle, the operator's and the
relay's, a Zenoh login per process, the router's login dictionary) and says what to copy
where. Make new ones for every mission: signatures bind its run id.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from cotsfleet.commands.mission_args import scenario_doc
from cotsfleet.errors import UsageError
from fleet_bus.credentials import CredentialsError, write_run_credentials

HELP = "make a mission's credentials beforehand (for --remote agents on other hosts)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("dir", type=Path, help="directory to create (must not exist)")
    p.add_argument("--scenario", type=Path, help="the mission's scenario (its vehicle ids)")
    p.add_argument("--vehicles", type=int, help="fleet size of the default scenario")
    p.add_argument("--seed", type=int, default=0, help="seed of the default scenario")


def run(args: argparse.Namespace) -> int:
    if args.dir.exists():
        raise UsageError(f"{args.dir} exists; credentials are made fresh for each mission")
    doc = scenario_doc(args.scenario, args.vehicles, args.seed)
    ids = [str(v["id"]) for v in doc.get("vehicles", []) if isinstance(v, dict)]
    try:
        run_id = write_run_credentials(args.dir, ids)
    except CredentialsError as exc:
        raise UsageError(str(exc)) from None
    print(f"credentials of run {run_id} in {args.dir}:")
    print(f"  this host:   cotsfleet run --credentials {args.dir} --remote ID ...")
    for vid in ids:
        print(f"  vehicle {vid}: copy {args.dir / vid} to its host; python -m fleet_agent "
              f"--id {vid} --credentials DIR ...")
    print(f"  a linked router on another host: copy {args.dir / 'router'}; python -m "
          f"comms_sim.router --credentials DIR --connect ...")
    return 0
