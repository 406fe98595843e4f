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
HOLD_LIMIT_WALL_S = 10.0  # a vehicle's hold allowance: no hold lasts longer
HOLD_REFILL_SHARE = 0.25  # the allowance refills by this many seconds per second not held


@dataclass
class Holds:
    """Which vehicles' processes are running the planner now (`fleet_agent.plans`), by wall
    time of the start. While any is, the operator runs the shared clock at `HOLD_WARP`:
    a planner burst then costs almost no mission time, as in the in-process simulation, and
    a vehicle is never silent for a whole suspicion window because its host was computing.

    A hold is rationed per vehicle, whatever its ``busy`` flag says: each vehicle has an
    allowance of ``limit_wall_s`` hold-seconds, spent while it holds and refilled at
    ``refill_share`` per second while it does not (a token bucket of seconds). A hold that
    spends it expires (counted in ``expired``: a process that died mid-plan, an end lost on
    the bus, an insider's ``busy`` repeated every few seconds), and the vehicle cools down
    until its allowance is full again (40 s): a ``busy`` meanwhile is refused (``refused``).
    Renewing a standing hold does not extend it. So a hold can slow the mission but never
    stop it, and one vehicle can hold the clock for at most a fifth of the wall time in the
    long run (``share / (1 + share)``); a planner's bursts, a fraction of a second each, never
    come near."""

    limit_wall_s: float = HOLD_LIMIT_WALL_S
    refill_share: float = HOLD_REFILL_SHARE
    _since: dict[str, float] = field(default_factory=dict)  # holding now, since
    _allowance: dict[str, tuple[float, float]] = field(default_factory=dict)  # (s left, as of)
    _cooling: set[str] = field(default_factory=set)
    count: int = 0  # holds begun
    held_wall_s: float = 0.0  # wall time with at least one hold
    expired: dict[str, int] = field(default_factory=dict)  # holds that spent the allowance
    refused: dict[str, int] = field(default_factory=dict)  # busy flags refused (cooling down)
    _held_from: float | None = None

    def update(self, vid: str, busy: bool, wall_s: float) -> None:
        left = self._settle(vid, wall_s)
        if busy:
            if vid in self._since:
                pass  # a standing hold is not renewed: it ends when its allowance does
            elif vid in self._cooling or left <= 0.0:
                self.refused[vid] = self.refused.get(vid, 0) + 1
            else:
                self._since[vid] = wall_s
                self.count += 1
        else:
            self._since.pop(vid, None)
        self.refresh(wall_s)

    @property
    def held(self) -> bool:
        """Any hold standing (as of the last `update` or `refresh`)."""
        return bool(self._since)

    @property
    def holders(self) -> tuple[str, ...]:
        return tuple(sorted(self._since))

    def refresh(self, wall_s: float) -> None:
        """End the holds whose allowance ran out by ``wall_s``; count the wall time held."""
        for vid in list(self._since):
            if self._settle(vid, wall_s) <= 0.0:
                del self._since[vid]
                self._cooling.add(vid)
                self.expired[vid] = self.expired.get(vid, 0) + 1
        for vid in list(self._cooling):
            self._settle(vid, wall_s)
        if self.held and self._held_from is None:
            self._held_from = wall_s
        elif not self.held and self._held_from is not None:
            self.held_wall_s += wall_s - self._held_from
            self._held_from = None

    def _settle(self, vid: str, wall_s: float) -> float:
        """``vid``'s allowance as of ``wall_s`` (spent while it holds, refilled while not);
        a cool-down ends when the allowance is full again."""
        left, at = self._allowance.get(vid, (self.limit_wall_s, wall_s))
        dt = max(0.0, wall_s - at)
        if vid in self._since:
            left = max(0.0, left - dt)
        else:
            left = min(self.limit_wall_s, left + self.refill_share * dt)
            if left >= self.limit_wall_s:
                self._cooling.discard(vid)
        self._allowance[vid] = (left, max(at, wall_s))
        return left
