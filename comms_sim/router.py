"""The embedded Zenoh router: a Python session in router mode, so no zenohd is needed.

``python -m comms_sim.router --listen tcp/127.0.0.1:7447`` prints one ready line and routes
until SIGTERM, SIGINT or SIGHUP. ``--connect tcp/otherhost:7447`` links it to another router,
which is how a mission spans machines: one router per host, linked, each host's processes on
its own.
"""

from __future__ import annotations

import argparse
import threading
from typing import Sequence

from fleet_bus.process import ROUTER_READY, process_stop, ready
from fleet_bus.session import DEFAULT_ENDPOINT, open_session, router_config

READY = ROUTER_READY


def main(listen: Sequence[str], stop: threading.Event, connect: Sequence[str] = ()) -> None:
    with open_session(router_config(listen, connect)):
        ready(READY, " ".join(listen))
        while not stop.wait(1.0):  # a bounded wait keeps signal handling prompt
            pass


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--listen", action="append", metavar="ENDPOINT",
                        help=f"endpoint to listen on (repeatable; default {DEFAULT_ENDPOINT})")
    parser.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                        help="another router to link to (repeatable)")
    args = parser.parse_args()
    main(args.listen or [DEFAULT_ENDPOINT], process_stop(), args.connect)
