"""The vehicle model: kinematics (paper eq. 3-7), injections and battery time.

The AUV cruises at constant speed |v| (Assumption 1) along straight legs in 3-D, with yaw and
pitch taken from the motion (eq. 5-6, roll neglected by Assumption 2); the distance run is the
sum of eq. 7 over the legs. At a spot it hovers for the spot's injection time. Battery time
runs down with mission time whatever the vehicle does (constant thrust power) until it is
recovered at the rendezvous. Around land a leg is the waypoint path of the land metric.

In a current (the scenario's ``current``) the vehicle keeps |v| through the water and crabs so
that it stays on the leg: it moves along the leg at the ground speed of `hfc_core.travel`,
piece by piece as that model cuts the leg (a gridded field's pieces, the tide's 60 s steps),
so it arrives exactly when the checker says it does. Yaw and pitch are those of the track.

Pure and exact: `advance` jumps to any later time, settling arrivals and injection ends at
the moment they happen, so the result does not depend on how often it is called (every
position is computed from the current segment's origin and its precomputed pieces).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Collection, Sequence

import numpy as np

from hfc_core.model.current import CurrentField
from hfc_core.model.feasibility import fits, room_s
from hfc_core.model.problem import Problem
from hfc_core.model.travel import LegError, segment_pieces

Point3 = tuple[float, float, float]
# (from, to) -> (length_m, waypoints after ``from`` ending at ``to``)
PathFn = Callable[[Point3, Point3], tuple[float, list[Point3]]]

TRANSIT, INJECTING, RETURNING, HOME, ABORTED = "transit", "injecting", "returning", "home", "aborted"
# Hovering at a predicted spot to see what is there (dynamic missions). Reported as
# "injecting" on the wire and in telemetry: for the fleet it is a vehicle busy at a spot.
INSPECTING = "inspecting"
# Hovering at a spot claimed moments ago until the claim has settled (`not_before`): an
# earlier claim of the same spot by a peer has had time to arrive. Reported as "injecting".
WAITING = "waiting"
_EPS = 1e-9


def straight_path(p: Point3, q: Point3) -> tuple[float, list[Point3]]:
    return math.dist(p, q), [q]


def path_function(problem: Problem) -> PathFn:
    """Straight legs in open water; shortest waypoint paths around land otherwise."""
    land = problem.land  # the planner's land metric (`hfc_core.geometry.LandMap`)
    if land is None:
        return straight_path

    def around_land(p: Point3, q: Point3) -> tuple[float, list[Point3]]:
        length, waypoints = land.shortest_path(p, q)
        points = [tuple(float(c) for c in w) for w in waypoints]
        points = [(*w, q[2]) if len(w) == 2 else w for w in points]  # 2-D waypoints: keep depth
        if not points or math.dist(points[-1], q) > 1e-6:
            points.append(q)
        if math.dist(points[0], p) <= 1e-6 and len(points) > 1:
            points = points[1:]
        return float(length), points  # type: ignore[return-value]

    return around_land


@dataclass(frozen=True)
class Cleared:
    """The vehicle finished injecting ``task`` at ``t_s``."""

    task: int
    t_s: float


@dataclass(frozen=True)
class Inspected:
    """The vehicle finished looking at ``task`` at ``t_s``: COTS ``present`` or not, and
    whether it stays to inject them (``treating``: False if they do not fit the battery)."""

    task: int
    t_s: float
    present: bool
    treating: bool


@dataclass(frozen=True)
class Arrived:
    """The vehicle reached the rendezvous at ``t_s``."""

    t_s: float


class _Looking:
    """The vehicle's look at a predicted spot (dynamic missions): it hovers ``inspect_s`` at
    a spot its agent knows nothing about, then injects what the camera showed (if it fits the
    battery) or moves on. Part of `Vehicle`, kept apart: one idea."""

    mode: str
    t_s: float
    pos: Point3
    inspect_s: float
    inspect_until_s: float | None
    wait_until_s: float | None
    route: list[int]
    inject_until_s: float | None
    readings: dict[int, float | None]
    reserve_s: float

    def _init_looking(self) -> None:
        # Which spots must be looked at before injecting (the agent's beliefs), how long a
        # look takes, what each look showed (task -> real injection time, None: empty), and
        # the battery kept back when deciding to inject what a look found.
        self.needs_look: Callable[[int], bool] = lambda task: False
        self.inspect_s = 0.0
        self.inspect_until_s = None
        self.readings = {}
        self.reserve_s = 0.0

    def _look_ends_s(self) -> float | None:
        """When the look under way ends; None past its end without the camera's answer:
        nothing happens until the driver delivers it (in the step that started the look)."""
        end = self.inspect_until_s if self.inspect_until_s is not None else self.t_s
        return end if end > self.t_s or self.route[0] in self.readings else None

    @property
    def inspecting(self) -> int | None:
        return self.route[0] if self.mode == INSPECTING and self.route else None

    def reveal(self, task: int, service_s: float | None) -> None:
        """The camera's answer for ``task``: its real injection time, or None (empty)."""
        self.readings[int(task)] = None if service_s is None else float(service_s)

    def _at_spot_left_s(self) -> float:
        """Time still to spend at the spot being looked at: the rest of the look, then the
        injection it reveals (expected from the plan's figure until the camera answers)."""
        task = self.route[0]
        left = max(0.0, (self.inspect_until_s or self.t_s) - self.t_s)
        if task in self.readings:
            service = self.readings[task]
            return left + (0.0 if service is None else service)
        return left + max(0.0, float(self.problem.service_s[task]) - self.inspect_s)

    def _busy_until_s(self, route: Sequence[int]) -> float | None:
        """When the vehicle is done at the spot it is busy at, if ``route`` starts with it
        (injecting; looking: the look and the injection it may reveal; waiting for a claim
        to settle: the wait, then the work); else None."""
        if not route or not self.route or route[0] != self.route[0]:
            return None
        if self.mode == INJECTING:
            return self.inject_until_s or self.t_s
        if self.mode == WAITING:
            task, service = self.route[0], float(self.problem.service_s[self.route[0]])
            work = max(self.inspect_s, service) if self.needs_look(task) else service
            return max(self.t_s, self.wait_until_s or self.t_s) + work
        return self.t_s + self._at_spot_left_s() if self.mode == INSPECTING else None

    def _fits_here(self, service_s: float) -> bool:
        """Can the vehicle inject for ``service_s`` here and still reach the rendezvous within
        its battery (less ``reserve_s``)?"""
        if self.current is None:
            home_s = service_s + self.paths(self.pos, self.rendezvous)[0] / self.speed_mps
        else:
            home_s = self._fly_s(self.pos, self.rendezvous, self.t_s + service_s) - self.t_s
        return fits(home_s, self.battery_left_s() - self.reserve_s)

    def _end_look(self, until_s: float, events: list) -> bool:
        """Finish the look under way if it ends by ``until_s`` and the camera has answered:
        inject what is there (it fits) or move on. False: nothing to do yet."""
        end = self.inspect_until_s if self.inspect_until_s is not None else self.t_s
        task = self.route[0]
        if end > until_s or task not in self.readings:
            return False
        self.t_s = max(self.t_s, end)
        self.inspect_until_s = None
        service = self.readings[task]
        treating = service is not None and self._fits_here(service)
        events.append(Inspected(task, self.t_s, service is not None, treating))
        if treating:
            self.mode = INJECTING
            self.inject_until_s = self.t_s + float(service)  # type: ignore[arg-type]
        else:  # nothing there, or more than the battery allows: move on
            self.route.pop(0)
            self.mode = TRANSIT
            self._retarget()  # type: ignore[attr-defined]
        return True


class _InCurrent:
    """The vehicle's motion through a current (the scenario's ``current``): when a leg ends,
    flown piece by piece as `hfc_core.travel.segment_pieces` cuts it (a gridded field's
    pieces, the tide's 60 s steps), and how far along a segment it is at a given time. Part
    of `Vehicle`, kept apart: one idea."""

    problem: Problem
    index: int
    speed_mps: float
    t_s: float
    pos: Point3
    current: CurrentField | None
    paths: PathFn
    not_before: Callable[[int], float]
    _target: int | None
    _waypoints: list[Point3]
    _origin_t: float
    _pieces: list[tuple[float, float]]

    def _time_to_finish_in_current(self, route: list[int]) -> float:
        """`time_to_finish_s` through the current: the leg under way as its pieces say, the
        others from the planner's exact times (steady current) or flown from the moment each
        starts (tidal)."""
        p = self.problem
        t = self.t_s
        i = 0
        busy = self._busy_until_s(route)  # type: ignore[attr-defined]
        if busy is not None:
            t = max(t, busy)
            i = 1
        elif route:
            t = max(self._reach_at_s(route[0]), self.not_before(route[0]))
            t += float(p.service_s[route[0]])
            i = 1
        prev = route[0] if route else None
        steady = self.current is not None and self.current.steady
        times = p.travel_s[self.index]
        for task in [*route[i:], -1]:
            if prev is None:
                t = self._reach_at_s(-1)
                break
            node = p.end_node(self.index) if task < 0 else task
            if steady:
                t += float(times[prev, node])
            else:
                t = self._fly_s(p.xyz[prev], self._target_pos(task), t)  # type: ignore[attr-defined]
            if task >= 0:
                t = max(t, self.not_before(task)) + float(p.service_s[task])
            prev = task
        return t - self.t_s

    def _reach_at_s(self, target: int) -> float:
        """When the vehicle, going now from where it is, reaches ``target`` (-1: rendezvous)."""
        if self._target == target and self._waypoints:
            return self._leg_end_s()  # type: ignore[attr-defined]
        return self._fly_s(self.pos, self._target_pos(target), self.t_s)  # type: ignore[attr-defined]

    def _fly_s(self, a: Sequence[float], b: Sequence[float], t_s: float) -> float:
        """When a leg a -> b (its waypoint path) started at ``t_s`` ends; inf if impossible."""
        _, waypoints = self.paths(tuple(float(c) for c in a), tuple(float(c) for c in b))  # type: ignore[arg-type]
        prev = a
        for w in waypoints:
            t_s = self._segment_end_s(prev, w, t_s)
            prev = w
        return t_s

    def _segment_end_s(self, a: Sequence[float], b: Sequence[float], t_s: float) -> float:
        try:
            return t_s + sum(d for d, _ in segment_pieces(self.current, a, b, self.speed_mps, t_s))
        except LegError:
            return math.inf  # the current makes the segment impossible: never there

    def _profile(self, a: Point3, b: Point3, t_s: float) -> list[tuple[float, float]]:
        """(mission time, metres run) at the end of each piece of the segment a -> b."""
        try:
            pieces = segment_pieces(self.current, a, b, self.speed_mps, t_s)
        except LegError:
            return [(math.inf, 0.0)]  # cannot make headway: holds station, never arrives
        out, t, run = [], t_s, 0.0
        for duration, length in pieces:
            t, run = t + duration, run + length
            out.append((t, run))
        return out

    def _run_m(self, t_s: float) -> float:
        """Metres run along the current segment at ``t_s`` (piece by piece from its origin)."""
        t0, run0 = self._origin_t, 0.0
        for t1, run1 in self._pieces:
            if t_s < t1:
                return run0 + (run1 - run0) * ((t_s - t0) / (t1 - t0)) if t1 > t0 else run0
            t0, run0 = t1, run1
        return run0


class Vehicle(_Looking, _InCurrent):
    """One AUV's physical state. ``route`` holds task indices still to treat, in order; the
    head is the spot being approached or injected."""

    def __init__(self, problem: Problem, index: int, paths: PathFn | None = None,
                 t_s: float = 0.0, pos: Point3 | None = None) -> None:
        spec = problem.vehicles[index]
        self.problem = problem
        self.index = index
        self.speed_mps = spec.speed_mps
        self.capacity_s = spec.battery_s
        self.rendezvous: Point3 = spec.rendezvous
        self.paths = paths or path_function(problem)
        self.pos: Point3 = tuple(pos) if pos is not None else spec.start  # type: ignore[assignment]
        self.t_s = float(t_s)
        self.route: list[int] = []
        self.mode = TRANSIT
        self.aborted = False
        self.distance_m = 0.0
        self.yaw_deg = 0.0
        self.pitch_deg = 0.0
        self.inject_until_s: float | None = None
        self.wait_until_s: float | None = None
        # When work at a spot may begin at the earliest (the agent's claim rule: a spot this
        # vehicle claimed moments ago waits for the claim to settle); 0: at once.
        self.not_before: Callable[[int], float] = lambda task: 0.0
        self.home_at_s: float | None = None
        self._init_looking()
        self._waypoints: list[Point3] = []
        self._target: int | None = None  # task index, or -1 for the rendezvous
        self._origin, self._origin_t, self._origin_dist = self.pos, self.t_s, 0.0
        self.current = problem.current
        # In a current: the segment toward the next waypoint as (mission time, metres run)
        # at the end of each piece of constant ground speed, from the segment's origin.
        self._pieces: list[tuple[float, float]] = []
        self._retarget()

    # -- queries ---------------------------------------------------------------------------

    def battery_left_s(self, t_s: float | None = None) -> float:
        t = self.t_s if t_s is None else t_s
        if self.home_at_s is not None:
            t = min(t, self.home_at_s)
        return self.capacity_s - t

    @property
    def done(self) -> bool:
        return self.mode == HOME

    @property
    def injecting(self) -> int | None:
        return self.route[0] if self.mode == INJECTING and self.route else None

    def state(self) -> str:
        """The telemetry state (`fleet_agent.telemetry.STATES`)."""
        if self.aborted and self.mode != HOME:
            return ABORTED
        return INJECTING if self.mode in (INSPECTING, WAITING) else self.mode


    def time_to_finish_s(self, route: Sequence[int] | None = None) -> float:
        """Time from now to the rendezvous through ``route`` (default: the current one)."""
        if self.mode == HOME:
            return 0.0
        route = self.route if route is None else list(route)
        if self.current is not None:
            return self._time_to_finish_in_current(route)
        dist = self.problem.dist_m
        total = 0.0
        i = 0
        busy = self._busy_until_s(route)
        if busy is not None:
            total += max(0.0, busy - self.t_s)
            i = 1
        elif route:
            total += self._reach_m(route[0]) / self.speed_mps
            total = max(total, self.not_before(route[0]) - self.t_s)
            total += self.problem.service_s[route[0]]
            i = 1
        prev = route[0] if route else None
        for task in route[i:]:
            total += dist[prev, task] / self.speed_mps
            total = max(total, self.not_before(task) - self.t_s)
            total += self.problem.service_s[task]
            prev = task
        if prev is None:
            total += self._reach_home_m() / self.speed_mps
        else:
            total += dist[prev, self.problem.end_node(self.index)] / self.speed_mps
        return total

    def slack_s(self, reserve_s: float = 0.0) -> float:
        """Extra time the rest of the mission may take and still fit the battery less
        ``reserve_s`` (`hfc_core.feasibility.room_s`): a detour of ``cost`` fits exactly when
        ``cost <= slack_s(reserve_s)``, by the planner's one rule."""
        return room_s(self.time_to_finish_s(), self.battery_left_s() - reserve_s)

    def next_event_s(self) -> float | None:
        """When the next arrival or injection end happens (None once home)."""
        if self.mode == HOME:
            return None
        if self.mode == INJECTING:
            return self.inject_until_s
        if self.mode == INSPECTING:
            return self._look_ends_s()
        if self.mode == WAITING:
            return self.wait_until_s
        return max(self.t_s, self._leg_end_s())

    # -- commands --------------------------------------------------------------------------

    def set_route(self, route: Sequence[int]) -> None:
        """Follow ``route`` from now on. Leaving the spot being injected abandons it."""
        route = [int(t) for t in route]
        if self.mode == HOME:
            return
        if self.mode in (INJECTING, INSPECTING, WAITING) and (
                not route or route[0] != self.route[0]):
            self.mode = TRANSIT
            self.inject_until_s = self.inspect_until_s = self.wait_until_s = None
        self.route = route if not self.aborted else []
        self._retarget()

    def abort(self) -> None:
        """Give up the mission and head straight for the rendezvous."""
        self.aborted = True
        self.set_route([])

    def restore(self, t_s: float, pos: Point3, distance_m: float, route: Sequence[int],
                aborted: bool, home_at_s: float | None) -> None:
        """Resume at ``t_s`` from a journal checkpoint (an injection in progress is started
        again: it never completed)."""
        self.t_s = float(t_s)
        self.pos = tuple(float(c) for c in pos)  # type: ignore[assignment]
        self.distance_m = float(distance_m)
        self.aborted = aborted
        self.inject_until_s = self.inspect_until_s = self.wait_until_s = None
        self._target, self._waypoints = None, []
        self._origin, self._origin_t, self._origin_dist = self.pos, self.t_s, self.distance_m
        if home_at_s is not None:
            self.home_at_s = float(home_at_s)
            self.mode = HOME
            self.route = []
            return
        self.mode = TRANSIT
        self.route = [] if aborted else [int(t) for t in route]
        self._retarget()

    def advance(self, until_s: float) -> list[Cleared | Arrived | Inspected]:
        """Move to time ``until_s``; return what happened on the way, in time order.

        An event due at ``until_s`` (as `next_event_s` announced it) is settled now, so
        waking at the announced time always makes progress."""
        events: list[Cleared | Arrived | Inspected] = []
        while self.mode != HOME:
            if self.mode == INSPECTING:
                if not self._end_look(until_s, events):
                    break  # still looking, or waiting for the camera's answer
                continue
            if self.mode == WAITING:
                end = self.wait_until_s if self.wait_until_s is not None else self.t_s
                if end > until_s:
                    break
                self.t_s = max(self.t_s, end)
                self.wait_until_s = None
                self._begin(self.route[0])
                continue
            if self.mode == INJECTING:
                end = self.inject_until_s if self.inject_until_s is not None else self.t_s
                if end > until_s:
                    break
                self.t_s = max(self.t_s, end)
                task = self.route.pop(0)
                events.append(Cleared(task, self.t_s))
                self.inject_until_s = None
                self.mode = TRANSIT
                self._retarget()
                continue
            # Transit: hop over the waypoints reached by ``until_s``, then interpolate. Every
            # position is computed from the current segment's origin and start time, so it
            # does not depend on how often the vehicle was advanced on the way.
            while self._waypoints:
                w = self._waypoints[0]
                seg_m = math.dist(self._origin, w)
                reach = (self._origin_t + seg_m / self.speed_mps if self.current is None
                         else self._pieces[-1][0] if self._pieces else self._origin_t)
                if reach > until_s:
                    break
                self._waypoints.pop(0)
                self._start_segment(w, max(self._origin_t, reach), self._origin_dist + seg_m)
            if self._waypoints:
                self.t_s = until_s
                self.pos, self.distance_m = self._interpolate(until_s)
                break
            self.t_s = max(self.t_s, self._origin_t)
            self._arrive(events)
        self.t_s = max(self.t_s, until_s)
        return events

    # -- internals -------------------------------------------------------------------------

    def _target_pos(self, target: int) -> Point3:
        if target < 0:
            return self.rendezvous
        return tuple(float(c) for c in self.problem.xyz[target])  # type: ignore[return-value]

    def _reach_m(self, task: int) -> float:
        if self._target == task:
            return self._leg_left_m()
        return self.paths(self.pos, self._target_pos(task))[0]

    def _reach_home_m(self) -> float:
        if self._target == -1:
            return self._leg_left_m()
        return self.paths(self.pos, self.rendezvous)[0]

    def _leg_left_m(self) -> float:
        total, prev = 0.0, self.pos
        for w in self._waypoints:
            total += math.dist(prev, w)
            prev = w
        return total

    def _leg_end_s(self) -> float:
        """When the current leg ends (from the segment origin, independent of stepping)."""
        if self.current is not None:
            if not self._waypoints:
                return self._origin_t
            t = self._pieces[-1][0] if self._pieces else self._origin_t
            prev = self._waypoints[0]
            for w in self._waypoints[1:]:
                t = self._segment_end_s(prev, w, t)
                prev = w
            return t
        total, prev = 0.0, self._origin
        for w in self._waypoints:
            total += math.dist(prev, w)
            prev = w
        return self._origin_t + total / self.speed_mps

    def _start_segment(self, origin: Point3, t_s: float, distance_m: float) -> None:
        self._origin, self._origin_t, self._origin_dist = origin, t_s, distance_m
        self.pos, self.distance_m = origin, distance_m
        self._pieces = []
        if self._waypoints:
            self._heading(origin, self._waypoints[0])
            if self.current is not None:
                self._pieces = self._profile(origin, self._waypoints[0], t_s)

    def _interpolate(self, t_s: float) -> tuple[Point3, float]:
        w = self._waypoints[0]
        seg_m = math.dist(self._origin, w)
        if self.current is None:
            run_m = min(seg_m, (t_s - self._origin_t) * self.speed_mps)
        else:
            run_m = min(seg_m, self._run_m(t_s))
        f = run_m / seg_m if seg_m > _EPS else 1.0
        pos = tuple(a + (b - a) * f for a, b in zip(self._origin, w))
        return pos, self._origin_dist + run_m  # type: ignore[return-value]

    def _retarget(self) -> None:
        if self.mode in (HOME, INJECTING, INSPECTING, WAITING):
            return
        target = self.route[0] if self.route else -1
        if target == self._target and self._waypoints:
            return
        self._target = target
        self.mode = TRANSIT if target >= 0 else RETURNING
        _, waypoints = self.paths(self.pos, self._target_pos(target))
        self._waypoints = list(waypoints)
        self._start_segment(self.pos, self.t_s, self.distance_m)

    def _arrive(self, events: list[Cleared | Arrived | Inspected]) -> None:
        target, self._target = self._target, None
        if target is None or target < 0:
            self.mode = HOME
            self.home_at_s = self.t_s
            events.append(Arrived(self.t_s))
        elif self.not_before(target) > self.t_s:
            self.mode = WAITING
            self.wait_until_s = self.not_before(target)
        else:
            self._begin(target)

    def _begin(self, task: int) -> None:
        """Work at the spot reached: look first if its agent knows nothing of it, else inject."""
        if self.needs_look(task):
            self.mode = INSPECTING
            self.inspect_until_s = self.t_s + self.inspect_s
        else:
            self.mode = INJECTING
            self.inject_until_s = self.t_s + float(self.problem.service_s[task])

    def _heading(self, p: Point3, w: Point3) -> None:
        """Yaw (eq. 5) and pitch (eq. 6) of the motion from ``p`` toward ``w``; NED, degrees."""
        dx, dy, dz = (b - a for a, b in zip(p, w))
        if math.hypot(dx, dy, dz) <= _EPS:
            return
        horizontal = math.hypot(dx, dy)
        if horizontal > _EPS:
            self.yaw_deg = math.degrees(math.atan2(dy, dx))
        self.pitch_deg = math.degrees(math.atan2(-dz, horizontal))


def fit_route(vehicle: Vehicle, route: Sequence[int], reserve_s: float,
              protect: Collection[int] = ()) -> list[int]:
    """``route`` with spots dropped until it ends at the rendezvous within the battery.

    Drops the spot whose removal saves the most time per unit of priority (the paper's
    screening idea), never the one being injected, and spots in ``protect`` only once no
    other spot is left to drop.
    """
    route = list(route)
    priority = vehicle.problem.priority
    budget_s = vehicle.battery_left_s() - reserve_s
    while route and not fits(vehicle.time_to_finish_s(route), budget_s):
        base = vehicle.time_to_finish_s(route)
        best, best_score = None, -math.inf
        spare = any(t not in protect and not (i == 0 and vehicle.injecting == t)
                    for i, t in enumerate(route))
        for i, task in enumerate(route):
            if (i == 0 and vehicle.injecting == task) or (spare and task in protect):
                continue
            saved = base - vehicle.time_to_finish_s(route[:i] + route[i + 1:])
            score = saved / max(float(priority[task]), 1e-9)
            if score > best_score:
                best, best_score = i, score
        if best is None:
            break
        route.pop(best)
    return route


def position_along(problem: Problem, v: int, pos: Point3, route: Sequence[int], dt_s: float,
                   first_service_left_s: float = 0.0, t0_s: float = 0.0) -> Point3:
    """Dead reckoning: where vehicle ``v`` is ``dt_s`` after being at ``pos`` (at mission time
    ``t0_s``, which matters only in a tidal current) with ``route`` ahead (straight legs; a
    spot being injected first if ``first_service_left_s`` > 0)."""
    speed = problem.vehicles[v].speed_mps
    if problem.current is not None:
        return _drift_along(problem, speed, pos, route, v, dt_s, first_service_left_s, t0_s)
    t = dt_s - first_service_left_s
    here = np.asarray(pos, dtype=float)
    targets = [problem.xyz[task] for task in route] + [np.asarray(problem.vehicles[v].rendezvous)]
    services = [float(problem.service_s[task]) for task in route] + [math.inf]
    for target, service in zip(targets, services):
        if t <= 0:
            break
        leg = float(np.linalg.norm(target - here))
        if leg / speed >= t:
            here = here + (target - here) * (t * speed / leg)
            t = 0.0
            break
        t -= leg / speed
        here = np.asarray(target, dtype=float)
        t -= service
    return (float(here[0]), float(here[1]), float(here[2]))


def _drift_along(problem: Problem, speed: float, pos: Point3, route: Sequence[int], v: int,
                 dt_s: float, first_service_left_s: float, t0_s: float) -> Point3:
    """`position_along` in a current: each straight leg at its ground speed, piece by piece."""
    now, until = t0_s + first_service_left_s, t0_s + dt_s
    here = tuple(float(c) for c in pos)
    targets = [tuple(float(c) for c in problem.xyz[task]) for task in route]
    services = [float(problem.service_s[task]) for task in route] + [math.inf]
    for target, service in zip([*targets, problem.vehicles[v].rendezvous], services):
        if now >= until:
            break
        try:
            pieces = segment_pieces(problem.current, here, target, speed, now)
        except LegError:
            break  # no headway against the current: it stays where it is
        run, leg = 0.0, math.dist(here, target)
        for duration, length in pieces:
            if now + duration >= until:
                run += length * ((until - now) / duration)
                f = run / leg
                return tuple(a + (b - a) * f for a, b in zip(here, target))  # type: ignore[return-value]
            now, run = now + duration, run + length
        here = tuple(float(c) for c in target)
        now += service
    return here  # type: ignore[return-value]


def fly(problem: Problem, index: int, route: Sequence[int], paths: PathFn | None = None
        ) -> list[Cleared | Arrived]:
    """Fly vehicle ``index`` of ``problem`` (its water: current and land) along ``route``
    (task indices, as planned, whatever water the plan assumed) from its start at mission time
    0 to the rendezvous, without replanning: the events, the `Arrived` one last. The battery
    does not stop it; compare ``Arrived.t_s`` with the battery to see how late it ends."""
    vehicle = Vehicle(problem, index, paths)
    vehicle.set_route(route)
    events: list[Cleared | Arrived] = []
    while not vehicle.done:
        due = vehicle.next_event_s()
        if due is None or not math.isfinite(due):
            break  # a leg the current makes impossible: it never gets there
        events += vehicle.advance(due)
    return events
