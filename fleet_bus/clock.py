"""Injected clocks: every component reads mission time through one of these.

Mission time is seconds since the mission epoch. `WarpClock` is the one clock shared by every
process of a multi-process mission (each computes it from the same epoch and warp, so no clock
messages are needed on one machine, and NTP suffices across machines). `ManualClock` is the
deterministic clock of the in-process discrete-event simulation and of tests (Trio's
MockClock idea).
"""

from __future__ import annotations

import math
import time
from typing import Callable, Protocol


class Clock(Protocol):
    def now(self) -> float:
        """Simulation seconds since the mission epoch."""
        ...


class ManualClock:
    """A clock that only moves when told to."""

    def __init__(self, start_s: float = 0.0) -> None:
        self._now = float(start_s)

    def now(self) -> float:
        return self._now

    def advance_to(self, t_s: float) -> None:
        if t_s < self._now:
            raise ValueError(f"time cannot run backwards: {t_s} < {self._now}")
        self._now = float(t_s)

    def advance(self, dt_s: float) -> None:
        self.advance_to(self._now + dt_s)


class WarpClock:
    """``sim = (wall - epoch_unix) * warp``: a 1-hour mission at warp 60 takes one minute."""

    def __init__(self, epoch_unix: float, warp: float,
                 wall: Callable[[], float] = time.time) -> None:
        if not (math.isfinite(warp) and warp > 0):
            raise ValueError(f"warp must be a positive finite number, got {warp}")
        if not math.isfinite(epoch_unix):
            raise ValueError(f"epoch must be finite, got {epoch_unix}")
        self.epoch_unix = float(epoch_unix)
        self.warp = float(warp)
        self._wall = wall

    def now(self) -> float:
        return (self._wall() - self.epoch_unix) * self.warp

    def wall_of(self, sim_s: float) -> float:
        """The wall (unix) time at which simulation time ``sim_s`` happens."""
        return self.epoch_unix + sim_s / self.warp

    def sim_of(self, wall_unix: float) -> float:
        """The simulation time at wall (unix) time ``wall_unix``."""
        return (wall_unix - self.epoch_unix) * self.warp

    def wall_delay(self, sim_dt_s: float) -> float:
        """Wall seconds that ``sim_dt_s`` simulated seconds take."""
        return max(0.0, sim_dt_s) / self.warp

    def sleep_until(self, sim_s: float) -> None:
        delay = self.wall_of(sim_s) - self._wall()
        if delay > 0:
            time.sleep(delay)
