"""The simulated vehicle: one AUV's body in the simulated world, behind the vehicle port.

Kinematics (paper eq. 3-7): the AUV keeps its cruise speed |v| through the water
(Assumption 1) along straight segments in 3-D, crabbing into a current so that its track stays
on the segment; each segment is flown piece by piece as `hfc_core.travel.segment_pieces` cuts
it (still water is one piece; a gridded field's pieces; the tide's 60 s steps), so it arrives
exactly when the planner's checker says it does. Yaw and pitch are those of the track (eq. 5-6,
roll neglected by Assumption 2); the odometer sums eq. 7 over the track.

It does what the port's commands say (`fleet_bus.vehicle_port`): fly a `GoTo`'s waypoints,
keep station to look or inject for a duration (or to wait), return home, abort. It reports
when it arrives (`Arrived`), when a look or an injection ends (`Looked` with the camera's
answer, `Injected`), what its camera sees on the way (`Sighted`) and, on every poll, a
navigation fix. States are an explicit machine over `Phase`.

Navigation (`reef_sim.navigation`, optional): without it the vehicle knows exactly where it is.
With it, everything the vehicle reports is in its own navigation estimate, which drifts from
the truth: the fix's position and sigma, a sighting's position (the estimate where the pass
began plus the offset the camera measured), and the waypoints it is sent to are positions in
that frame too: it flies until its *estimate* reads the waypoint, so it really ends off by its
navigation error. The camera works where the vehicle really is (a look sees the predicted
aggregation only within its footprint of the true position, `ReefCamera.look`), and the world
keeps its own books of what each injection really treated (`treatments`), of when its
camera first saw each aggregation (`sighted`) and of where the battery went (`time`, a
`reef_sim.timebook.TimeBook`). A waypoint at the surface (depth within
`SURFACE_M`) gives a GPS fix when the vehicle reaches it (`DeadReckoning.surface_fix`): an
agent whose estimate has grown uncertain sends its vehicle up for one
(`fleet_agent.policies.navigation`).

Pure and exact: `poll` runs to any later time, settling arrivals and work ends at the moment
they happen, so what it reports does not depend on how often it is polled (every position is
computed from the current segment's origin and its precomputed pieces).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from typing import Sequence

from fleet_bus.vehicle_port import (HOME_TARGET, Abort, Arrived, GoTo, HelmCommand, Injected,
                                    Looked, NavFix, Refused, ReturnHome, Sighted, StationKeep,
                                    VehicleReport, Work)
from hfc_core.model.paths import PathFn, as_point3, path_function
from hfc_core.model.problem import Problem
from hfc_core.model.travel import LegError, segment_pieces
from reef_sim.camera import ReefCamera
from reef_sim.navigation import DeadReckoning
from reef_sim.timebook import TimeBook

Point3 = tuple[float, float, float]
_EPS = 1e-9
SURFACE_M = 0.5  # a waypoint this close to the surface puts the GPS antenna out of the water


def at_surface(w: Sequence[float]) -> bool:
    """Is waypoint ``w`` at the surface (its GPS takes a fix there)?"""
    return len(w) > 2 and w[2] >= -SURFACE_M


class Phase(Enum):
    HOLDING = "holding"  # keeping station, nothing under way (before orders, after arriving)
    FLYING = "flying"  # toward the target of a GoTo (or home) through waypoints
    WORKING = "working"  # keeping station to look or inject until the work ends
    HOME = "home"  # recovered: at the rendezvous, or at the surface after an abort


@dataclass
class _Segment:
    """The straight segment under way: its origin, when and at what odometer reading it began,
    and (mission time, metres run) at the end of each piece of constant ground speed."""

    origin: Point3
    t0_s: float
    odometer0_m: float
    pieces: list[tuple[float, float]] = field(default_factory=list)

    @property
    def end_s(self) -> float:
        return self.pieces[-1][0] if self.pieces else self.t0_s

    def run_m(self, t_s: float) -> float:
        """Metres run along the segment at ``t_s`` (piece by piece from its origin)."""
        t0, run0 = self.t0_s, 0.0
        for t1, run1 in self.pieces:
            if t_s < t1:
                return run0 + (run1 - run0) * ((t_s - t0) / (t1 - t0)) if t1 > t0 else run0
            t0, run0 = t1, run1
        return run0


@dataclass(frozen=True)
class Treatment:
    """The world's book of one injection: when it ended, the spot the vehicle was told it was
    (``task``, an index of its agent's working problem), where the vehicle really was, and
    the truth spot that really got treated there (None: nothing within the footprint)."""

    t_s: float
    task: int
    pos: Point3
    spot: int | None


class SimVehicle:
    """A simulated AUV (a `fleet_bus.vehicle_port.VehiclePort`). ``camera``: its camera on
    the hidden reef (dynamic missions), else it sees nothing. ``navigation``: its drifting
    navigation estimate (None: exact)."""

    name = "sim"

    def __init__(self, problem: Problem, index: int, *, camera: ReefCamera | None = None,
                 t_s: float = 0.0, pos: Sequence[float] | None = None,
                 odometer_m: float = 0.0, navigation: DeadReckoning | None = None) -> None:
        spec = problem.vehicles[index]
        self.index = index
        self.speed_mps = spec.speed_mps
        self.current = problem.current
        self.camera = camera
        self.t_s = float(t_s)
        self.pos: Point3 = as_point3(spec.start if pos is None else pos)
        self.odometer_m = float(odometer_m)
        self.yaw_deg = 0.0
        self.pitch_deg = 0.0
        self.phase = Phase.HOLDING
        self.target: int | None = None  # what the flight under way goes to
        self.ahead: tuple[Point3, ...] = ()  # the route after it, as last commanded
        self._waypoints: list[Point3] = []
        self._segment = _Segment(self.pos, self.t_s, self.odometer_m)
        self._work: StationKeep | None = None
        self._work_end_s = math.inf
        self._held: list[VehicleReport] = []  # reported while catching up to a command
        self.navigation = navigation
        self._seg_end: Point3 = self.pos  # where the segment under way really ends
        # `_flight_end_s` of a segment: the flight's waypoints change only with a new segment
        # (a waypoint reached, a new flight, a fix), and the agent asks at every step.
        self._flight_end: tuple[_Segment, float] | None = None
        self._fixed_s = self.t_s  # the last time navigation fixes were taken up to
        self._swept: tuple[Point3, float] = (self.pos, self.odometer_m)  # the camera's last
        self.treatments: list[Treatment] = []
        self.sighted: dict[int, float] = {}  # truth spot -> when the camera first saw it
        self.time = TimeBook(self.t_s)  # where the battery went, by activity

    # -- the port ----------------------------------------------------------------------------

    def command(self, cmd: HelmCommand, t_s: float) -> None:
        if t_s > self.t_s:  # orders for a later time: run there first, keep what happened
            self._run(t_s, self._held)
        if self.phase is Phase.HOME:
            self._held.append(Refused(self.t_s, type(cmd).__name__, "recovered"))
            return
        if isinstance(cmd, GoTo):
            if self.phase is Phase.FLYING and self.target == cmd.target and (
                    not cmd.waypoints or not self._waypoints
                    or as_point3(cmd.waypoints[-1]) == self._waypoints[-1]) \
                    and not self._climbs(cmd.waypoints):
                self.ahead = cmd.ahead  # the same leg: fly on, only the route after it changed
                return
            # the same target somewhere else (its camera saw it there): a new leg
            self.ahead = cmd.ahead
            self._fly_to(cmd.target, cmd.waypoints)
        elif isinstance(cmd, StationKeep):
            self._keep_station(cmd)
        elif isinstance(cmd, Abort) and cmd.surface:
            self.phase, self.target = Phase.HOME, HOME_TARGET
            self.time.enter(self.t_s, "recovered")
            self._held.append(Arrived(self.t_s, HOME_TARGET))
        elif isinstance(cmd, (ReturnHome, Abort)):
            self.ahead = ()
            self._fly_to(HOME_TARGET, cmd.waypoints)

    def _climbs(self, waypoints: Sequence[Sequence[float]]) -> bool:
        """Does a GoTo to the target under way add a climb to the surface on the way (a fix
        its agent asked for, `fleet_agent.policies.navigation`)? Then it is a new leg."""
        def up(ws: Sequence[Sequence[float]]) -> bool:
            return any(at_surface(w) for w in ws[:-1])
        return up(waypoints) and not up(self._waypoints)

    def poll(self, until_s: float) -> list[VehicleReport]:
        out, self._held = self._held, []
        self._run(until_s, out)
        out.append(self.fix())
        return out

    def next_report_s(self) -> float | None:
        if self.phase is Phase.FLYING:
            # A fix under way steers the flight again from the new estimate: the end is known
            # only from there, and the agent hears of the jump in its navigation then.
            fix = math.inf if self.navigation is None else self.navigation.next_fix_s(
                self._fixed_s)
            return max(self.t_s, min(self._flight_end_s(), fix))
        if self.phase is Phase.WORKING:
            return max(self.t_s, self._work_end_s)
        return None

    def close(self) -> None:
        pass  # nothing held outside this object

    # -- what the simulation itself reads ----------------------------------------------------

    def fix(self) -> NavFix:
        """The navigation estimate now (exact without a navigation model)."""
        speed = self.speed_mps if self.phase is Phase.FLYING else 0.0
        nav = self.navigation
        if nav is None:
            return NavFix(self.t_s, self.pos, 0.0, self.yaw_deg, self.pitch_deg, speed,
                          self.odometer_m)
        yaw = self.yaw_deg + nav.heading_deg()  # the compass's bias, within -180..180
        yaw = yaw - 360.0 if yaw > 180.0 else yaw + 360.0 if yaw <= -180.0 else yaw
        return NavFix(self.t_s, self.estimate(), nav.sigma_m(self.pos, self.odometer_m), yaw,
                      self.pitch_deg, speed, self.odometer_m)

    def estimate(self) -> Point3:
        """Where the vehicle believes it is."""
        if self.navigation is None:
            return self.pos
        return self.navigation.estimate(self.pos, self.odometer_m)

    def true_pose(self) -> tuple[Point3, float, float]:
        """Where the vehicle really is (the channel's and the ground station's truth)."""
        return self.pos, self.yaw_deg, self.pitch_deg

    # -- motion ----------------------------------------------------------------------------

    def _run(self, until_s: float, out: list[VehicleReport]) -> None:
        """Run to ``until_s``, reporting arrivals, ends of work and sightings as they happen,
        taking each navigation fix at its time (a flight then steers again from it)."""
        nav = self.navigation
        while nav is not None and (t_fix := nav.next_fix_s(self._fixed_s)) <= until_s:
            self._advance(t_fix, out)
            nav.fix(t_fix, self.pos, self.odometer_m)
            self._fixed_s = t_fix
            if self.phase is Phase.FLYING and self._waypoints:
                self._start_segment(self.pos, self.t_s, self.odometer_m)
        self._advance(until_s, out)

    def _advance(self, until_s: float, out: list[VehicleReport]) -> None:
        while True:
            if self.phase is Phase.FLYING:
                if not self._fly(until_s, out):
                    break
            elif self.phase is Phase.WORKING and self._work_end_s <= until_s:
                self.t_s = max(self.t_s, self._work_end_s)
                done = self._work_done()
                out.append(done)
                self.time.enter(self.t_s, "holding", ended_as=None if not isinstance(
                    done, Looked) else "look_cots" if done.present else "look_empty")
                self.phase, self._work = Phase.HOLDING, None
            else:
                break
        self.t_s = max(self.t_s, until_s)
        out += self._sightings(self.t_s)  # the camera is always on, holding station too

    def _fly(self, until_s: float, out: list[VehicleReport]) -> bool:
        """Fly toward the target until ``until_s``; True once arrived (reported)."""
        seen: list[VehicleReport] = []  # sightings at the waypoint just reached
        while self._waypoints:
            reach_s = self._segment.end_s
            out += seen
            if reach_s > until_s:
                self.t_s = max(self.t_s, until_s)
                self._move_along(until_s)
                return False
            self._waypoints.pop(0)
            w = self._seg_end
            seg_m = math.dist(self._segment.origin, w)
            self.t_s = max(self.t_s, reach_s)
            odometer = self._segment.odometer0_m + seg_m
            if self._fixes_at(w):
                assert self.navigation is not None
                self.navigation.surface_fix(self.t_s, w, odometer)  # steers on from the fix
            self._start_segment(w, self.t_s, odometer)
            seen = self._sightings(self.t_s)
        assert self.target is not None
        out.append(Arrived(self.t_s, self.target))  # then what the camera saw there
        out += seen
        self.phase = Phase.HOME if self.target == HOME_TARGET else Phase.HOLDING
        self.time.enter(self.t_s, "recovered" if self.phase is Phase.HOME else "holding")
        return True

    def _fly_to(self, target: int, waypoints: Sequence[Sequence[float]]) -> None:
        self.phase, self.target, self._work = Phase.FLYING, target, None
        self.time.enter(self.t_s, "homing" if target == HOME_TARGET else "transit")
        self._waypoints = [as_point3(w) for w in waypoints] or [self.estimate()]
        self._start_segment(self.pos, self.t_s, self.odometer_m)

    def _start_segment(self, origin: Point3, t_s: float, odometer_m: float) -> None:
        self.pos, self.odometer_m = origin, odometer_m
        seg = self._segment = _Segment(origin, t_s, odometer_m)
        if not self._waypoints:
            return
        end = self._seg_end = self._true_end(self._waypoints[0], origin, odometer_m)
        self._heading(origin, end)
        try:
            pieces = segment_pieces(self.current, origin, end, self.speed_mps, t_s)
        except LegError:
            seg.pieces = [(math.inf, 0.0)]  # no headway against the current: never arrives
            return
        t, run = t_s, 0.0
        for duration, length in pieces:
            t, run = t + duration, run + length
            seg.pieces.append((t, run))

    def _true_end(self, target: Point3, origin: Point3, odometer_m: float) -> Point3:
        """Where a straight run from ``origin`` really ends when the vehicle is sent to
        ``target`` (a position in its navigation frame)."""
        if self.navigation is None:
            return target
        return self.navigation.to_true(target, origin, odometer_m)

    def _move_along(self, t_s: float) -> None:
        w, seg = self._seg_end, self._segment
        seg_m = math.dist(seg.origin, w)
        run_m = min(seg_m, seg.run_m(t_s))
        f = run_m / seg_m if seg_m > _EPS else 1.0
        self.pos = as_point3(a + (b - a) * f for a, b in zip(seg.origin, w))
        self.odometer_m = seg.odometer0_m + run_m

    def _flight_end_s(self) -> float:
        """When the flight under way ends, or first reaches the surface, whose fix steers the
        rest anew (from the segment's origin: independent of polling; kept per segment)."""
        cached = self._flight_end
        if cached is not None and cached[0] is self._segment:
            return cached[1]
        t = self._sum_flight_s()
        self._flight_end = (self._segment, t)
        return t

    def _sum_flight_s(self) -> float:
        t = self._segment.end_s
        prev = self._seg_end if self._waypoints else self.pos
        odometer = self._segment.odometer0_m + math.dist(self._segment.origin, prev)
        for target in self._waypoints[1:]:
            if self._fixes_at(prev):
                return t  # the end is known only from the fix there
            w = self._true_end(target, prev, odometer)
            try:
                t += sum(d for d, _ in segment_pieces(self.current, prev, w, self.speed_mps, t))
            except LegError:
                return math.inf
            odometer += math.dist(prev, w)
            prev = w
        return t

    def _fixes_at(self, w: Point3) -> bool:
        """Does reaching waypoint ``w`` give a navigation fix (a drifting estimate, at the
        surface)?"""
        return self.navigation is not None and at_surface(w)

    def _heading(self, p: Point3, w: Point3) -> None:
        """Yaw (eq. 5) and pitch (eq. 6) of the motion from ``p`` toward ``w``, degrees."""
        dx, dy, dz = (b - a for a, b in zip(p, w))
        if math.hypot(dx, dy, dz) <= _EPS:
            return
        horizontal = math.hypot(dx, dy)
        if horizontal > _EPS:
            self.yaw_deg = math.degrees(math.atan2(dy, dx))
        self.pitch_deg = math.degrees(math.atan2(-dz, horizontal))

    # -- station keeping and the camera ----------------------------------------------------

    def _keep_station(self, cmd: StationKeep) -> None:
        self._waypoints, self.target, self._flight_end = [], None, None
        if cmd.work is Work.WAIT:
            self.phase, self._work = Phase.HOLDING, None
            self.time.enter(self.t_s, "holding")
            return
        if cmd.work is Work.LOOK and self.camera is None:
            self.phase = Phase.HOLDING
            self.time.enter(self.t_s, "holding")
            self._held.append(Refused(self.t_s, "StationKeep", "no camera to look with"))
            return
        self.phase, self._work = Phase.WORKING, cmd
        # a look is booked by what it found when it ends (`_advance`); cut short, as empty
        self.time.enter(self.t_s, "injecting" if cmd.work is Work.INJECT else "look_empty")
        self._work_end_s = self.t_s + max(0.0, float(cmd.duration_s))

    def _work_done(self) -> VehicleReport:
        work = self._work
        assert work is not None
        if work.work is Work.LOOK:
            assert self.camera is not None
            i = self.camera.seen_by_look(work.task, self.pos)
            if i is None:
                return Looked(self.t_s, work.task, False, 0.0, 0.0, None)
            s = self.camera.reef.spots[i]
            return Looked(self.t_s, work.task, True, s.priority, s.service_s, self._measured(i))
        spot = None if self.camera is None else self.camera.treated(work.task, self.pos)
        self.treatments.append(Treatment(self.t_s, work.task, self.pos, spot))
        if spot is None:
            return Injected(self.t_s, work.task)
        assert self.camera is not None  # a treated spot needs a camera to see it
        return Injected(self.t_s, work.task, self._measured(spot),
                        float(self.camera.reef.spots[spot].priority))

    def _measured(self, i: int) -> Point3:
        """Where the camera, keeping station here, measures truth spot ``i`` (a look's or an
        injection's aggregation), in the vehicle's frame: its truth moved by the navigation
        error here and the camera's own (keyed as pass 0 of that spot: sweeps count their
        passes from 1, so a look and the injection after it measure alike)."""
        assert self.camera is not None
        truth = self.camera.reef.spots[i].pos
        if self.navigation is None:
            return truth
        ex, ey = self.navigation.error(self.pos, self.odometer_m)
        cx, cy = self.navigation.camera_error(i, 0)
        return (truth[0] + ex + cx, truth[1] + ey + cy, truth[2])

    def _sightings(self, t_s: float) -> list[VehicleReport]:
        if self.camera is None:
            return []
        (a, odometer_a), self._swept = self._swept, (self.pos, self.odometer_m)
        seen = self.camera.sweep(self.pos)
        for s in seen:
            self.sighted.setdefault(s.spot, t_s)
        nav = self.navigation
        if nav is None:
            return [Sighted(t_s, s.pos, s.priority, s.service_s) for s in seen]
        out: list[VehicleReport] = []
        for s in seen:
            # The estimate where the pass began, plus the offset the camera measured: the
            # aggregation moved by the navigation error there, and the camera's own error.
            at = s.at if s.at is not None else self.pos
            ex, ey = nav.error(at, odometer_a + math.dist(a, at))
            cx, cy = nav.camera_error(s.spot, s.pass_no)
            pos = (s.pos[0] + ex + cx, s.pos[1] + ey + cy, s.pos[2])
            out.append(Sighted(t_s, pos, s.priority, s.service_s))
        return out


def fly(problem: Problem, index: int, route: Sequence[int], paths: PathFn | None = None
        ) -> list[Injected | Arrived]:
    """Replay a plan: fly vehicle ``index`` of ``problem`` (its water: current and land) along
    ``route`` (task indices, as planned, whatever water the plan assumed) from its start at
    mission time 0 to the rendezvous, injecting each spot for its time, without replanning:
    the `Injected` reports, then the `Arrived` home one. The battery does not stop it; compare
    the arrival's time with the battery to see how late it ends."""
    paths = paths or path_function(problem)
    vehicle = SimVehicle(problem, index)
    rendezvous = problem.vehicles[index].rendezvous
    todo = [int(t) for t in route]
    events: list[Injected | Arrived] = []

    def onward() -> None:
        goal = as_point3(problem.xyz[todo[0]]) if todo else rendezvous
        waypoints = tuple(paths(vehicle.pos, goal)[1])
        vehicle.command(GoTo(todo[0], waypoints) if todo else ReturnHome(waypoints),
                        vehicle.t_s)

    onward()
    while (due := vehicle.next_report_s()) is not None and math.isfinite(due):
        for r in vehicle.poll(due):
            if isinstance(r, Arrived) and r.target == HOME_TARGET:
                events.append(r)
                return events
            if isinstance(r, Arrived):
                vehicle.command(StationKeep(Work.INJECT, r.target,
                                            float(problem.service_s[r.target])), r.t_s)
            elif isinstance(r, Injected):
                events.append(r)
                todo.pop(0)
                onward()
    return events  # a leg the current makes impossible: it never gets there
