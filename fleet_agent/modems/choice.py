"""Which modem an agent talks through (``--modem``, ``--modem-rate``): `ModemChoice`."""

from __future__ import annotations

from dataclasses import dataclass

from fleet_agent.modems.link import parse_link
from fleet_agent.modems.micromodem import MicroModem, micromodem_spec
from fleet_bus.clock import Clock
from fleet_bus.modem_port import WATER_SPEC, ModemPort, ModemSpec, ReportSink


@dataclass(frozen=True)
class ModemChoice:
    """The emulated water (``water``: `fleet_agent.modems.water`, opened on the mission's
    Zenoh session) or a WHOI Micro-Modem (``micromodem:LINK``, LINK a serial device or
    ``tcp:HOST:PORT``) at ``rate``."""

    name: str = "water"
    rate: int = 1

    @property
    def spec(self) -> ModemSpec:
        return WATER_SPEC if self.name == "water" else micromodem_spec(self.rate)

    @property
    def link(self) -> str:
        return self.name.partition(":")[2]

    def open(self, sink: ReportSink, clock: Clock) -> ModemPort:
        """The Micro-Modem on its link (the water is opened on the session instead)."""
        if self.name == "water":
            raise ValueError("the emulated water is opened on the mission's Zenoh session")
        return MicroModem(self.link, sink, clock, rate=self.rate)

    @staticmethod
    def parse(text: str, rate: int = 1) -> "ModemChoice":
        """ValueError, saying why, for anything but ``water`` or ``micromodem:LINK``."""
        if text == "water":
            return ModemChoice()
        kind, _, link = text.partition(":")
        if kind != "micromodem" or not link:
            raise ValueError(f"--modem is water or micromodem:LINK, got {text!r}")
        parse_link(link)
        micromodem_spec(rate)
        return ModemChoice(text, rate)
