"""What ``cotsfleet run --modem water|micromodem`` starts as the water, and how each agent
then reaches it.

- ``water`` (the default): the Zenoh relay (``python -m comms_sim``); agents put their
  frames on ``fleet/tx/<id>``.
- ``micromodem``: the emulated Micro-Modems (``cotsfleet water --face micromodem``) in the
  relay's place, on the same bus (the fleet's clock, its truths, link events and stats), one
  TCP port per vehicle; each agent drives its modem with the project's NMEA driver
  (``--modem micromodem:tcp:127.0.0.1:<port> --modem-rate R``).

The agents' TDMA slot must hold the modem's packet (`micromodem_slot_s`), unless the user's
agent config sets ``slot_s``.
"""

from __future__ import annotations

import math
import socket
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fleet_agent.modems.micromodem import micromodem_spec
from fleet_bus.credentials import RELAY_ID
from fleet_bus.modem_port import ModemSpec
from fleet_bus.process import RELAY_READY, WATER_READY
from hfc_core.model.problem import Problem

MODEMS = ("water", "micromodem")
SOUND_SPEED_MPS = 1500.0  # the channel's default (`comms_sim.config.ChannelConfig`)
# What a slot holds beyond the packet's bits and its way across the scenario: the packet's
# preamble (0.3 s in the emulated channel's presets, 0.5 s at rate 0), the slot's lead
# (`fleet_agent.radio.SLOT_OFFSET`, 5 %), the hosts' clock offsets and the serial exchange
# with the modem before the packet goes out.
SLOT_GUARD_S = 1.0
PORT_TRIES = 20


def scenario_span_m(problem: Problem) -> float:
    """The longest way a packet may travel in the scenario: the diagonal of the box that
    holds every spot, start and rendezvous."""
    points = [problem.xyz] + [np.array([v.start, v.rendezvous], float) for v in problem.vehicles]
    pts = np.vstack(points)
    return float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))


def micromodem_slot_s(spec: ModemSpec, problem: Problem, guard_s: float = SLOT_GUARD_S) -> float:
    """A TDMA slot that holds one full packet of ``spec`` (its frames x bytes at its bit
    rate) and its propagation across the scenario, plus ``guard_s``; rounded up to 0.1 s.
    Rate 1 on the paper preset: 3.07 s + 0.79 s + 1.0 s -> 4.9 s."""
    airtime = spec.airtime_s(spec.frames_per_packet * spec.max_frame_bytes)
    propagation = scenario_span_m(problem) / SOUND_SPEED_MPS
    return math.ceil(10.0 * (airtime + propagation + guard_s) - 1e-9) / 10.0


def free_port_run(n: int, host: str = "127.0.0.1") -> int:
    """A first port P such that P .. P + n - 1 are free now (OSError if none found)."""
    for _ in range(PORT_TRIES):
        with socket.socket() as s:
            s.bind((host, 0))
            base = int(s.getsockname()[1])
        if base + n - 1 > 65535:
            continue
        taken = []
        try:
            for port in range(base, base + n):
                sock = socket.socket()
                taken.append(sock)
                sock.bind((host, port))
            return base
        except OSError:
            continue
        finally:
            for sock in taken:
                sock.close()
    raise OSError(f"no run of {n} free TCP ports on {host}")


@dataclass
class ModemLaunch:
    """The water of a run and each agent's modem (module docstring)."""

    name: str = "water"
    rate: int = 1
    base_port: int = 0  # micromodem: vehicle i's modem on base_port + i

    def __post_init__(self) -> None:
        if self.name not in MODEMS:
            raise ValueError(f"--modem is one of {', '.join(MODEMS)}, got {self.name!r}")
        if self.name == "micromodem":
            from comms_sim.micromodem.packet import emulated_rates

            if self.rate not in emulated_rates():
                raise ValueError(f"--modem-rate {self.rate} is not emulated; choose from "
                                 f"{', '.join(map(str, emulated_rates()))}")

    @property
    def spec(self) -> ModemSpec:
        from fleet_bus.modem_port import WATER_SPEC

        return WATER_SPEC if self.name == "water" else micromodem_spec(self.rate)

    @property
    def child(self) -> str:
        """The water's name among the run's processes (its log, its crash policy)."""
        return "relay" if self.name == "water" else "water"

    @property
    def ready_prefix(self) -> str:
        return RELAY_READY if self.name == "water" else WATER_READY

    def water_argv(self, endpoint: str, creds: Path, run_dir: Path, seed: int, n: int,
                   loss: float, mission_timeout_s: float) -> list[str]:
        """The water's command line (``loss``: the relay's extra uniform loss; the emulated
        modems take it as link control instead, `ProcessBackend`)."""
        if self.name == "water":
            return ["-m", "comms_sim", "--connect", endpoint, "--credentials",
                    str(creds / RELAY_ID), "--mission-from-bus",
                    "--mission-timeout", str(mission_timeout_s)] + (
                        ["--loss", str(loss)] if loss else [])
        self.base_port = free_port_run(n)
        return ["-m", "cotsfleet", "water", "--face", "micromodem",
                "--scenario", str(run_dir / "scenario.json"), "--port", str(self.base_port),
                "--seed", str(seed), "--rate", str(self.rate), "--connect", endpoint,
                "--credentials", str(creds / RELAY_ID)]

    def agent_argv(self, index: int) -> list[str]:
        if self.name == "water":
            return []
        return ["--modem", f"micromodem:tcp:127.0.0.1:{self.base_port + index}",
                "--modem-rate", str(self.rate)]

    def describe(self, slot_s: float, derived: bool) -> dict[str, object]:
        """The report's ``modem`` section."""
        spec = self.spec
        out: dict[str, object] = {
            "name": self.name, "spec": spec.name, "frames_per_packet": spec.frames_per_packet,
            "max_frame_bytes": spec.max_frame_bytes, "bit_rate_bps": spec.bit_rate_bps,
            "slot_s": slot_s, "slot_from": "modem" if derived else "config"}
        if self.name == "micromodem":
            out["rate"] = self.rate
        return out
