"""The emulated Micro-Modems of one scenario on one water.

Vehicle i (0-based, scenario order) gets the modem with address i + 1, known to the channel by
the vehicle's id (so that the fleet's truths, `fleet/truth/<id>`, move it), placed at the
vehicle's start until a truth or its host (``$PCFLP``) says otherwise. Every modem runs the
water's one rate (`comms_sim.micromodem.packet.channel_config`).
"""

from __future__ import annotations

import datetime as dt
from typing import Callable, Sequence

from comms_sim.channel import Channel
from comms_sim.link_event import LinkEvent
from comms_sim.micromodem.modem import VirtualModem
from comms_sim.micromodem.packet import OnAir
from comms_sim.water import Timer, Water
from fleet_bus.nmea import MAX_ADDRESS, RATES

Point = tuple[float, float, float]


class ModemFleet:
    """The modems of ``vehicles`` (id, start) on ``water``, whose channel runs ``rate``.
    ``epoch_unix`` dates mission time zero on the modems' clocks; ``warp`` turns a host's
    wall-clock timeouts (``DTO``) into mission time."""

    def __init__(self, water: Water, rate: int, vehicles: Sequence[tuple[str, Point]],
                 epoch_unix: Callable[[], float], warp: Callable[[], float]) -> None:
        if not 1 <= len(vehicles) <= MAX_ADDRESS:
            raise ValueError(f"between 1 and {MAX_ADDRESS} modems, got {len(vehicles)}")
        if water.channel.config.tdma is not None:
            raise ValueError("the Micro-Modem face runs without the channel's TDMA: the hosts "
                             "schedule their own transmissions")
        self.water = water
        self.config = water.channel.config
        self.rate = RATES[rate]
        self._epoch_unix = epoch_unix
        self._warp = warp
        self.modems = [VirtualModem(self, vid, i + 1) for i, (vid, _) in enumerate(vehicles)]
        self._by_node = {m.node: m for m in self.modems}

        def place_all(channel: Channel, now: float) -> None:
            for vid, start in vehicles:
                channel.set_position(vid, start, now)

        water.act(place_all)
        water.add_listener(self._on_events)

    # -- what the modems use ---------------------------------------------------------------

    def now(self) -> float:
        return self.water.clock.now()

    def date_of(self, t_s: float) -> dt.datetime:
        return dt.datetime.fromtimestamp(self._epoch_unix() + t_s, dt.timezone.utc)

    def airtime_s(self, nbytes: int) -> float:
        return self.config.airtime_s(nbytes)

    def submit(self, node: str, on_air: bytes, t_s: float, tag: OnAir) -> None:
        self.water.act(lambda channel, now: channel.submit(node, on_air, t_s, "data",
                                                           keep_time=True, tag=tag))

    def place(self, node: str, pos: Point) -> None:
        """Raises ValueError on a position that is not 3 finite numbers."""
        error: list[ValueError] = []

        def set_position(channel: Channel, now: float) -> None:
            try:
                channel.set_position(node, pos, now)
            except ValueError as exc:
                error.append(exc)

        self.water.act(set_position)
        if error:
            raise error[0]

    def at(self, t_s: float, fn: Callable[[], None]) -> Timer:
        return self.water.call_at(t_s, fn)

    def after_wall(self, wall_s: float, fn: Callable[[], None]) -> Timer:
        """``fn`` after ``wall_s`` seconds of the host's time (mission time at the warp)."""
        return self.water.call_at(self.now() + max(0.0, wall_s) * self._warp(), fn)

    # -- the water's events ----------------------------------------------------------------

    def _on_events(self, events: list[LinkEvent]) -> None:
        for event in events:
            modem = self._by_node.get(event.dst)
            if modem is not None and isinstance(event.tag, OnAir):
                modem.on_event(event)

    def heartbeat(self) -> None:
        for modem in self.modems:
            modem.heartbeat()

    def counters(self) -> dict[str, dict[str, int]]:
        return {m.node: dict(m.counters) for m in self.modems}
