"""When the operator slows the shared clock: a vehicle's process that stays behind it.

Every agent reports in each status the worst lateness of its host since the previous one
(`Status.lag_s`, mission seconds). A single late step is a burst (a replan of a few hundred
wall milliseconds is tens of mission seconds at warp 60): slowing the clock afterwards would
not undo it, and since silence is not death (`docs/fleet_agent.md`) it costs no spot and no
false alarm as long as it is shorter than the suspicion window; the replanner's bursts, the
long ones, hold the clock instead (`Holds`, `benchmarks/demo_warp.py`). A host that stays
late, status after status, is one the machine cannot keep up with at this warp: it wakes after
its TDMA slots and its decisions come late, which a slower clock does fix. So the clock is
slowed when one vehicle has reported more than ``bound_s`` in ``sustained`` consecutive
statuses, at once to the warp that host can keep (`slower_warp`). Once every vehicle has
kept well within the bound (a quarter of it) for
``recover`` statuses in a row (a minute at the default period), the busy spell is over and the
clock speeds up again, a step at a time, up to the requested warp (`faster_warp`): a host
starved for a few seconds costs a few slower minutes, not a slow mission. Correctness does
not depend on any of this (a late host's frames are dated at their slots: `Radio.take_slot`);
the pace only keeps decisions timely. Pure logic: `clock_control.ClockControl` feeds it the
statuses the launcher sees and acts on `behind` and `calm`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

SUSTAINED_STATUSES = 3  # consecutive late statuses (15 mission s at the default period)
RECOVER_STATUSES = 12  # consecutive calm statuses of every vehicle before speeding up again
# One slowdown divides the warp by at most 1 / MIN_FACTOR and at least 1 / MAX_FACTOR.
MIN_FACTOR, MAX_FACTOR = 0.2, 0.7


def slower_warp(warp: float, lag_s: float, bound_s: float) -> float:
    """The warp at which a host ``lag_s`` mission seconds behind at ``warp`` would be half of
    ``bound_s`` behind: its lateness in wall seconds (``lag_s / warp``) stays what it is, so
    mission lateness scales with the warp. In one step, not many: a host that stays behind
    while the clock is eased down a step every few wall seconds runs late slot after slot
    (its frames are dated at their slots, so this costs timeliness, not correctness)."""
    factor = 0.5 * bound_s / lag_s if lag_s > 0 else MAX_FACTOR
    return warp * min(MAX_FACTOR, max(MIN_FACTOR, factor))


def faster_warp(warp: float, requested: float) -> float:
    """One step back up after a calm spell: the inverse of the gentlest slowdown, never past
    the warp the operator asked for."""
    return min(requested, warp / MAX_FACTOR)


@dataclass
class LagWatch:
    """Per vehicle, how many of its latest statuses in a row reported a lag over ``bound_s``
    (late), and how many at most a quarter of it (calm)."""

    bound_s: float
    sustained: int = SUSTAINED_STATUSES
    recover: int = RECOVER_STATUSES
    _last_t: dict[str, float] = field(default_factory=dict)
    _late_run: dict[str, int] = field(default_factory=dict)
    _calm_run: dict[str, int] = field(default_factory=dict)
    _worst: dict[str, float] = field(default_factory=dict)
    max_lag_s: float = 0.0

    def see(self, vid: str, t_s: float, lag_s: float) -> None:
        """A status of ``vid`` stamped ``t_s``; one already seen (same or older) is ignored."""
        if t_s <= self._last_t.get(vid, float("-inf")):
            return
        self._last_t[vid] = t_s
        self.max_lag_s = max(self.max_lag_s, lag_s)
        self._calm_run[vid] = self._calm_run.get(vid, 0) + 1 if lag_s <= 0.25 * self.bound_s \
            else 0
        if lag_s > self.bound_s:
            self._late_run[vid] = self._late_run.get(vid, 0) + 1
            self._worst[vid] = max(self._worst.get(vid, 0.0), lag_s)
        else:
            self._late_run[vid] = 0
            self._worst[vid] = 0.0

    def behind(self) -> float:
        """The worst lag of a vehicle that stayed behind (0.0 if none did)."""
        return max((self._worst[v] for v, n in self._late_run.items() if n >= self.sustained),
                   default=0.0)

    def calm(self) -> bool:
        """Every vehicle heard from kept well within the bound for ``recover`` statuses."""
        return bool(self._calm_run) and min(self._calm_run.values()) >= self.recover

    def restart(self) -> None:
        """After a change of pace: the statuses must show the new pace before the next one."""
        self._late_run.clear()
        self._worst.clear()
        self._calm_run.clear()


HOLD_WARP = 2.0  # the shared clock's pace while an agent plans (mission s per wall s)
HOLD_EXPIRE_WALL_S = 10.0  # a hold not released this long after it began is dropped


@dataclass
class Holds:
    """Which vehicles' processes are running the planner now (`fleet_agent.plans`), by wall
    time of the start. While any is, the operator runs the shared clock at `HOLD_WARP`:
    a planner burst then costs almost no mission time, as in the in-process simulation, and
    a vehicle is never silent for a whole suspicion window because its host was computing.
    A hold older than ``expire_wall_s`` is dropped (a process that died mid-plan, or an end
    lost on the bus), so a hold can slow the mission but never stop it."""

    expire_wall_s: float = HOLD_EXPIRE_WALL_S
    _since: dict[str, float] = field(default_factory=dict)
    count: int = 0  # holds begun
    held_wall_s: float = 0.0  # wall time with at least one hold
    _held_from: float | None = None

    def update(self, vid: str, busy: bool, wall_s: float) -> None:
        if busy:
            if vid not in self._since:
                self.count += 1
            self._since[vid] = wall_s
        else:
            self._since.pop(vid, None)
        self.refresh(wall_s)

    @property
    def held(self) -> bool:
        """Any hold standing (as of the last `update` or `refresh`)."""
        return bool(self._since)

    def refresh(self, wall_s: float) -> None:
        """Drop the holds expired at ``wall_s`` and count the wall time held up to it."""
        for vid, t in list(self._since.items()):
            if wall_s - t > self.expire_wall_s:
                del self._since[vid]
        if self.held and self._held_from is None:
            self._held_from = wall_s
        elif not self.held and self._held_from is not None:
            self.held_wall_s += wall_s - self._held_from
            self._held_from = None
