"""TDMA slot arithmetic, shared by the agents (who send in their own slot) and the water (the
channel's optional TDMA MAC): slot ``i`` of cycle ``n`` opens at ``n * cycle + i * slot_s``,
slots numbered in the scenario's vehicle order everywhere.

All processes share the mission clock (`fleet_bus.clock`), so slots need no negotiation and
the fleet's own frames never collide.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

EPS_S = 1e-9  # float slack on slot boundaries


@dataclass(frozen=True)
class TdmaSchedule:
    n_slots: int
    slot_s: float

    def __post_init__(self) -> None:
        if not (isinstance(self.n_slots, int) and self.n_slots >= 1):
            raise ValueError(f"a TDMA cycle needs at least one slot, got {self.n_slots!r}")
        if not (math.isfinite(self.slot_s) and self.slot_s > 0):
            raise ValueError(f"slot length must be positive, got {self.slot_s!r}")

    @property
    def cycle_s(self) -> float:
        return self.n_slots * self.slot_s

    def opens(self, slot: int, cycle: int, lead: float = 0.0) -> float:
        """When ``slot`` opens in cycle ``cycle``, plus ``lead`` (a share of the slot: senders
        start a little into their slot, room for clock skew)."""
        return cycle * self.cycle_s + (slot + lead) * self.slot_s

    def first_cycle(self, slot: int, t_s: float, lead: float = 0.0) -> int:
        """The first cycle in which ``opens(slot, cycle, lead)`` is at or after ``t_s``."""
        n = max(0, math.ceil((t_s - self.opens(slot, 0, lead)) / self.cycle_s))
        while self.opens(slot, n, lead) < t_s:
            n += 1
        return n

    def next_start(self, t_s: float, slot: int, airtime_s: float, guard_s: float) -> float:
        """Earliest time >= ``t_s`` at which a frame of ``airtime_s`` can start in ``slot`` and
        still end ``guard_s`` before the slot closes."""
        if airtime_s + guard_s > self.slot_s + EPS_S:
            raise ValueError(f"a {airtime_s:.3f} s frame never fits a {self.slot_s} s slot")
        cycle = math.floor(t_s / self.cycle_s)
        while True:
            opens = self.opens(slot, cycle)
            start = max(t_s, opens)
            if start + airtime_s <= opens + self.slot_s - guard_s + EPS_S:
                return start
            cycle += 1
