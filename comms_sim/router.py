"""The embedded Zenoh router: a Python session in router mode, so no zenohd is needed.

``python -m comms_sim.router --listen tcp/127.0.0.1:7447`` prints one ready line and routes
until SIGTERM, SIGINT or SIGHUP. ``--connect tcp/otherhost:7447`` links it to another router,
which is how a mission spans machines: one router per host, linked, each host's processes on
its own. ``--credentials DIR`` (a router's credentials directory, `fleet_bus.credentials`)
turns on authentication and the fleet's access control: only the run's processes connect,
each with its own rights (`fleet_bus.session.access_control`). With TLS credentials every
link is mutual TLS (``tls/`` endpoints, listening and linking alike) and each process is
known by its certificate; with plain ones, by its login, on loopback only. Without
credentials the router is open: experiments only.
"""

from __future__ import annotations

import argparse
import sys
import threading
from pathlib import Path
from typing import Sequence

from fleet_bus.credentials import CredentialsError, uses_tls
from fleet_bus.process import ROUTER_READY, process_stop, ready
from fleet_bus.session import DEFAULT_ENDPOINT, open_session, router_config

READY = ROUTER_READY


def main(listen: Sequence[str], stop: threading.Event, connect: Sequence[str] = (),
         credentials: Path | None = None) -> None:
    with open_session(router_config(listen, connect, credentials)):
        how = ("open" if credentials is None else "TLS, by certificate" if uses_tls(credentials)
               else "by login")
        ready(READY, f"{' '.join(listen)} ({how})")
        while not stop.wait(1.0):  # a bounded wait keeps signal handling prompt
            pass


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--listen", action="append", metavar="ENDPOINT",
                        help=f"endpoint to listen on (repeatable; default {DEFAULT_ENDPOINT})")
    parser.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                        help="another router to link to (repeatable)")
    parser.add_argument("--credentials", type=Path, metavar="DIR",
                        help="the router's credentials directory: identities and access control")
    args = parser.parse_args()
    try:
        main(args.listen or [DEFAULT_ENDPOINT], process_stop(), args.connect, args.credentials)
    except CredentialsError as exc:
        print(f"comms_sim router: {exc}", file=sys.stderr)
        raise SystemExit(2)
