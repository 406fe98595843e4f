"""The fleet's self-organised TDMA: vehicle ``i`` owns slot ``i`` of every cycle.

All agents share the mission clock (`comms_sim.clock`), so slots need no negotiation and the
fleet's own frames never collide. A cycle (``n_vehicles * slot_s``) is the heartbeat period.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

SLOT_OFFSET = 0.05  # start this far into the slot (share of it): room for clock skew


@dataclass(frozen=True)
class Slots:
    index: int
    n_vehicles: int
    slot_s: float

    @property
    def cycle_s(self) -> float:
        return self.n_vehicles * self.slot_s

    def time(self, n: int) -> float:
        """Start of this vehicle's slot in cycle ``n``."""
        return n * self.cycle_s + (self.index + SLOT_OFFSET) * self.slot_s

    def first_from(self, t_s: float) -> int:
        """The first cycle whose slot starts at or after ``t_s``."""
        n = max(0, math.ceil((t_s - self.time(0)) / self.cycle_s))
        while self.time(n) < t_s:
            n += 1
        return n

    def missed(self, n: int, now_s: float) -> bool:
        """Too late to start slot ``n``'s frame (a slow host): it would spill into the next
        vehicle's slot."""
        return now_s - self.time(n) > 0.5 * self.slot_s
