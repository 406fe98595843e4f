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
    """``sim = (wall - epoch_unix) * warp``: a 1-hour mission at warp 60 takes one minute.

    The operator may change its pace mid-mission (`at_warp`, a new epoch and warp from the
    same instant on, so mission time never jumps); every process then `follow`s the newest
    record. Epoch and warp are swapped together (one tuple), so a reader on another thread
    never sees one without the other."""

    def __init__(self, epoch_unix: float, warp: float,
                 wall: Callable[[], float] = time.time, seq: int = 0) -> None:
        _check(epoch_unix, warp)
        self._seg = (float(epoch_unix), float(warp))
        self.seq = seq
        self._wall = wall

    @property
    def epoch_unix(self) -> float:
        return self._seg[0]

    @property
    def warp(self) -> float:
        return self._seg[1]

    def now(self) -> float:
        epoch, warp = self._seg
        return (self._wall() - epoch) * warp

    def follow(self, epoch_unix: float, warp: float, seq: int) -> bool:
        """Take a newer clock record (``seq`` above the one followed); True if taken."""
        if seq <= self.seq:
            return False
        _check(epoch_unix, warp)
        self._seg, self.seq = (float(epoch_unix), float(warp)), seq
        return True

    def at_warp(self, warp: float) -> tuple[float, float, int]:
        """The record that runs this clock at ``warp`` from now on without a jump: (epoch,
        warp, seq), to be put on the bus and followed (`follow`), by this process too."""
        at = self._wall()
        sim = (at - self._seg[0]) * self._seg[1]
        return at - sim / warp, float(warp), self.seq + 1

    def wall_of(self, sim_s: float) -> float:
        """The wall (unix) time at which simulation time ``sim_s`` happens."""
        epoch, warp = self._seg
        return epoch + sim_s / warp

    def sim_of(self, wall_unix: float) -> float:
        """The simulation time at wall (unix) time ``wall_unix``."""
        epoch, warp = self._seg
        return (wall_unix - epoch) * warp

    def wall_delay(self, sim_dt_s: float) -> float:
        """Wall seconds that ``sim_dt_s`` simulated seconds take."""
        return max(0.0, sim_dt_s) / self._seg[1]

    def sleep_until(self, sim_s: float) -> None:
        delay = self.wall_of(sim_s) - self._wall()
        if delay > 0:
            time.sleep(delay)


def _check(epoch_unix: float, warp: float) -> None:
    if not (math.isfinite(warp) and warp > 0):
        raise ValueError(f"warp must be a positive finite number, got {warp}")
    if not math.isfinite(epoch_unix):
        raise ValueError(f"epoch must be finite, got {epoch_unix}")
