"""What goes into the agent's state machine and what comes out of it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Iterable, Union

from fleet_agent.records import JournalRecord
from fleet_bus.commands import Command as OperatorCommand
from fleet_bus.states import EventKind
from fleet_bus.telemetry import Event, Status, Truth
from fleet_bus.vehicle_port import HelmCommand


@dataclass(frozen=True)
class Tick:
    """Time passed: do whatever is due at ``now``."""

    now: float


@dataclass(frozen=True)
class Frame:
    """Bytes off the radio at ``now`` (anything: the agent authenticates them)."""

    data: bytes
    now: float


@dataclass(frozen=True)
class Command:
    """Fault injection from the operator: ``abort``."""

    name: OperatorCommand
    now: float


Input = Union[Tick, Frame, Command]


@dataclass(frozen=True)
class Send:
    """One transmission for the modem: its frames (at most the modem's frames per packet)."""

    frames: tuple[bytes, ...]
    kind: str  # the modem's queue class: "pose" (may be superseded) or "data"
    messages: tuple[str, ...]  # wire kind names, for counters
    # When the vehicle sends it, on its own clock: its slot's opening if the host ran late
    # (`Radio.take_slot`); the channel places the frame there, not when the bus delivers it.
    sent_s: float | None = None


@dataclass(frozen=True)
class Publish:
    """Telemetry for the ground station (never read by other agents)."""

    topic: str  # "status" | "event" | "truth"
    payload: Status | Event | Truth


@dataclass(frozen=True)
class Record:
    """A journal record; ``durable`` ones are fsync'ed (what was cleared or promised)."""

    doc: dict[str, Any]
    durable: bool = False


@dataclass(frozen=True)
class Helm:
    """A command for the vehicle (`fleet_bus.vehicle_port`), from the step's time on."""

    command: HelmCommand


Output = Union[Send, Publish, Record, Helm]


class Outputs(list):
    """The outputs of one step, with the helpers every part of the agent uses to add to them.
    Events name tasks by their scenario ids (``tids``) and the vehicle by ``vid``."""

    def __init__(self, vid: str, tids: Callable[[Iterable[int]], list[int]]) -> None:
        super().__init__()
        self.vid, self._tids = vid, tids

    def record(self, rec: JournalRecord) -> None:
        self.append(Record(rec.doc(), rec.durable))

    def event(self, t_s: float, kind: EventKind, tasks: Iterable[int] = (), peer: str = "",
              detail: str = "") -> None:
        self.append(Publish("event", Event(float(t_s), self.vid, kind, self._tids(tasks),
                                           peer, detail)))
