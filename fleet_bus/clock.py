"""Injected clocks: every component reads mission time through one of these.

Mission time is seconds since the mission epoch. `MissionClock` is the one clock shared by
every process of a multi-process mission: it runs on this host's monotonic clock
(``time.monotonic``, which no wall-clock step moves), tied to the operator's reference time by
a measured offset (`OffsetFilter`, an NTP-like exchange: `fleet_bus.mission.ClockSync`), and
never steps once the mission has begun: a correction (a newer offset, a clock record that
came late) is slewed in (`MAX_SLEW`). `WallWatch` notices the host's wall clock stepping,
which then changes nothing but a counter. `WarpClock` is the older wall-clock form (``(wall
- epoch) * warp``), kept for the tools that date things on the wall (the emulated modems).
`ManualClock` is the deterministic clock of the in-process discrete-event simulation and of
tests (Trio's MockClock idea).
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Callable, NamedTuple, Protocol

# A correction (newer offset, late record) changes the pace of mission time by at most this
# share of the warp while it is slewed in: time never runs backwards (or stops), a 2 s error
# is gone in 4 s.
MAX_SLEW = 0.5
WALL_STEP_S = 0.5  # the wall clock moved this much against the monotonic one: it stepped
SYNC_WINDOW = 8  # time samples kept; the one with the least delay wins (RFC 5905 §10)


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


@dataclass(frozen=True)
class TimeSample:
    """One exchange with the reference (RFC 5905 §8): how far the reference is ahead of this
    host's monotonic clock, and the round trip it was measured over."""

    offset_s: float  # reference - local
    delay_s: float  # round trip, less the time the reference held the query
    local_s: float  # when the answer came (local monotonic)


def time_sample(sent_local: float, ref_received: float, ref_answered: float,
                got_local: float) -> TimeSample:
    """``t0..t3`` of an NTP exchange: the query left at ``sent_local`` and its answer came at
    ``got_local`` (this host's monotonic clock); the reference received it at ``ref_received``
    and answered at ``ref_answered`` (its clock). The offset is exact when both legs take
    equally long; its error is at most half the delay."""
    offset = ((ref_received - sent_local) + (ref_answered - got_local)) / 2.0
    delay = (got_local - sent_local) - (ref_answered - ref_received)
    return TimeSample(offset, max(0.0, delay), got_local)


class OffsetFilter:
    """The last `SYNC_WINDOW` samples; the estimate is the offset of the one with the least
    round trip (NTP's clock filter, RFC 5905 §10: queueing only ever adds delay, and the
    error of a sample is bounded by half its delay)."""

    def __init__(self, window: int = SYNC_WINDOW) -> None:
        self._samples: deque[TimeSample] = deque(maxlen=window)

    def add(self, sample: TimeSample) -> None:
        if math.isfinite(sample.offset_s) and math.isfinite(sample.delay_s):
            self._samples.append(sample)

    def best(self) -> TimeSample | None:
        return min(self._samples, key=lambda s: s.delay_s, default=None)

    def __len__(self) -> int:
        return len(self._samples)


class _Timing(NamedTuple):
    """Everything `MissionClock.now` reads, swapped as one (a reader on another thread never
    sees half of a change)."""

    epoch_ref: float  # reference time of mission time 0 on the current segment
    warp: float
    offset_s: float  # reference - local monotonic
    correction_s: float  # mission seconds still to slew away, as of ``since``
    since: float  # local monotonic time of the last change


class MissionClock:
    """Mission time from this host's monotonic clock: ``(local + offset - epoch_ref) * warp``.

    ``epoch_ref`` and ``warp`` come from the operator's clock records (``seq`` orders them);
    ``offset`` (reference minus local) from the time exchange (`steer`). Until the mission
    begins (mission time 0) a change applies at once; after, the clock is continuous and
    monotonic: the jump a change would make becomes a correction slewed away at most
    ``max_slew * warp`` mission seconds per second. The wall clock (``wall``) is read only to
    put dates on things (`wall_of`); nothing here depends on it.

    The operator's own clock is the reference: offset 0, never corrected."""

    def __init__(self, epoch_ref: float, warp: float, seq: int = 0, *, offset_s: float = 0.0,
                 epoch_unix: float | None = None, mono: Callable[[], float] = time.monotonic,
                 wall: Callable[[], float] = time.time, max_slew: float = MAX_SLEW) -> None:
        _check(epoch_ref, warp)
        if not 0.0 < max_slew < 1.0:
            raise ValueError(f"max_slew must be in (0, 1), got {max_slew}")
        self._mono, self._wall, self.max_slew = mono, wall, max_slew
        self._t = _Timing(float(epoch_ref), float(warp), float(offset_s), 0.0, mono())
        self.seq = seq
        self._epoch_unix = epoch_unix
        self._started = False
        self._lock = threading.Lock()

    # -- reading ----------------------------------------------------------------------------

    def now(self) -> float:
        t = self._mono()
        m = self._at(self._t, t)
        if m >= 0.0 and not self._started:
            self._started = True
        return m

    @property
    def warp(self) -> float:
        return self._t.warp

    @property
    def epoch_ref(self) -> float:
        return self._t.epoch_ref

    @property
    def offset_s(self) -> float:
        return self._t.offset_s

    @property
    def correction_s(self) -> float:
        """Mission seconds still being slewed away (positive: this clock is ahead)."""
        return self._correction(self._t, self._mono())

    @property
    def epoch_unix(self) -> float:
        """A date for mission time 0 on this segment: the operator's (from its record), else
        this host's wall clock's."""
        if self._epoch_unix is not None:
            return self._epoch_unix
        t = self._t
        return t.epoch_ref - t.offset_s + (self._wall() - self._mono())

    def stamp(self) -> float:
        """This host's monotonic time now: `sim_of` turns it into mission time later."""
        return self._mono()

    def sim_of(self, stamp: float) -> float:
        """Mission time at local monotonic ``stamp`` (never later than now)."""
        return min(self._at(self._t, stamp), self.now())

    def wall_of(self, sim_s: float) -> float:
        """The wall (unix) time at which mission time ``sim_s`` happens, read off this host's
        wall clock (for dates only: ROS stamps, logs)."""
        return self._wall() + (sim_s - self.now()) / self._t.warp

    def wall_delay(self, sim_dt_s: float) -> float:
        """Seconds that ``sim_dt_s`` mission seconds take (at the warp; a correction being
        slewed in makes it a little more or less: callers look again)."""
        return max(0.0, sim_dt_s) / self._t.warp

    def sleep_until(self, sim_s: float, max_step_s: float = 0.25) -> None:
        while True:
            delay = self.wall_delay(sim_s - self.now())
            if delay <= 0:
                return
            time.sleep(min(delay, max_step_s))

    # -- changing ---------------------------------------------------------------------------

    def follow(self, epoch_ref: float, warp: float, seq: int,
               epoch_unix: float | None = None) -> bool:
        """Take a newer clock record (``seq`` above the one followed); True if taken."""
        if seq <= self.seq:
            return False
        _check(epoch_ref, warp)
        with self._lock:
            if seq <= self.seq:
                return False
            self._retarget(float(epoch_ref), float(warp), self._t.offset_s)
            self.seq, self._epoch_unix = seq, epoch_unix
        return True

    def steer(self, offset_s: float) -> None:
        """A new estimate of the reference's offset from this host's monotonic clock."""
        if not math.isfinite(offset_s):
            raise ValueError(f"offset must be finite, got {offset_s}")
        with self._lock:
            t = self._t
            self._retarget(t.epoch_ref, t.warp, float(offset_s))

    def at_warp(self, warp: float) -> tuple[float, float, int]:
        """The record that runs this clock at ``warp`` from now on without a jump: (epoch_ref,
        warp, seq), to be put on the bus and followed (`follow`), by this process too."""
        t = self._t
        local = self._mono()
        return local + t.offset_s - self._at(t, local) / warp, float(warp), self.seq + 1

    # -- inside -----------------------------------------------------------------------------

    def _retarget(self, epoch_ref: float, warp: float, offset_s: float) -> None:
        """Swap in a new timing (with the lock held): continuous from now on once the mission
        has begun, at once before."""
        local = self._mono()
        shown = self._at(self._t, local)
        correction = 0.0
        if self._started or shown >= 0.0:
            self._started = True
            correction = shown - (local + offset_s - epoch_ref) * warp
        self._t = _Timing(epoch_ref, warp, offset_s, correction, local)

    def _correction(self, t: _Timing, local: float) -> float:
        left = abs(t.correction_s) - self.max_slew * t.warp * max(0.0, local - t.since)
        return math.copysign(left, t.correction_s) if left > 0.0 else 0.0

    def _at(self, t: _Timing, local: float) -> float:
        return (local + t.offset_s - t.epoch_ref) * t.warp + self._correction(t, local)


class WallWatch:
    """Notices this host's wall clock stepping: between two looks, the wall and the monotonic
    clock moved apart by `WALL_STEP_S` or more (an NTP step, an operator's ``date -s``; a
    slewing NTP moves them apart by at most 0.5 ms a second). Mission time does not read the
    wall clock, so a step changes nothing but these counters."""

    def __init__(self, mono: Callable[[], float] = time.monotonic,
                 wall: Callable[[], float] = time.time, threshold_s: float = WALL_STEP_S) -> None:
        self._mono, self._wall, self.threshold_s = mono, wall, threshold_s
        self._gap = wall() - mono()
        self.steps = 0
        self.last_step_s = 0.0
        self.stepped_s = 0.0  # the sum of the steps seen

    def check(self) -> float | None:
        """The step since the last look (seconds, signed), or None."""
        gap = self._wall() - self._mono()
        step, self._gap = gap - self._gap, gap
        if abs(step) < self.threshold_s:
            return None
        self.steps += 1
        self.last_step_s = step
        self.stepped_s += step
        return step


def _check(epoch_unix: float, warp: float) -> None:
    if not (math.isfinite(warp) and warp > 0):
        raise ValueError(f"warp must be a positive finite number, got {warp}")
    if not math.isfinite(epoch_unix):
        raise ValueError(f"epoch must be finite, got {epoch_unix}")
