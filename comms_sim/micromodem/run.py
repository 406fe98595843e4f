"""`run_water`: the emulated Micro-Modems of a scenario, served until stopped.

Standalone, the mission clock starts when the modems listen (``epoch`` now, ``warp``). On a
mission bus (``connect``), the water also takes the fleet's truths (positions), link control
and the stats query, and publishes every frame's fate on ``fleet/link/<src>/<dst>`` as the
relay does (`comms_sim.relay.serve` with ``take_tx=False``); its clock follows the operator's
``fleet/clock`` record once there is one (until then it runs from its own start, and nothing
is sent: agents transmit once the mission clock runs).
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Callable, Sequence

from comms_sim.channel import Channel
from comms_sim.micromodem.fleet import ModemFleet, Point
from comms_sim.micromodem.packet import channel_config
from comms_sim.micromodem.server import ModemServer
from comms_sim.seeds import channel_rng
from comms_sim.water import Water
from fleet_bus.clock import WarpClock
from fleet_bus.process import WATER_READY, ready

PRE_MISSION_S = 10 * 365 * 86400.0
HEARTBEAT_S = 60.0  # mission seconds between $CAREV of an idle modem (0: never)


def run_water(vehicles: Sequence[tuple[str, Point]], host: str, base_port: int, rate: int,
              warp: float, seed: int, stop: threading.Event,
              connect: Sequence[str] = (), credentials: Path | None = None,
              heartbeat_s: float = HEARTBEAT_S,
              on_ready: Callable[[ModemServer, ModemFleet], None] | None = None
              ) -> dict[str, object]:
    """Serve one emulated modem per vehicle until ``stop``; returns the counters. Raises
    ValueError on a bad rate or fleet, OSError if a port cannot be bound."""
    # On a bus, mission time waits far in the past for the operator's record (seq >= 0
    # replaces seq -1): the channel never runs ahead of the mission it will join.
    clock = WarpClock(time.time() + (PRE_MISSION_S if connect else 0.0), warp, seq=-1)
    water = Water(Channel(channel_config(rate), channel_rng(seed)), clock)
    fleet = ModemFleet(water, rate, vehicles, lambda: clock.epoch_unix, lambda: clock.warp)
    server = ModemServer(fleet.modems, host, base_port)
    server.start()
    threads: list[threading.Thread] = []
    try:
        threads.append(threading.Thread(target=server.serve, args=(stop,), name="modem-ports",
                                        daemon=True))
        threads.append(threading.Thread(target=_heartbeats, args=(fleet, clock, stop,
                                                                  heartbeat_s),
                                        name="modem-heartbeat", daemon=True))
        for thread in threads:
            thread.start()

        def announce() -> None:
            ready(WATER_READY, f"face=micromodem rate={rate} ports={server.ports[0]}-"
                               f"{server.ports[-1]} modems={len(fleet.modems)} warp={warp:g} "
                               f"bus={'on' if connect else 'off'}")
            if on_ready is not None:
                on_ready(server, fleet)

        if connect:
            _on_bus(water, clock, fleet, vehicles, connect, credentials, stop, announce)
        else:
            announce()
            water.run(stop)
    finally:
        stop.set()
        server.wake()
        for thread in threads:
            thread.join(5.0)
        server.close()
    return {"modems": fleet.counters(), "server": dict(server.counters)}


def _heartbeats(fleet: ModemFleet, clock: WarpClock, stop: threading.Event,
                period_s: float) -> None:
    if period_s <= 0:
        return
    next_s = clock.now() + period_s
    while not stop.wait(min(1.0, clock.wall_delay(next_s - clock.now()))):
        now = clock.now()
        if now >= next_s:
            fleet.heartbeat()
            next_s = max(next_s + period_s, now)


def _on_bus(water: Water, clock: WarpClock, fleet: ModemFleet,
            vehicles: Sequence[tuple[str, Point]], connect: Sequence[str],
            credentials: Path | None, stop: threading.Event,
            announce: Callable[[], None]) -> None:
    """Serve the bus side (`comms_sim.relay.serve`, no deliveries) on the shared water."""
    from comms_sim.relay import serve
    from fleet_bus.credentials import RELAY_ID, load_auth
    from fleet_bus.mission import fetch_clock, follow_clock
    from fleet_bus.session import client_config, open_session

    auth = load_auth(credentials, RELAY_ID) if credentials else None
    with open_session(client_config(list(connect), credentials=credentials)) as session:
        follower = follow_clock(session, clock, auth)  # noqa: F841  (kept alive)

        def first_clock() -> None:
            record = fetch_clock(session, stop, 365 * 86400.0, auth)
            if record is not None:
                clock.follow(record.epoch_unix, record.warp, record.seq)

        threading.Thread(target=first_clock, name="clock-fetch", daemon=True).start()
        serve(session, water.channel, clock, stop, frozenset(v for v, _ in vehicles),
              on_ready=lambda _: announce(), auth=auth, take_tx=False, water=water)
