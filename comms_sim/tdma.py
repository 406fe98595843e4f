"""A sender's modem queue and the TDMA slot arithmetic.

The queue holds frames waiting for the transmitter (busy with an earlier frame, or waiting
for the vehicle's TDMA slot). Only a pose report is worth less than its successor, so a new
"pose" frame replaces the queued "pose" frames of the same sender; every other kind
(cleared spots, claims, ...) stays queued until sent.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from fleet_bus.tdma import SpatialSchedule, TdmaSchedule

SUPERSEDABLE = "pose"


@dataclass(frozen=True)
class QueuedFrame:
    frame: bytes
    kind: str
    t_submitted_s: float
    tag: object = None  # what the sender's face needs back with the frame (`Channel.submit`)


class SenderQueue:
    """FIFO of one sender's frames; see the module docstring for what may be replaced."""

    def __init__(self) -> None:
        self._frames: deque[QueuedFrame] = deque()

    def push(self, item: QueuedFrame) -> int:
        """Append ``item``; return how many older frames it superseded."""
        superseded = 0
        if item.kind == SUPERSEDABLE:
            kept = deque(q for q in self._frames if q.kind != SUPERSEDABLE)
            superseded = len(self._frames) - len(kept)
            self._frames = kept
        self._frames.append(item)
        return superseded

    def head(self) -> QueuedFrame | None:
        return self._frames[0] if self._frames else None

    def pop(self) -> QueuedFrame:
        return self._frames.popleft()

    def __len__(self) -> int:
        return len(self._frames)


def slot_start(t_s: float, airtime_s: float, slot: int, n_slots: int, slot_s: float,
               guard_s: float, schedule: SpatialSchedule | None = None) -> float:
    """Earliest time >= ``t_s`` at which a frame of ``airtime_s`` can start in slot ``slot``
    of an ``n_slots``-slot cycle and still end ``guard_s`` before the slot closes; with a
    spatial ``schedule``, in vehicle ``slot``'s slots of it (the agents' own arithmetic), and
    at once for a node beyond its roster (not of the fleet: not held to its schedule)."""
    if schedule is not None:
        if slot >= schedule.n:
            return t_s
        return schedule.next_start(slot, t_s, airtime_s, guard_s)
    return TdmaSchedule(n_slots, slot_s).next_start(t_s, slot, airtime_s, guard_s)
