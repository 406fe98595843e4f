"""What the agent expects of its own vehicle: where it is, what it is doing, what the rest takes.

The agent never moves its vehicle. It reads the vehicle's navigation fixes and reports
(`fleet_bus.vehicle_port`: arrived, looked, injected) and says what the vehicle should do next
(`OwnVehicle.command`). In between, this is its model of the vehicle: the position of the
last fix, the route ahead, and an explicit state machine over `Activity`:

    TRANSIT --arrived--> WAITING --claim settled--> LOOKING --looked: COTS, fit--> INJECTING
       ^                    |                          |  (nothing there, or      |
       |                    +--known spot--> INJECTING +   no battery for them)   |
       +---------------------------- next spot <----------------------------------+
    RETURNING (no spot left, or aborted) --arrived home--> HOME

Times come from the planner's travel model (`Problem.travel`, `Problem.travel_s`): still
water, steady and tidal currents and land alike (still water is one piece of current), so a
route the agent checks against the battery is timed as the planner and the checker time it.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import Enum

from fleet_agent.landmarks import MapFrame
from fleet_bus.states import VehicleState
from fleet_bus.vehicle_port import (HOME_TARGET, Abort, GoTo, HelmCommand, NavFix, ReturnHome,
                                    StationKeep, Work)
from hfc_core.model.feasibility import fits, room_s
from hfc_core.model.paths import PathFn, as_point3
from hfc_core.model.problem import Problem
from hfc_core.model.travel import LegError

# Where the vehicle was, kept for `position_at`: a point every TRAIL_STEP_S of mission time,
# TRAIL_POINTS of them (2 h; older asks get the oldest point). Membership asks where this
# vehicle was when a peer fell silent, which may be many of a large fleet's cycles ago.
TRAIL_STEP_S = 30.0
TRAIL_POINTS = 240

Point3 = tuple[float, float, float]


class Activity(Enum):
    TRANSIT = "transit"  # flying to the next spot of the route
    RETURNING = "returning"  # flying to the rendezvous (no spot left, or aborted)
    WAITING = "waiting"  # at the next spot until its claim has settled (`Conduct.not_before`)
    LOOKING = "looking"  # at a predicted spot, the camera looking
    INJECTING = "injecting"  # at a spot, injecting
    HOME = "home"  # recovered at the rendezvous


AT_SPOT = (Activity.WAITING, Activity.LOOKING, Activity.INJECTING)


@dataclass(frozen=True)
class Conduct:
    """How this vehicle works a spot (the agent's rules, given at construction): when work
    may begin (a spot claimed moments ago waits for the claim to settle), whether it must look
    first (its agent knows nothing of the spot), how long a look takes, and the battery it
    keeps back when deciding to inject what a look found."""

    not_before: Callable[[int], float]
    needs_look: Callable[[int], bool]
    inspect_s: float = 0.0
    reserve_s: float = 0.0
    # At the spot, past ``not_before``: until when to wait longer (0: not at all), given the
    # task and ``not_before``'s time; an earlier claim of it may be in a frame not yet proven.
    held_back: Callable[[int, float], float] | None = None
    # A time no ``not_before`` is later than (None: not known; every spot is asked).
    settled_by: Callable[[], float] | None = None


@dataclass(frozen=True)
class Cleared:
    """The vehicle finished injecting ``task`` at ``t_s``, after ``injected_s`` of it."""

    task: int
    t_s: float
    injected_s: float


@dataclass(frozen=True)
class Inspected:
    """The look at ``task`` ended at ``t_s``: COTS ``present`` or not, and whether the vehicle
    stays to inject them (``treating``: False if they do not fit the battery)."""

    task: int
    t_s: float
    present: bool
    treating: bool


@dataclass(frozen=True)
class ReachedHome:
    """The vehicle reached the rendezvous at ``t_s``."""

    t_s: float


class OwnVehicle:
    """The agent's model of its vehicle. ``route`` holds task indices still to treat, in
    order; the head is the spot being approached or worked."""

    def __init__(self, problem: Problem, index: int, paths: PathFn, conduct: Conduct,
                 t_s: float = 0.0) -> None:
        spec = problem.vehicles[index]
        self.problem = problem  # the working problem (rebound when beliefs change)
        self.index, self.paths, self.conduct = index, paths, conduct
        self.speed_mps = spec.speed_mps
        self.capacity_s = spec.battery_s
        self.rendezvous: Point3 = spec.rendezvous
        self.t_s = float(t_s)
        self.pos: Point3 = spec.start
        self.sigma_m = 0.0
        # The vehicle's frame against the map's (`landmarks`): positions here are the map's,
        # the waypoints commanded the vehicle's. Off on an exact map (nothing to sight).
        self.frame = MapFrame(enabled=False)
        self.yaw_deg = 0.0
        self.pitch_deg = 0.0
        self.distance_m = 0.0
        self.route: list[int] = []
        self.activity = Activity.RETURNING
        self.aborted = False
        self.home_at_s: float | None = None
        self.busy_until_s: float | None = None  # when the work at the spot ends
        self.injecting_since_s = 0.0  # when the injection under way began (while INJECTING)
        self._waited_s = 0.0  # when a wait at the spot was last judged still on
        # A search flown on the way to the next spot (`policies.searching`): its waypoints,
        # from and back to where the vehicle is, and how long they take.
        self.detour: tuple[tuple[Point3, ...], float] | None = None
        self.readings: dict[int, float | None] = {}  # looks' answers: injection time or None
        self._legs: dict[int, float] = {}  # first-leg times from (pos, t_s), memoised
        self._legs_from: tuple[Point3, float] | None = None
        self.trail: deque[tuple[float, Point3]] = deque(maxlen=TRAIL_POINTS)
        self._trail_t: deque[float] = deque(maxlen=TRAIL_POINTS)  # the trail's times

    # -- what it is doing ------------------------------------------------------------------

    @property
    def done(self) -> bool:
        return self.activity is Activity.HOME

    @property
    def injecting(self) -> int | None:
        return self.route[0] if self.activity is Activity.INJECTING and self.route else None

    @property
    def inspecting(self) -> int | None:
        return self.route[0] if self.activity is Activity.LOOKING and self.route else None

    @property
    def at_spot(self) -> int | None:
        """The spot the vehicle is at, waiting, looking or injecting (None: under way)."""
        return self.route[0] if self.activity in AT_SPOT and self.route else None

    def state(self) -> VehicleState:
        """The telemetry state: busy at a spot is injecting."""
        if self.aborted and not self.done:
            return VehicleState.ABORTED
        return VehicleState.INJECTING if self.activity in AT_SPOT \
            else VehicleState(self.activity.value)

    def battery_left_s(self, t_s: float | None = None) -> float:
        t = self.t_s if t_s is None else t_s
        if self.home_at_s is not None:
            t = min(t, self.home_at_s)
        return self.capacity_s - t

    def command(self) -> HelmCommand | None:
        """What the vehicle should be doing now (None once home)."""
        act = self.activity
        if act is Activity.HOME:
            return None
        out = self.frame.to_vehicle
        search = self.detour[0][1:] if self.detour is not None else ()
        if act is Activity.RETURNING:
            waypoints = tuple(out(w) for w in (*search, *self.paths(self.pos, self.rendezvous)[1]))
            return Abort(waypoints) if self.aborted else ReturnHome(waypoints)
        task = self.route[0]
        if act is Activity.TRANSIT:
            goal = self._target_pos(task)
            ahead = tuple(out(self._target_pos(t)) for t in self.route[1:])
            return GoTo(task, tuple(out(w) for w in (*search, *self.paths(self.pos, goal)[1])),
                        ahead)
        work = {Activity.WAITING: Work.WAIT, Activity.LOOKING: Work.LOOK,
                Activity.INJECTING: Work.INJECT}[act]
        assert self.busy_until_s is not None
        return StationKeep(work, task, max(0.0, self.busy_until_s - self.t_s))

    def command_key(self) -> tuple[Activity, int | None, bool, tuple[float, float] | None,
                                   bool]:
        """What changes the command: the activity and the spot it is about, and while it
        flies, the offset of its frame from the map's (a landmark moved the goal)."""
        moving = self.activity in (Activity.TRANSIT, Activity.RETURNING)
        return self.activity, (self.route[0] if self.route else None), self.aborted, \
            (self.frame.key() if moving else None), self.detour is not None

    def rebind(self, problem: Problem) -> None:
        """Beliefs changed: time routes on the new working problem (finds move slots)."""
        self.problem, self._legs_from = problem, None

    # -- what the vehicle reports ------------------------------------------------------------

    def fix(self, nav: NavFix) -> None:
        """A navigation fix: where the vehicle believes it is (in the map's frame)."""
        self.frame.nav(nav.sigma_m, nav.pos)
        pos = self.frame.to_map(as_point3(nav.pos)) if self.frame.enabled else \
            as_point3(nav.pos)
        if self.problem.land is not None:  # a drifted estimate may lie on land: paths start at sea
            pos = as_point3(self.problem.land.to_water(pos))
        if nav.odometer_m is not None:
            self.distance_m = float(nav.odometer_m)
        elif nav.t_s >= self.t_s:
            self.distance_m += math.dist(self.pos, pos)
        self.pos = pos
        self.sigma_m = self.frame.sigma_m if self.frame.enabled else nav.sigma_m
        self.yaw_deg, self.pitch_deg = nav.yaw_deg, nav.pitch_deg
        self.t_s = max(self.t_s, float(nav.t_s))
        if not self.trail or self.t_s - self.trail[-1][0] >= TRAIL_STEP_S:
            self.trail.append((self.t_s, self.pos))
            self._trail_t.append(self.t_s)

    def position_at(self, t_s: float) -> Point3:
        """Where the vehicle was at ``t_s`` (its fixes, a point every `TRAIL_STEP_S`, linear
        between them; now's position from its last point on)."""
        trail = self.trail
        if not trail or t_s >= trail[-1][0]:
            return self.pos if not trail or t_s >= self.t_s else _between(
                trail[-1], (self.t_s, self.pos), t_s)
        i = bisect.bisect_right(self._trail_t, t_s)
        if i == 0:
            return trail[0][1]
        return _between(trail[i - 1], trail[i], t_s)

    def at_time(self, t_s: float) -> None:
        self.t_s = max(self.t_s, float(t_s))

    def arrived(self, target: int, t_s: float) -> ReachedHome | None:
        """The vehicle reached ``target``: home, or the next spot (wait, look or inject);
        an arrival the route has moved on from is ignored."""
        self.at_time(t_s)
        self.detour = None  # a search on the way is over once the leg is
        if target == HOME_TARGET:
            if self.activity is Activity.RETURNING:
                self.activity, self.home_at_s, self.route = Activity.HOME, self.t_s, []
                return ReachedHome(self.t_s)
            return None
        if self.activity is Activity.TRANSIT and self.route and self.route[0] == target:
            wait_until = self._wait_until(target)
            if wait_until > self.t_s:
                self.activity, self.busy_until_s = Activity.WAITING, wait_until
                self._waited_s = self.t_s
            else:
                self._begin(target, self.t_s)
        return None

    def _wait_until(self, task: int) -> float:
        """Until when a vehicle at ``task`` waits before working it (`Conduct`)."""
        until = self.conduct.not_before(task)
        held = self.conduct.held_back
        return max(until, held(task, until)) if until and held is not None else until

    def wake(self, t_s: float) -> bool:
        """Time passed: a wait judged over begins the work at its end, and not before the
        last time it was judged still on (whenever the host gets to it). The wait is judged
        again at every wake: a claim proven meanwhile may end or lengthen it. True if the
        activity changed."""
        self.at_time(t_s)
        if self.activity is not Activity.WAITING or self.busy_until_s is None:
            return False
        until = max(self._wait_until(self.route[0]), self._waited_s)
        if until > self.t_s:
            self.busy_until_s, self._waited_s = until, self.t_s
            return False
        self._begin(self.route[0], until)
        return True

    def looked(self, task: int, service_s: float | None, t_s: float) -> Inspected | None:
        """The look at ``task`` ended: inject what is there (``service_s``) if it fits the
        battery, else move on. None for a look the route has moved on from."""
        self.at_time(t_s)
        if self.inspecting != task:
            return None
        self.readings[task] = service_s
        treating = service_s is not None and self.fits_here(service_s)
        if treating:
            assert service_s is not None
            self.activity, self.busy_until_s = Activity.INJECTING, self.t_s + float(service_s)
            self.injecting_since_s = self.t_s
        else:  # nothing there, or more than the battery allows: on to the next spot
            self.route.pop(0)
            self._moving()
        return Inspected(task, self.t_s, service_s is not None, treating)

    def injected(self, task: int, t_s: float) -> Cleared | None:
        """The injection at ``task`` ended (None: one the route has moved on from)."""
        self.at_time(t_s)
        if self.injecting != task:
            return None
        done = Cleared(task, self.t_s, self.t_s - self.injecting_since_s)
        self.route.pop(0)
        self._moving()
        return done

    # -- what the agent decides ------------------------------------------------------------

    def set_route(self, route: Sequence[int]) -> None:
        """Follow ``route`` from now on. Leaving the spot being worked abandons it."""
        if self.done:
            return
        route = [int(t) for t in route]
        if (route[0] if route else None) != (self.route[0] if self.route else None):
            self.detour = None  # a new way: the search on the old one is given up
        if self.activity in AT_SPOT and (not route or route[0] != self.route[0]):
            self.activity, self.busy_until_s = Activity.TRANSIT, None
        self.route = [] if self.aborted else route
        if self.activity not in AT_SPOT:
            self._moving()

    def abort(self) -> None:
        """Give up the mission and head straight for the rendezvous."""
        self.aborted = True
        self.set_route([])

    def restore(self, t_s: float, pos: Point3, distance_m: float, route: Sequence[int],
                aborted: bool, home_at_s: float | None) -> None:
        """Resume at ``t_s`` from a journal checkpoint (an injection in progress is started
        again: it never completed)."""
        self.t_s, self.pos, self.distance_m = float(t_s), pos, float(distance_m)
        self.aborted, self.busy_until_s = aborted, None
        if home_at_s is not None:
            self.home_at_s, self.activity, self.route = float(home_at_s), Activity.HOME, []
            return
        self.route = [] if aborted else [int(t) for t in route]
        self._moving()

    def set_detour(self, waypoints: tuple[Point3, ...], duration_s: float) -> None:
        """Fly ``waypoints`` (from here, back here) before the next leg."""
        self.detour = (tuple(waypoints), float(duration_s))

    # -- timing ----------------------------------------------------------------------------

    def time_to_finish_s(self, route: Sequence[int] | None = None) -> float:
        """Time from now to the rendezvous through ``route`` (default: the current one)."""
        if self.done:
            return 0.0
        route = self.route if route is None else list(route)
        p, nb, by = self.problem, self.conduct.not_before, self.conduct.settled_by
        t, rest, horizon = self.t_s, route, math.inf if by is None else by()
        busy = self._busy_until_s(route)
        if self.detour is not None and busy is None:
            t += self.detour[1]  # the search flown first
        if busy is not None:
            t, rest = max(t, busy), route[1:]
        elif route:
            t = max(t + self._reach_s(route[0]), nb(route[0])) + float(p.service_s[route[0]])
            rest = route[1:]
        if not route:
            return t - self.t_s + self._reach_s(HOME_TARGET)
        prev = route[0]
        for task in [*rest, HOME_TARGET]:
            t += self._leg_s(prev, task, t)
            if task != HOME_TARGET:
                t = (max(t, nb(task)) if t < horizon else t) + float(p.service_s[task])
            prev = task
        return t - self.t_s

    def slack_s(self, reserve_s: float = 0.0) -> float:
        """Extra time the rest of the mission may take and still fit the battery less
        ``reserve_s`` (`hfc_core.feasibility.room_s`): a detour of ``cost`` fits exactly when
        ``cost <= slack_s(reserve_s)``, by the planner's one rule."""
        return room_s(self.time_to_finish_s(), self.battery_left_s() - reserve_s)

    def fits_here(self, service_s: float) -> bool:
        """Can the vehicle inject for ``service_s`` here and still reach the rendezvous within
        its battery (less the conduct's reserve)?"""
        home_s = service_s + self._leg_time_s(self.pos, self.rendezvous, self.t_s + service_s)
        return bool(fits(home_s, self.battery_left_s() - self.conduct.reserve_s))

    def _busy_until_s(self, route: Sequence[int]) -> float | None:
        """When the vehicle is done at the spot it is busy at, if ``route`` starts with it
        (injecting; looking: the look and the injection it may reveal; waiting for a claim
        to settle: the wait, then the work); else None."""
        if not route or not self.route or route[0] != self.route[0] or \
                self.activity not in AT_SPOT or self.busy_until_s is None:
            return None
        task, until = self.route[0], self.busy_until_s
        service = float(self.problem.service_s[task])
        if self.activity is Activity.INJECTING:
            return until
        if self.activity is Activity.WAITING:
            work = max(self.conduct.inspect_s, service) if self.conduct.needs_look(task) \
                else service
            return max(self.t_s, until) + work
        left = max(0.0, until - self.t_s)  # looking: the rest of the look, then the injection
        if task in self.readings:
            reading = self.readings[task]
            return self.t_s + left + (0.0 if reading is None else reading)
        return self.t_s + left + max(0.0, service - self.conduct.inspect_s)

    def _reach_s(self, target: int) -> float:
        """Time from here, now, to ``target`` (a task index, or the rendezvous)."""
        here = (self.pos, self.t_s)
        if self._legs_from != here:
            self._legs_from, self._legs = here, {}
        if target not in self._legs:
            self._legs[target] = self._leg_time_s(self.pos, self._target_pos(target), self.t_s)
        return self._legs[target]

    def _leg_s(self, a: int, b: int, t_s: float) -> float:
        """Planning time of the leg between two route nodes (spots, or the rendezvous),
        started at ``t_s``: the planner's matrix, flown from ``t_s`` in a tidal current."""
        p = self.problem
        node = p.end_node(self.index) if b == HOME_TARGET else b
        if p.current is not None and not p.current.steady:
            return self._leg_time_s(p.xyz[a], p.xyz[node], t_s)
        return float(p.travel_s[self.index][a, node])

    def leg_time_s(self, a: Sequence[float], b: Sequence[float]) -> float:
        """Time from ``a`` to ``b`` leaving now (inf: the current forbids it)."""
        return self._leg_time_s(a, b, self.t_s)

    def _leg_time_s(self, a: Sequence[float], b: Sequence[float], t_s: float) -> float:
        assert self.problem.travel is not None
        try:
            return self.problem.travel.leg_time_s(a, b, self.speed_mps, t_s)
        except LegError:
            return math.inf  # the current makes the leg impossible: never there

    def _target_pos(self, target: int) -> Point3:
        if target == HOME_TARGET:
            return self.rendezvous
        return as_point3(self.problem.xyz[target])

    # -- transitions -------------------------------------------------------------------------

    def _begin(self, task: int, t_s: float) -> None:
        """Work at the spot reached: look first if its agent knows nothing of it, else inject."""
        if self.conduct.needs_look(task):
            self.activity, self.busy_until_s = Activity.LOOKING, t_s + self.conduct.inspect_s
        else:
            self.activity, self.injecting_since_s = Activity.INJECTING, t_s
            self.busy_until_s = t_s + float(self.problem.service_s[task])

    def _moving(self) -> None:
        self.activity = Activity.TRANSIT if self.route else Activity.RETURNING
        self.busy_until_s = None


def _between(a: tuple[float, Point3], b: tuple[float, Point3], t_s: float) -> Point3:
    """The point at ``t_s`` on the straight line from ``a`` to ``b`` (time, position)."""
    (ta, pa), (tb, pb) = a, b
    w = 0.0 if tb <= ta else min(1.0, max(0.0, (t_s - ta) / (tb - ta)))
    return (pa[0] + w * (pb[0] - pa[0]), pa[1] + w * (pb[1] - pa[1]),
            pa[2] + w * (pb[2] - pa[2]))
