"""What goes into the agent's state machine and what comes out of it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Union

from comms_sim.bus import Truth
from fleet_agent.telemetry import Event, Status


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
    """Fault injection from the launcher: ``"abort"``."""

    name: str
    now: float


Input = Union[Tick, Frame, Command]


@dataclass(frozen=True)
class Send:
    """A frame for the radio."""

    frame: bytes
    kind: str  # the relay's queue class: "pose" (may be superseded) or "data"
    message: str  # wire kind name, for counters


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


Output = Union[Send, Publish, Record]
