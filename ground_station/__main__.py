"""``python -m ground_station``: watch the fleet over Zenoh and show it in Rerun.

Started by ``cotsfleet run`` (or by hand, late, or again after a crash: statuses are
cumulative, so the picture rebuilds itself from the next round of them)."""

from __future__ import annotations

import argparse
import sys
import threading
from dataclasses import replace
from pathlib import Path
from typing import Sequence

import zenoh

from fleet_bus.auth import BusAuth
from fleet_bus.credentials import CredentialsError, load_auth
from fleet_bus.mission import fetch_mission
from fleet_bus.process import STATION_READY, process_stop, ready
from fleet_bus.session import DEFAULT_ENDPOINT, client_config, open_session
from ground_station.blueprint import live_blueprint
from ground_station.rerun_log import legend_bounds
from ground_station.station import APPLICATION_ID, GroundStation, mission_layers
from ground_station.subscriber import Inbox, subscribed
from ground_station.viewer import (
    VIEWERS,
    SinkError,
    ViewerOptions,
    check_rrd,
    open_recording,
    resolve_viewer,
    rrd_for_run,
)

PREFIX = "ground_station:"


def main(conf: zenoh.Config, opts: ViewerOptions, stop: threading.Event,
         mission_timeout_s: float = 120.0, auth: BusAuth | None = None) -> int:
    """Run until ``stop``; 0 on a clean stop, 2 if a viewer or file cannot be opened (said in
    one line), 3 if no mission record ever came. With ``auth`` (the run's key ring: the station
    signs nothing) every sample must be signed by its rightful sender; the rest is dropped
    and counted (``auth_<reason>``), on the dashboard too."""
    with open_session(conf) as session:
        inbox = Inbox(auth=auth)
        # subscribe before asking for the mission, so nothing published meanwhile is lost
        with subscribed(session, inbox):
            mission = fetch_mission(session, stop, mission_timeout_s, auth)
            if mission is None:
                if stop.is_set():
                    return 0
                print(f"{PREFIX} no mission record on fleet/mission", file=sys.stderr)
                return 3
            layers = mission_layers(mission)
            if opts.rrd is not None:
                opts = replace(opts, rrd=rrd_for_run(opts.rrd, mission.run_id))
            try:
                sinks = open_recording(APPLICATION_ID, mission.run_id, opts, live_blueprint(
                    layers[0].bounds, legend_bounds(layers[0]), layers[0].dynamic))
            except (SinkError, OSError) as exc:
                print(f"{PREFIX} {exc}", file=sys.stderr, flush=True)
                return 2
            rec = sinks.rec
            station = GroundStation(mission, rec, layers)
            ready(STATION_READY, f"{mission.run_id} joined")
            for note in sinks.notes:
                print(f"{PREFIX} {note}", flush=True)
            if opts.rrd is not None:
                print(f"{PREFIX} recording to {opts.rrd}", flush=True)
            if sinks.url is not None:
                print(f"{PREFIX} web viewer at {sinks.url}", flush=True)
            try:
                while not stop.is_set():
                    sample = inbox.get(timeout_s=0.2)
                    if sample is not None:
                        station.handle(*sample)
                    for reason, n in inbox.take_refused().items():
                        station.refused(reason, n)
            finally:
                station.close()
                before = len(sinks.notes)
                sinks.close()
                for note in sinks.notes[before:]:
                    print(f"{PREFIX} {note}", file=sys.stderr, flush=True)
                dropped = dict(station.dropped) | ({"overflow": inbox.overflow}
                                                   if inbox.overflow else {})
                print(f"{PREFIX} {station.handled} samples logged, dropped {dropped}",
                      flush=True)
    return 0


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m ground_station", description=__doc__,
                                allow_abbrev=False)
    p.add_argument("--connect", action="append", metavar="ENDPOINT",
                   help=f"Zenoh router endpoint (repeatable; default {DEFAULT_ENDPOINT})")
    p.add_argument("--viewer", choices=VIEWERS, default=None,
                   help="native desktop viewer, locally served web viewer, or none "
                        "(default: native with a display, else web)")
    p.add_argument("--rrd", type=Path, help="also record to this .rrd file for replay")
    p.add_argument("--web-host", "--host", dest="web_host", default="127.0.0.1",
                   help="address the web viewer and its data server listen on (default "
                        "127.0.0.1: this machine only; 0.0.0.0: every interface)")
    p.add_argument("--web-port", type=int, default=9090,
                   help="web viewer HTTP port (0: any; a busy one is replaced by a free one, "
                        "and the printed URL says which)")
    p.add_argument("--grpc-port", type=int, default=0,
                   help="port of the Rerun gRPC server the viewer reads (0: any free port)")
    p.add_argument("--mission-timeout", type=float, default=120.0,
                   help="seconds to wait for the fleet/mission record")
    p.add_argument("--credentials", type=Path, metavar="DIR",
                   help="the station's credentials directory (the run's key ring and a Zenoh "
                        "login; no signing key); without it the bus is open: experiments only")
    return p.parse_args(argv)


if __name__ == "__main__":
    args = parse_args()
    try:
        bus_auth = load_auth(args.credentials) if args.credentials else None
    except CredentialsError as exc:
        print(f"{PREFIX} {exc}", file=sys.stderr)
        raise SystemExit(2)
    viewer, note = resolve_viewer(args.viewer)
    try:
        check_rrd(args.rrd)
    except SinkError as exc:
        print(f"{PREFIX} {exc}", file=sys.stderr)
        raise SystemExit(2)
    if note:
        print(f"{PREFIX} {note}", file=sys.stderr, flush=True)
    options = ViewerOptions(viewer=viewer, rrd=args.rrd,
                            web_host=args.web_host, web_port=args.web_port,
                            grpc_port=args.grpc_port)
    raise SystemExit(main(client_config(args.connect or [DEFAULT_ENDPOINT],
                                        credentials=args.credentials), options,
                          process_stop(), args.mission_timeout, bus_auth))
