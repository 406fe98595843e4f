"""The operator's hand on the shared clock of a multi-process mission.

The launcher owns the mission clock (`fleet_bus.clock.MissionClock` on its own monotonic
clock: the fleet's reference) and serves it as a signed record on ``fleet/clock``, timing
each answer so that every process can measure its offset from the reference
(`fleet_bus.mission.ClockSync`); every process follows the newest record. Two rules change
its pace, both from `cotsfleet.mission.pacing` (pure), applied here:

- **Pace** (`pace`): a vehicle whose host stays behind the clock (`LagWatch`) slows it to
  the warp that host can keep (`slower_warp`), at most once per `SLOW_HOLD_WALL_S` (the
  statuses must show the new pace first) and never below `MIN_WARP`; after a calm spell it
  speeds up again, a step at a time, towards the requested warp (`faster_warp`).
- **Holds** (`busy`): while any agent runs its planner (`fleet/busy/<id>`), the clock runs
  at `HOLD_WARP` and gets its warp back after (`Holds`: rationed per vehicle, whatever its
  flag says); pacing waits while a hold stands, since an agent's lateness while it plans is
  not the machine's pace.

It also names the hosts whose wall clock stepped (the operator's own, `WallWatch`, and each
vehicle's, from the ``clock_wall_steps`` counter of its statuses): a line in the log and the
report's ``clock.wall_steps``; mission time never reads a wall clock, so that is all a step
does.

The main loop paces and the bus callbacks hold, on different threads: both change the clock
under one lock. The monotonic clock is injected (``wall``: the reference, and the hold and
pace timers) and so is the wall clock (``unix``: dates only), as is what puts a new record
on the bus (``publish``), so the rules run in tests without a bus.
"""

from __future__ import annotations

import threading
import time
from typing import Any, Callable, Iterable

from cotsfleet.mission.pacing import HOLD_WARP, Holds, LagWatch, faster_warp, slower_warp
from fleet_bus.clock import MissionClock, WallWatch
from fleet_bus.mission import ClockRecord, answer_clock
from fleet_bus.telemetry import Status

SLOW_HOLD_WALL_S = 2.0  # wall seconds between two changes of pace
MIN_WARP = 1.0
START_DELAY_S = 1.0  # mission time 0 this long after the clock is first served
WALL_STEPS = "clock_wall_steps"  # the agents' status counter of their host's wall-clock steps


class ClockControl:
    """``control.start(epoch)`` once every agent is ready; then `pace` from the main loop,
    `busy` from the busy callback, `record` to serve, `report` at the end."""

    def __init__(self, requested_warp: float, bound_s: float,
                 publish: Callable[[bytes], None], out: Callable[[str], None] = print,
                 wall: Callable[[], float] = time.monotonic,
                 unix: Callable[[], float] = time.time) -> None:
        self.requested = requested_warp
        self._publish, self._out, self._wall, self._unix = publish, out, wall, unix
        self.clock: MissionClock | None = None
        self.record = b""  # the current clock record (unsigned payload), served on fleet/clock
        self._epoch0 = 0.0  # reference time of mission time 0 (for the effective warp)
        self._unix_gap = 0.0  # wall - monotonic when the clock started: the records' dates
        self.watch = WallWatch(wall, unix)  # the operator's own wall clock
        self.wall_steps: dict[str, int] = {}  # host (vehicle id, "operator") -> steps seen
        self.slowdowns: list[dict[str, float]] = []
        self.speedups: list[dict[str, float]] = []  # back up after a calm spell
        self.lag_watch = LagWatch(bound_s)
        self.holds = Holds()
        self._held_warp: float | None = None  # the warp to give back after the hold
        self._next_change_wall = 0.0
        self._expired_seen = 0
        self._lock = threading.Lock()

    def start(self, delay_s: float = START_DELAY_S) -> MissionClock:
        """The mission clock: mission time 0 ``delay_s`` from now, at the requested warp
        (held at once if an agent already plans)."""
        with self._lock:
            self._unix_gap = self._unix() - self._wall()
            self._epoch0 = self._wall() + delay_s
            self.clock = MissionClock(self._epoch0, self.requested, mono=self._wall,
                                      wall=self._unix, epoch_unix=self._epoch0 + self._unix_gap)
            self.record = self._record()
            self._apply_hold()
            return self.clock

    def answer(self, parameters: str) -> bytes:
        """The answer to a query of ``fleet/clock`` (unsigned payload): the newest record,
        timed on the reference clock for the asker's offset (`ClockSync`)."""
        received = self._wall()
        return answer_clock(self.record, parameters, received, self._wall)

    @property
    def held(self) -> bool:
        """The clock runs at `HOLD_WARP` now because an agent plans."""
        return self._held_warp is not None

    def pace(self, statuses: Iterable[Status]) -> None:
        """Slow the clock down when a vehicle's host stays behind it, and speed it up again
        once every host keeps up: a slow machine gives a slower mission, not a different
        one. ``statuses``: the latest status of each vehicle."""
        with self._lock:  # a hold's end restarts the watch (`busy`, another thread)
            for s in statuses:
                self.lag_watch.see(s.id, s.t_s, s.lag_s)
                self._see_steps(s.id, s.counters.get(WALL_STEPS, 0))
            if self.watch.check() is not None:
                self._see_steps("operator", self.watch.steps, self.watch.last_step_s)
            self._apply_hold()  # holds expire
            if self._held_warp is None:
                self._pace_step()

    def busy(self, vid: str, busy: bool) -> None:
        """``vid`` starts (True) or ends (False) a planner run; also False for a process that
        died, whose hold ends with it."""
        with self._lock:
            self.holds.update(vid, busy, self._wall())
            self._apply_hold()

    def report(self) -> dict[str, Any]:
        """Requested, final and effective warp (mission seconds per wall second over the
        whole mission), the changes of pace, the holds and the worst lag any host had."""
        clock = self.clock
        if clock is None:
            return {"warp": self.requested}
        wall = self._wall() - self._epoch0
        return {"warp": self.requested, "final_warp": round(clock.warp, 2),
                "effective_warp": round(clock.now() / wall, 2) if wall > 0 else None,
                "slowdowns": self.slowdowns, "speedups": self.speedups,
                "max_lag_s": round(self.lag_watch.max_lag_s, 2),
                "holds": self.holds.count, "held_wall_s": round(self.holds.held_wall_s, 2),
                "holds_expired": dict(self.holds.expired),
                "holds_refused": dict(self.holds.refused),
                "wall_steps": dict(self.wall_steps)}

    def _see_steps(self, host: str, steps: int, step_s: float | None = None) -> None:
        """A host's count of wall-clock steps; a new one is named in the log."""
        if not isinstance(steps, int) or steps <= self.wall_steps.get(host, 0):
            return
        self.wall_steps[host] = steps
        size = f" by {step_s:+.1f} s" if step_s is not None else ""
        when = f"t={self.clock.now():.0f} s: " if self.clock is not None else ""
        self._out(f"{when}the wall clock of {host}'s host stepped{size} ({steps} step(s) so "
                  "far); mission time runs on the monotonic clock and is unaffected")

    def _pace_step(self) -> None:
        clock = self.clock
        if clock is None or self._wall() < self._next_change_wall:
            return
        lag = self.lag_watch.behind()
        if lag > 0.0 and clock.warp > MIN_WARP:
            warp = max(MIN_WARP, slower_warp(clock.warp, lag, self.lag_watch.bound_s))
            self.slowdowns.append({"t_s": round(clock.now(), 1), "warp": round(warp, 2),
                                   "lag_s": round(lag, 2)})
            self._out(f"t={clock.now():.0f} s: a vehicle ran {lag:.1f} s behind the mission "
                      f"clock; warp slowed to {warp:.1f}")
        elif lag <= 0.0 and clock.warp < self.requested and self.lag_watch.calm():
            warp = faster_warp(clock.warp, self.requested)
            self.speedups.append({"t_s": round(clock.now(), 1), "warp": round(warp, 2)})
            self._out(f"t={clock.now():.0f} s: every vehicle keeps up; warp back up to "
                      f"{warp:.1f}")
        else:
            return
        self._set_warp(warp)
        self._next_change_wall = self._wall() + SLOW_HOLD_WALL_S
        self.lag_watch.restart()

    def _apply_hold(self) -> None:
        """Hold the clock at HOLD_WARP while any agent plans, give it back after (with the
        lock held)."""
        clock = self.clock
        if clock is None:
            return
        self.holds.refresh(self._wall())
        expired = sum(self.holds.expired.values())
        if expired > self._expired_seen:
            self._expired_seen = expired
            self._out(f"t={clock.now():.0f} s: a planning hold ran out of its allowance "
                      f"(expired so far: {dict(self.holds.expired)}); the clock goes on")
        if self.holds.held and self._held_warp is None:
            self._held_warp = clock.warp
            if clock.warp > HOLD_WARP:
                self._set_warp(HOLD_WARP)
        elif not self.holds.held and self._held_warp is not None:
            warp, self._held_warp = self._held_warp, None
            if warp != clock.warp:
                self._set_warp(warp)
            self.lag_watch.restart()  # lateness measured across a hold is not the pace

    def _set_warp(self, warp: float) -> None:
        """Run the clock at ``warp`` from now on: a new record, without a jump in mission
        time (`WarpClock.at_warp`), followed here and put on the bus for every process."""
        assert self.clock is not None
        epoch, warp, seq = self.clock.at_warp(warp)
        self.clock.follow(epoch, warp, seq, epoch + self._unix_gap)
        self.record = self._record()
        self._publish(self.record)

    def _record(self) -> bytes:
        clock = self.clock
        assert clock is not None
        return ClockRecord(clock.epoch_unix, clock.warp, clock.seq, clock.epoch_ref,
                           self.holds.holders).encode()
