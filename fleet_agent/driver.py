"""The one shell around an agent: inputs in, outputs carried out, the same under every backend.

A backend supplies the vehicle (a `fleet_bus.vehicle_port.VehiclePort`: the simulated vehicle,
a MOOS-IvP or a ROS 2 helm), the modem (a `fleet_bus.modem_port.ModemPort`: the emulated
water, or a Micro-Modem), a `Telemetry` sink and a `JournalSink`; it feeds
`AgentDriver.step` with inputs at mission times (frames the modem received among them) and
ticks the agent at `next_wakeup`. Two backends exist: the Zenoh node (`fleet_agent.node`, one OS process per
vehicle on the shared warp clock) and the in-process simulation (`cotsfleet.mission.inprocess`,
the whole fleet on a discrete-event loop). Both go through `carry_out`, so what a vehicle
journals, sends, reports and commands, and in which order, never depends on the backend.

Before each input the driver polls the vehicle and hands its reports to the agent with the
input. A simulated vehicle knows when its next report is due (`next_report_s`): the driver
first runs every report due before the input at its own time, so the agent decides at the
exact moment an arrival or the end of an injection happens, however late the host runs.

Where the vehicle is simulated (``truth``), the driver also publishes where it really is
(``fleet/truth``: the channel's positions, the ground station's picture) every
``truth_period_s``, before the frames of the same step: the relay places a sender before its
frames. The agent itself only ever knows its navigation estimate.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Protocol, Sequence

from fleet_agent.agent import Agent
from fleet_agent.io_types import Command, Frame, Helm, Input, Output, Publish, Record, Send, Tick
from fleet_bus.telemetry import Event, Status, Truth
from fleet_bus.modem_port import ModemPort
from fleet_bus.vehicle_port import NavFix, VehiclePort

Point3 = tuple[float, float, float]
TruePose = Callable[[], tuple[Point3, float, float]]  # where the vehicle is: pos, yaw, pitch


class Telemetry(Protocol):
    def publish(self, topic: str, payload: Status | Event | Truth) -> None:
        """Telemetry for the ground station and the mission runner."""


class JournalSink(Protocol):
    def append(self, doc: dict[str, Any], durable: bool = False) -> None: ...


class AgentDriver:
    """Steps one agent with its vehicle's reports and carries out what it decides."""

    def __init__(self, agent: Agent, vehicle: VehiclePort, modem: ModemPort,
                 telemetry: Telemetry, journal: JournalSink, *, truth: TruePose | None = None,
                 truth_period_s: float = 5.0,
                 tap: Callable[[Sequence[Output]], None] | None = None) -> None:
        self.agent, self.vehicle, self.modem, self.journal = agent, vehicle, modem, journal
        self.telemetry = telemetry
        self.truth, self.truth_period_s = truth, truth_period_s
        self.tap = tap  # sees every step's outputs (tests, debugging)
        self.nav_fixes = 0  # fixes the agent took from its vehicle
        self._next_truth = agent.t if truth is not None else math.inf

    def tick(self, now: float) -> None:
        self.step(Tick(now))

    def frame(self, data: bytes, now: float) -> None:
        self.step(Frame(data, now))

    def command(self, name: str, now: float) -> None:
        self.step(Command(name, now))

    def step(self, inp: Input) -> None:
        while (due := self.vehicle.next_report_s()) is not None and due < inp.now:
            self._step(Tick(max(due, self.agent.t)))  # the vehicle's news, at its own time
        self._step(inp)

    def next_wakeup(self) -> float:
        due = self.vehicle.next_report_s()
        return min(self.agent.next_wakeup(), math.inf if due is None else due, self._next_truth)

    def _step(self, inp: Input) -> None:
        reports = self.vehicle.poll(inp.now)
        self.nav_fixes += sum(1 for r in reports if isinstance(r, NavFix))
        outputs = self.agent.step(inp, reports)
        self._publish_truth()
        self.carry_out(outputs)

    def _publish_truth(self) -> None:
        now = self.agent.t
        if self.truth is None or now < self._next_truth:
            return
        self._next_truth = now + self.truth_period_s
        pos, yaw, pitch = self.truth()
        self.telemetry.publish("truth", Truth(now, pos, yaw, pitch, self.agent.state))

    def carry_out(self, outputs: Sequence[Output]) -> None:
        """Journal first (what is announced is already on record if the process dies right
        after), then the modem, telemetry and the vehicle in the order the agent produced
        them."""
        if self.tap is not None:
            self.tap(outputs)
        for o in outputs:
            if isinstance(o, Record):
                self.journal.append(o.doc, o.durable)
        for o in outputs:
            if isinstance(o, Send):
                self.modem.transmit(o.frames, o.kind, o.sent_s)
            elif isinstance(o, Publish):
                self.telemetry.publish(o.topic, o.payload)
            elif isinstance(o, Helm):
                self.vehicle.command(o.command, self.agent.t)

    def final_status(self, now: float) -> None:
        """The last word on the way out (shutdown): a status at ``now``."""
        self.telemetry.publish("status", self.agent.status(now))
