"""The centralized online baseline: the fleet's vehicles under one planner that knows at once
everything any of them has seen.

The same simulated vehicles as a mission (`reef_sim.vehicle.SimVehicle` through
`fleet_agent.helms.sim.sim_vehicle`: the same kinematics, camera draws and navigation error,
seeded alike) and no radio: every report of every vehicle reaches the one planner the moment
it is polled (every ``poll_s`` seconds, and at each arrival or end of work). Whenever it learns
something (a look, a sighting, an injection done) it replans every vehicle with
`hfc_core.replan.replan_indexed` from where each believes it is, with the battery each has
left, keeping the spot one is working. It never treats a spot twice: it knows every treatment
at once, and judges a sighting or a spot against the treated ones by
`fleet_agent.association` (navigation error makes two estimates of one aggregation differ).

What it decides is the fleet agent's own decision model with perfect communication: a
predicted spot is planned at its expected value (``p_cots`` x rho, the look plus ``p_cots`` x
t) until a look or a sighting shows it; a vehicle looks before injecting a spot nobody has seen;
finds are planned at their figures; with a search belief (`fleet_agent.search`) the
orbits around positive spots are offered to the planner as spots worth what they are expected
to reveal. Comparing the fleet with it separates the cost of decentralization (the fleet /
this) from the cost of not knowing the reef (this / the clairvoyant plan).

The report is the mission report (`cotsfleet.mission.report.build_report`, mode
``central``) through a `FleetLedger` fed the same events a fleet's telemetry carries, plus
``world``: the world's own tally of what was really treated (`reef_sim.score.world_tally`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import numpy as np

from cotsfleet.mission.report import build_report
from cotsfleet.mission.runner import horizon_of
from fleet_agent.association import (DEFAULT_PARAMS, AssociationParams, Estimate, predicted,
                                     probably_treated, resolve, sighting)
from fleet_agent.helms.sim import sim_vehicle
from fleet_agent.search import BeliefParams, SearchBelief, evaluate, orbit, ring_middle
from fleet_bus.ledger import FleetLedger
from fleet_bus.states import EventKind
from fleet_bus.telemetry import Event, Status, cleared_detail, position_detail
from fleet_bus.vehicle_port import (HOME_TARGET, Arrived, GoTo, Injected, Looked, NavFix,
                                    ReturnHome, Sighted, StationKeep, Work)
from hfc_core.model.feasibility import fits
from hfc_core.model.geometry import distance_matrix
from hfc_core.model.live import IndexedVehicle
from hfc_core.model.paths import as_point3, path_function
from hfc_core.model.problem import Problem, Task
from hfc_core.replan import replan_indexed
from hfc_core.solve import solve
from reef_sim.navigation import NavigationParams
from reef_sim.score import world_tally
from reef_sim.truth import Reef

Point3 = tuple[float, float, float]
UNKNOWN, PRESENT, EMPTY = "unknown", "present", "empty"


@dataclass(frozen=True)
class CentralParams:
    """The one planner's settings (the fleet agent's where they mean the same): ``p_cots``
    the prior a predicted spot holds COTS, iteration budgets, the battery reserve, how often
    vehicles are polled, the association rule, and the search belief (None: no search;
    ``max_searches`` orbits offered at a time)."""

    p_cots: float = 0.75
    plan_iterations: int = 500
    replan_iterations: int = 150
    reserve_s: float = 1.0
    poll_s: float = 5.0
    association: AssociationParams = DEFAULT_PARAMS
    belief: BeliefParams | None = None
    max_searches: int = 3

    def __post_init__(self) -> None:
        if not 0.0 <= self.p_cots <= 1.0:
            raise ValueError(f"p_cots must be in 0..1, got {self.p_cots!r}")
        if not (self.poll_s > 0 and self.reserve_s >= 0):
            raise ValueError("poll_s must be > 0 and reserve_s >= 0")
        if self.plan_iterations < 1 or self.replan_iterations < 0 or self.max_searches < 0:
            raise ValueError("iteration budgets and max_searches must be >= 0 (plan >= 1)")


@dataclass
class Item:
    """A spot the planner may send a vehicle to: a predicted spot, a find, or an orbit around
    a positive spot (``kind``), where it is believed to be (``estimate``) and what it is
    worth and takes in the working problem. ``done``: treated, empty, searched or withdrawn:
    off limits."""

    kind: str
    task_id: int
    estimate: Estimate
    pos: Point3
    priority: float
    service_s: float
    state: str = UNKNOWN
    done: bool = False
    waypoints: tuple[tuple[float, float], ...] = ()  # an orbit's pattern
    centre: int = -1  # an orbit: the item it is around
    # where each vehicle's own camera last saw it, in that vehicle's navigation frame: a
    # vehicle flies to what it saw (its own error cancels), others to the shared estimate
    seen: dict[int, Point3] = field(default_factory=dict)

    def goal_for(self, vehicle: int) -> Point3:
        return self.seen.get(vehicle, self.pos)


class Activity(Enum):
    TRANSIT = "transit"
    LOOKING = "looking"
    INJECTING = "injecting"
    SEARCHING = "searching"  # flying an orbit's pattern
    RETURNING = "returning"
    HOME = "home"


@dataclass
class Seat:
    """One vehicle under the central planner."""

    index: int
    vid: str
    port: Any  # reef_sim.vehicle.SimVehicle
    est: Point3
    sigma_m: float = 0.0
    distance_m: float = 0.0
    route: list[int] = field(default_factory=list)
    activity: Activity = Activity.RETURNING
    commanded: tuple[Activity, int | None, Point3 | None] | None = None
    treated: list[int] = field(default_factory=list)  # task ids
    collected: float = 0.0
    home_at_s: float | None = None
    injecting_since_s: float = 0.0  # when the injection under way was commanded
    track: list[tuple[float, float]] = field(default_factory=list)  # since the last leg end


class Central:
    """The vehicles, the one planner's knowledge, and the loop that joins them."""

    def __init__(self, problem: Problem, reef: Reef, *, seed: int,
                 navigation: NavigationParams | None = None,
                 params: CentralParams = CentralParams()) -> None:
        self.problem, self.reef, self.seed, self.params = problem, reef, seed, params
        self.paths = path_function(problem)
        self.inspect_s = reef.inspect_s
        self.ledger = FleetLedger()
        self.items: list[Item] = []
        # every treatment's estimate, all vehicles, and whether it was of a find
        self.treated_at: list[tuple[Estimate, bool]] = []
        self.counters = {"replans": 0, "finds": 0, "finds_on_land": 0, "sightings_treated": 0,
                         "sightings_ambiguous": 0, "skipped_treated": 0, "searches_flown": 0}
        self._next_id = max((t.id for t in problem.tasks), default=-1) + 1
        self._dist: np.ndarray | None = None
        self._dist_n = -1
        self._working: Problem | None = None
        a = params.association
        for t in problem.tasks:
            self.items.append(Item("predicted", t.id, predicted(t.pos, a), t.pos,
                                   params.p_cots * t.priority,
                                   self.inspect_s + params.p_cots * t.service_s))
        self.belief = None
        if params.belief is not None:
            margin = params.belief.reach_m + reef.detect_radius_m
            xy = problem.xyz[:, :2]
            bounds = (float(xy[:, 0].min() - margin), float(xy[:, 0].max() + margin),
                      float(xy[:, 1].min() - margin), float(xy[:, 1].max() + margin))
            self.belief = SearchBelief(params.belief, problem.xyz[: problem.n_tasks], bounds)
        self.seats = []
        for v, spec in enumerate(problem.vehicles):
            port = sim_vehicle(problem, v, seed=seed, reef=reef, t_s=0.0, pos=spec.start,
                               odometer_m=0.0, navigation=navigation)
            self.seats.append(Seat(v, spec.id, port, port.fix().pos))

    # -- the loop -----------------------------------------------------------------------------

    def run(self, horizon_s: float) -> float:
        """Fly the mission to its end (every vehicle home) or ``horizon_s``; the end time."""
        for seat in self.seats:
            self._fix(seat, seat.port.fix())
        self._initial_plan()
        self._command_all(0.0)
        t, stuck = 0.0, 0
        while t < horizon_s and not all(s.activity is Activity.HOME for s in self.seats):
            due = [s.port.next_report_s() for s in self.seats]
            t_next = min([horizon_s, t + self.params.poll_s, *(d for d in due if d is not None)])
            stuck = stuck + 1 if t_next <= t else 0
            if stuck > 10_000:  # a logic bug must fail loudly, never hang a benchmark
                raise RuntimeError(f"the central baseline makes no progress at t={t}")
            t = t_next
            reports = sorted(((r.t_s, s.index, k, r) for s in self.seats
                              for k, r in enumerate(s.port.poll(t))), key=lambda e: e[:3])
            learned = False
            for _, v, _, r in reports:
                learned |= self._report(self.seats[v], r, t)
            if learned:
                self._replan(t)
            self._command_all(t)
        return t

    def _command_all(self, t: float) -> None:
        for seat in self.seats:
            self._command(seat, t)

    # -- what the vehicles report -----------------------------------------------------------

    def _fix(self, seat: Seat, nav: NavFix) -> None:
        seat.est, seat.sigma_m = as_point3(nav.pos), float(nav.sigma_m)
        if self.problem.land is not None:  # a drifted estimate may lie on land (as the agent's)
            seat.est = as_point3(self.problem.land.to_water(seat.est))
        if nav.odometer_m is not None:
            seat.distance_m = float(nav.odometer_m)
        if not seat.track or seat.track[-1] != seat.est[:2]:
            seat.track.append((seat.est[0], seat.est[1]))

    def _report(self, seat: Seat, r: Any, now: float) -> bool:
        """Take one report; True if the planner learned something."""
        if isinstance(r, NavFix):
            self._fix(seat, r)
            return False
        if isinstance(r, Sighted):
            return self._sighted(seat, r)
        if isinstance(r, Arrived):
            return self._arrived(seat, r)
        if isinstance(r, Looked):
            return self._looked(seat, r)
        if isinstance(r, Injected):
            return self._injected(seat, r)
        return False

    def _sweep(self, seat: Seat) -> None:
        """A leg ended: the camera's pass over it, for the search belief."""
        if self.belief is not None and len(seat.track) > 1:
            self.belief.swept(seat.track, self.reef.detect_radius_m, self.reef.p_detect)
        seat.track = [(seat.est[0], seat.est[1])]

    def _sighted(self, seat: Seat, r: Sighted) -> bool:
        a = self.params.association
        seen = sighting(r.pos, seat.sigma_m, a, r.priority)
        candidates = [(i, it.estimate) for i, it in enumerate(self.items)
                      if it.kind != "search" and it.state != EMPTY]
        i, sure = resolve(seen, candidates, a)
        if i is not None:
            it = self.items[i]
            if not sure:
                self.counters["sightings_ambiguous"] += 1  # which spot: a look will tell
                return False
            it.seen[seat.index] = (float(r.pos[0]), float(r.pos[1]), float(r.pos[2]))
            if it.kind == "predicted" and it.state == UNKNOWN and not it.done:
                self._learn_present(i, r.priority, r.service_s)
                return True
            return False  # known already (and if treated, treated)
        if probably_treated(seen, self._treated(finds_only=False), a):
            self.counters["sightings_treated"] += 1
            return False
        pos = (float(r.pos[0]), float(r.pos[1]), float(r.pos[2]))
        land = self.problem.land
        if land is not None and bool(land.inside(np.array([pos]))[0]):
            self.counters["finds_on_land"] += 1  # the estimate fell ashore: nobody could go
            return False
        item = Item("find", self._new_id(), seen, pos, float(r.priority), float(r.service_s),
                    PRESENT, seen={seat.index: pos})
        self.items.append(item)
        self.counters["finds"] += 1
        self.ledger.add_event(Event(r.t_s, seat.vid, EventKind.FOUND, [item.task_id],
                                    detail=f"{position_detail(pos)} rho {r.priority:g}"))
        return True

    def _arrived(self, seat: Seat, r: Arrived) -> bool:
        if r.target == HOME_TARGET:
            if seat.activity is Activity.RETURNING:
                seat.activity, seat.home_at_s = Activity.HOME, r.t_s
                self._sweep(seat)
            return False
        if not seat.route or seat.route[0] != r.target:
            return False  # an arrival the route moved on from
        self._sweep(seat)
        i = r.target
        it = self.items[i]
        if seat.activity is Activity.SEARCHING:  # the orbit is flown
            it.done = True
            self.counters["searches_flown"] += 1
            return self._next(seat)
        if it.done:
            return self._next(seat)
        if it.kind == "search":
            seat.activity = Activity.SEARCHING
            return False
        if it.kind == "predicted" and it.state == UNKNOWN:
            seat.activity = Activity.LOOKING
            return False
        return self._inject_or_skip(seat, i, r.t_s)

    def _treated(self, finds_only: bool) -> list[Estimate]:
        return [e for e, of_find in self.treated_at if of_find or not finds_only]

    def _inject_or_skip(self, seat: Seat, i: int, t_s: float) -> bool:
        it = self.items[i]
        # a predicted spot against treated finds only: the map says predicted spots differ
        treated = self._treated(finds_only=it.kind == "predicted")
        if probably_treated(it.estimate, treated, self.params.association):
            it.done = True  # treated under another name (another vehicle's estimate of it)
            self.counters["skipped_treated"] += 1
            return self._next(seat)
        if not self._fits_here(seat, it.service_s if it.state == PRESENT else 0.0, t_s):
            return self._next(seat)
        seat.activity = Activity.INJECTING
        return False

    def _looked(self, seat: Seat, r: Looked) -> bool:
        if seat.activity is not Activity.LOOKING or not seat.route or seat.route[0] != r.task:
            return False
        it = self.items[r.task]
        if not r.present:
            it.state, it.done = EMPTY, True
            if self.belief is not None:
                self.belief.learn(r.task, False)
            self.ledger.add_event(Event(r.t_s, seat.vid, EventKind.EMPTY, [it.task_id]))
            self._next(seat)
            return True
        if it.state == UNKNOWN:
            self._learn_present(r.task, r.priority, r.service_s)
        self.ledger.add_event(Event(r.t_s, seat.vid, EventKind.INSPECTED, [it.task_id],
                                    detail="present"))
        self._inject_or_skip(seat, r.task, r.t_s)
        return True

    def _injected(self, seat: Seat, r: Injected) -> bool:
        if seat.activity is not Activity.INJECTING or not seat.route or seat.route[0] != r.task:
            return False
        it = self.items[r.task]
        it.done = True
        self.treated_at.append((sighting(seat.est, seat.sigma_m, self.params.association,
                                         r.priority), it.kind == "find"))
        seat.treated.append(it.task_id)
        seat.collected += it.priority
        detail = cleared_detail(r.t_s - seat.injecting_since_s,
                                it.pos if it.kind == "find" else None)
        self.ledger.add_event(Event(r.t_s, seat.vid, EventKind.CLEARED, [it.task_id],
                                    detail=detail))
        self._next(seat)
        return True

    def _learn_present(self, i: int, priority: float, service_s: float) -> None:
        it = self.items[i]
        it.state, it.priority, it.service_s = PRESENT, float(priority), float(service_s)
        if self.belief is not None:
            self.belief.learn(i, True)

    def _next(self, seat: Seat) -> bool:
        seat.route.pop(0)
        seat.activity = Activity.TRANSIT if seat.route else Activity.RETURNING
        return True

    def _fits_here(self, seat: Seat, service_s: float, t_s: float) -> bool:
        spec = self.problem.vehicles[seat.index]
        travel = self.problem.travel
        assert travel is not None
        home_s = service_s + travel.leg_time_s(seat.est, spec.rendezvous, spec.speed_mps,
                                               t_s + service_s)
        return bool(fits(home_s, spec.battery_s - t_s - self.params.reserve_s))

    def _new_id(self) -> int:
        self._next_id += 1
        return self._next_id - 1

    # -- commands -----------------------------------------------------------------------------

    def _command(self, seat: Seat, t: float) -> None:
        act = seat.activity
        head = seat.route[0] if seat.route else None
        goal = None if head is None or act is not Activity.TRANSIT else \
            self.items[head].goal_for(seat.index)
        key = (act, head, goal)
        if act is Activity.HOME or key == seat.commanded:
            return
        seat.commanded = key
        spec = self.problem.vehicles[seat.index]
        if act is Activity.RETURNING or head is None:
            seat.activity = Activity.RETURNING
            seat.commanded = (Activity.RETURNING, None, None)
            seat.port.command(ReturnHome(tuple(self.paths(seat.est, spec.rendezvous)[1])), t)
            return
        it = self.items[head]
        if act is Activity.TRANSIT:
            assert goal is not None
            seat.port.command(GoTo(head, tuple(self.paths(seat.est, goal)[1])), t)
        elif act is Activity.SEARCHING:
            depth = it.pos[2]
            seat.port.command(GoTo(head, tuple((x, y, depth) for x, y in it.waypoints[1:])), t)
        elif act is Activity.LOOKING:
            seat.port.command(StationKeep(Work.LOOK, head, self.inspect_s), t)
        elif act is Activity.INJECTING:
            seat.injecting_since_s = t
            seat.port.command(StationKeep(Work.INJECT, head, it.service_s), t)

    # -- planning -----------------------------------------------------------------------------

    def _working_problem(self) -> Problem:
        sc = self.problem
        tasks = [Task(i, it.pos, it.priority if not it.done else 0.0,
                      it.service_s if not it.done else 0.0) for i, it in enumerate(self.items)]
        if self._dist is None or self._dist_n != len(tasks):
            xyz = np.zeros((len(tasks) + 2 * sc.n_vehicles, 3))
            xyz[: len(tasks)] = [t.pos for t in tasks]
            xyz[len(tasks):] = sc.xyz[sc.n_tasks:]
            self._dist = sc.land.distance_matrix(xyz) if sc.land is not None else \
                distance_matrix(xyz)
            self._dist_n = len(tasks)
        return Problem.build(f"{sc.name}-central", sc.vehicles, tasks,
                             [poly.tolist() for poly in sc.forbidden], dist_m=self._dist,
                             current=sc.current)

    def _initial_plan(self) -> None:
        problem = self._working_problem().with_reserve(self.params.reserve_s)
        result = solve(problem, "best", max_iterations=self.params.plan_iterations,
                       seed=self.seed)
        for seat, route in zip(self.seats, result.plan.routes):
            seat.route = [int(t) for t in route]
            seat.activity = Activity.TRANSIT if seat.route else Activity.RETURNING

    def _offer_searches(self) -> None:
        """Orbits around the positive spots (predicted seen holding COTS, finds), the
        ``max_searches`` expected to reveal the most per second offered at their value, the
        rest at none; one orbit per spot, flown once."""
        if self.belief is None:
            return
        reef, p = self.reef, self.params
        orbit_of = {it.centre: i for i, it in enumerate(self.items) if it.kind == "search"}
        radius = ring_middle(self.belief.params)
        busy = {s.route[0] for s in self.seats if s.route and s.activity is Activity.SEARCHING}
        scored = []
        for c, it in enumerate(list(self.items)):
            if it.kind == "search" or it.state != PRESENT:
                continue
            i = orbit_of.get(c)
            if i is not None and (self.items[i].done or i in busy):
                continue
            option = evaluate(self.belief, orbit(it.pos, radius), speed_mps=self.problem.
                              vehicles[0].speed_mps, detect_radius_m=reef.detect_radius_m,
                              p_detect=reef.p_detect)
            if i is None:
                i = len(self.items)
                self.items.append(Item("search", self._new_id(), it.estimate, it.pos, 0.0, 0.0,
                                       PRESENT, waypoints=option.waypoints, centre=c))
                orbit_of[c] = i
            rate = option.expected_priority / option.time_s if option.time_s > 0 else 0.0
            scored.append((rate, i, option))
        scored.sort(key=lambda e: -e[0])
        for rank, (_, i, option) in enumerate(scored):
            it = self.items[i]
            offered = rank < p.max_searches and option.expected_priority > 0
            it.priority = option.expected_priority if offered else 0.0
            it.service_s = option.time_s if offered else 0.0

    def _replan(self, t: float) -> None:
        self._offer_searches()
        problem = self._working_problem()
        live, cleared = [], {i for i, it in enumerate(self.items) if it.done or (
            it.kind == "search" and it.priority <= 0)}
        working = {s.route[0] for s in self.seats if s.route and s.activity in (
            Activity.LOOKING, Activity.INJECTING, Activity.SEARCHING)}
        for s in self.seats:
            if s.activity is Activity.HOME:
                continue
            locked = (s.route[0],) if s.route and s.route[0] in working and \
                s.activity is not Activity.TRANSIT else ()
            battery = self.problem.vehicles[s.index].battery_s - t - self.params.reserve_s
            live.append(IndexedVehicle(s.index, s.est, max(0.0, battery),
                                       route=tuple(r for r in s.route if r not in cleared
                                                   or r in locked), locked=locked))
        if not live:
            return
        routes = replan_indexed(problem, live, cleared=cleared - working,
                                max_iterations=self.params.replan_iterations, seed=self.seed,
                                now_s=t)
        self.counters["replans"] += 1
        for s in self.seats:
            if s.index not in routes:
                continue
            s.route = [int(r) for r in routes[s.index]]
            if s.activity in (Activity.TRANSIT, Activity.RETURNING):
                s.activity = Activity.TRANSIT if s.route else Activity.RETURNING

    # -- the report ---------------------------------------------------------------------------

    def statuses(self, end_s: float) -> list[Status]:
        out = []
        for s in self.seats:
            spec = self.problem.vehicles[s.index]
            used = s.home_at_s if s.home_at_s is not None else end_s
            state = "home" if s.activity is Activity.HOME else "returning"
            out.append(Status(end_s, s.vid, state, s.est, spec.battery_s - used, 0.0, [],
                              list(s.treated), sum(it.done for it in self.items),
                              round(s.collected, 2), s.distance_m,
                              counters={k: v for k, v in self.counters.items()}
                              if s.index == 0 else {}))
        return out


@dataclass
class CentralResult:
    report: dict[str, Any]
    wall_s: float
    central: Central


def run_central(problem: Problem, reef: Reef, *, seed: int,
                navigation: NavigationParams | None = None,
                params: CentralParams = CentralParams(),
                horizon_s: float | None = None) -> CentralResult:
    """One seeded mission of the centralized online baseline, and its report."""
    wall = time.perf_counter()
    central = Central(problem, reef, seed=seed, navigation=navigation, params=params)
    end = central.run(horizon_s if horizon_s is not None else horizon_of(problem))
    for status in central.statuses(end):
        central.ledger.add_status(status)
    world = world_tally(reef, {s.vid: s.port.treatments for s in central.seats})
    report = build_report(problem, central.ledger, None, [], mode="central", seed=seed,
                          end_s=end, reef=reef,
                          extra={"world": world, "central": dict(central.counters)}).to_dict()
    return CentralResult(report, time.perf_counter() - wall, central)
