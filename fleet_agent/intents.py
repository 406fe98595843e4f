"""What the agent's policies decide, as data.

A policy (`fleet_agent.policies`) reads the knowledge and returns intents; the agent applies
them in order (`Agent._apply`): claims and releases are journalled before they are owed to
the fleet, a route is fitted to the battery and what it leaves out is released, events and
records go out with the step. So a policy never writes to the radio, the journal or another
part of the agent, and what it decided can be read off its return value in a test.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Union

from fleet_agent.outbox import Owed
from fleet_agent.records import JournalRecord
from fleet_bus.states import EventKind


@dataclass(frozen=True)
class Hold:
    """Claim (or release) ``tasks`` now: journalled first, then owed to the fleet."""

    tasks: tuple[int, ...]
    claim: bool


@dataclass(frozen=True)
class Steer:
    """Follow ``route`` from now on, fitted to the battery (spots in ``protect`` dropped
    last); whatever this vehicle holds and the fitted route leaves out is released. ``why``
    names the change in the event log ("sync" changes are not logged)."""

    route: tuple[int, ...]
    why: str
    protect: frozenset[int] = field(default_factory=frozenset)


@dataclass(frozen=True)
class Owe:
    """Owe the fleet ``item`` of ``kind`` (`fleet_agent.outbox`)."""

    kind: Owed
    item: object = None


@dataclass(frozen=True)
class Tell:
    """An event for the log (``tasks`` as task indices; ``peer`` a vehicle id)."""

    t_s: float
    kind: EventKind
    tasks: tuple[int, ...] = ()
    peer: str = ""
    detail: str = ""


@dataclass(frozen=True)
class Note:
    """A journal record."""

    record: JournalRecord


@dataclass(frozen=True)
class Count:
    """Add ``n`` to the agent's counter ``name`` (reported in its statuses)."""

    name: str
    n: int = 1


@dataclass(frozen=True)
class LastWords:
    """Peer ``v`` is gone: what it said in its last cycle can never be proven its (`tesla`);
    take from it what cannot hurt anyone but ``v``'s own work: its own spots cleared."""

    v: int


@dataclass(frozen=True)
class SeekWork:
    """Look for other work at once, not at the next cooperation period (a lost claim, a
    find settled, a spot found empty, a peer revived)."""


Intent = Union[Hold, Steer, Owe, Tell, Note, Count, LastWords, SeekWork]
