"""The one shell around an agent: inputs in, outputs carried out, the same under every backend.

A backend supplies the vehicle (a `fleet_bus.vehicle_port.VehiclePort`: the simulated vehicle,
a MOOS-IvP or a ROS 2 helm), the modem (a `fleet_bus.modem_port.ModemPort`: the emulated
water, or a Micro-Modem), a `Telemetry` sink and a `JournalSink`; it feeds
`AgentDriver.step` with inputs at mission times (frames the modem received among them) and
ticks the agent at `next_wakeup`. Two backends exist: the Zenoh node (`fleet_agent.node`, one
OS process per vehicle on the shared warp clock) and the in-process simulation
(`cotsfleet.mission.inprocess`, the whole fleet on a discrete-event loop). Both go through
`carry_out`, so what a vehicle journals, sends, reports and commands, and in which order, never
depends on the backend.

Before each input the driver polls the vehicle and hands its reports to the agent with the
input. A simulated vehicle knows when its next report is due (`next_report_s`): the driver
first runs every report due before the input at its own time, so the agent decides at the
exact moment an arrival or the end of an injection happens, however late the host runs.

The driver tells the agent how old the vehicle's last navigation fix is at each step (a live
helm's own ``nav_age_s()``, else the time since the last fix it handed over), counts the
fixes into the agent's counters (``nav_fixes``) with the worst delay between a fix and the
step that took it (``nav_delay_max_ms``), and wakes at least every ``poll_s`` for a live
helm (one that does not say when it next reports), so a fix waits for the agent no longer.

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
from fleet_bus.commands import Command as OperatorCommand
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
                 tap: Callable[[Sequence[Output]], None] | None = None,
                 poll_s: float = 1.0) -> None:
        self.agent, self.vehicle, self.modem, self.journal = agent, vehicle, modem, journal
        self.telemetry = telemetry
        self.truth, self.truth_period_s = truth, truth_period_s
        self.tap = tap  # sees every step's outputs (tests, debugging)
        self.nav_fixes = 0  # fixes the agent took from its vehicle
        self.nav_delay_max_s = 0.0  # the worst delay from a fix to the step that took it
        self._last_fix_s = self._t0 = agent.t  # before the first fix: the agent's start
        self._poll_s = poll_s if getattr(vehicle, "name", "sim") != "sim" else None
        self._next_truth = agent.t if truth is not None else math.inf

    def tick(self, now: float) -> None:
        self.step(Tick(now))

    def frame(self, data: bytes, now: float) -> None:
        self.step(Frame(data, now))

    def command(self, name: OperatorCommand, now: float) -> None:
        self.step(Command(name, now))

    def step(self, inp: Input) -> None:
        while (due := self.vehicle.next_report_s()) is not None and due < inp.now:
            self._step(Tick(max(due, self.agent.t)))  # the vehicle's news, at its own time
        self._step(inp)

    def next_wakeup(self) -> float:
        due = self.vehicle.next_report_s()
        times = [self.agent.next_wakeup(), math.inf if due is None else due, self._next_truth]
        if self._poll_s is not None:  # a live helm: look at it regularly
            times.append(self.agent.t + self._poll_s)
        return min(times)

    def _step(self, inp: Input) -> None:
        reports = self.vehicle.poll(inp.now)
        fixes = [r.t_s for r in reports if isinstance(r, NavFix)]
        if fixes:
            self.nav_fixes += len(fixes)
            self.agent.count("nav_fixes", len(fixes))
            self._last_fix_s = max(self._last_fix_s, fixes[-1])
            # From the agent's start on (a live helm's fixes from before it are not late).
            worst = max(0.0, inp.now - max(self._t0, min(fixes)))
            if worst > self.nav_delay_max_s:
                self.nav_delay_max_s = worst
                self.agent.counters["nav_delay_max_ms"] = int(round(1000.0 * worst))
        outputs = self.agent.step(inp, reports, nav_age_s=self.nav_age_s(inp.now))
        self._publish_truth()
        self.carry_out(outputs)

    def nav_age_s(self, now: float) -> float:
        """How old the vehicle's last fix is at ``now``: a live helm's own figure when it
        keeps one (``nav_age_s()``), else since the last fix handed to the agent."""
        own = getattr(self.vehicle, "nav_age_s", None)
        age = own() if callable(own) else math.inf
        if not math.isfinite(age):  # no fix from the helm yet: counted from the start
            age = now - self._last_fix_s
        return max(0.0, age)

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
