"""The one shell around an agent: inputs in, outputs carried out, the same under every backend.

A backend supplies a `Transport` (send a frame on the radio, publish telemetry) and a
`JournalSink`; it feeds `AgentDriver.step` with inputs at mission times and ticks the agent at
`next_wakeup`. Two backends exist: the Zenoh node (`fleet_agent.node`, one OS process per
vehicle on the shared warp clock) and the in-process simulation (`cotsfleet.mission.inprocess`,
the whole fleet on a discrete-event loop). Both go through `carry_out`, so what a vehicle
journals, sends and reports, and in which order, never depends on the backend.

In a dynamic mission the driver also carries the world's camera (`fleet_agent.sensor.World`):
after each step it sweeps the track the vehicle just ran and answers a look that began, and
feeds what the camera saw back to the agent as a `Sensed` input at the same mission time. So
the agent learns the reef only through its sensor, the same way under both backends.
"""

from __future__ import annotations

from typing import Any, Callable, Protocol, Sequence

from fleet_agent.agent import Agent
from fleet_agent.io_types import (Command, Frame, Input, Output, Publish, Record, Send, Sensed,
                                  Tick)
from fleet_agent.sensor import World
from fleet_bus.telemetry import Event, Status, Truth


class Transport(Protocol):
    def send(self, frame: bytes, kind: str, sent_s: float | None = None) -> None:
        """Put ``frame`` on the radio (``kind``: the relay's queue class; ``sent_s``: when
        the vehicle sends it on the mission clock, `fleet_bus.link.TxTag`)."""

    def publish(self, topic: str, payload: Status | Event | Truth) -> None:
        """Telemetry for the ground station and the mission runner."""


class JournalSink(Protocol):
    def append(self, doc: dict[str, Any], durable: bool = False) -> None: ...


class AgentDriver:
    """Steps one agent and carries out what it decides."""

    def __init__(self, agent: Agent, transport: Transport, journal: JournalSink,
                 tap: Callable[[Sequence[Output]], None] | None = None,
                 world: World | None = None) -> None:
        self.agent, self.transport, self.journal = agent, transport, journal
        self.tap = tap  # sees every step's outputs (tests, debugging)
        self.world = world  # the simulated camera (dynamic missions), else None

    def tick(self, now: float) -> None:
        self.step(Tick(now))

    def frame(self, data: bytes, now: float) -> None:
        self.step(Frame(data, now))

    def command(self, name: str, now: float) -> None:
        self.step(Command(name, now))

    def step(self, inp: Input) -> None:
        self.carry_out(self.agent.step(inp))
        if self.world is not None:
            self._sense()

    def _sense(self) -> None:
        """What the camera saw since the last step, and the answer of a look just begun."""
        agent, world = self.agent, self.world
        assert world is not None
        v = agent.vehicle
        sightings = tuple(world.sweep(v.pos))
        task = v.inspecting
        inspection = world.inspect(task) if task is not None and task not in v.readings \
            else None
        if sightings or inspection is not None:
            self.carry_out(agent.step(Sensed(agent.t, sightings, inspection)))

    def next_wakeup(self) -> float:
        return self.agent.next_wakeup()

    def carry_out(self, outputs: Sequence[Output]) -> None:
        """Journal first (what is announced is already on record if the process dies right
        after), then radio and telemetry in the order the agent produced them."""
        if self.tap is not None:
            self.tap(outputs)
        for o in outputs:
            if isinstance(o, Record):
                self.journal.append(o.doc, o.durable)
        for o in outputs:
            if isinstance(o, Send):
                self.transport.send(o.frame, o.kind, o.sent_s)
            elif isinstance(o, Publish):
                self.transport.publish(o.topic, o.payload)

    def final_status(self, now: float) -> None:
        """The last word on the way out (shutdown): a status at ``now``."""
        self.transport.publish("status", self.agent.status(now))
