"""The problem model: vehicles, COTS spots (tasks) and travel times (paper eq. 2, 7-8).

A `Problem` is immutable. Tasks are addressed internally by their index ``0..n-1`` in
``problem.tasks``; scenario task ids (any ints) appear only at the edges (I/O, wire, reports).

Node numbering of the distance matrix ``dist_m`` (shape ``(n + 2k, n + 2k)``):
``0..n-1`` are tasks, ``n + 2*v`` is vehicle ``v``'s start, ``n + 2*v + 1`` its rendezvous.
Travel time between two nodes for vehicle ``v`` is ``travel_s[v][a, b]``: in still water
``dist_m[a, b] / vehicles[v].speed_mps`` (eq. 7-8); with a ``current`` the time through the
moving water (`hfc_core.model.travel`: asymmetric; for a tidal current, the longest the leg can take
during the mission). With forbidden polygons the matrix holds shortest paths around land
(see `hfc_core.model.geometry`), and ``Problem.land`` gives paths and distances from any position.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Sequence

import numpy as np

from hfc_core.model.current import CurrentField
from hfc_core.model.errors import Point3, ScenarioError, finite, point
from hfc_core.model.geometry import LandMap, distance_matrix
from hfc_core.model.travel import IMPOSSIBLE_S, LegError, Travel


@dataclass(frozen=True)
class Vehicle:
    """One AUV: start station, rendezvous, battery time budget and cruise speed."""

    id: str
    start: Point3
    rendezvous: Point3
    battery_s: float
    speed_mps: float

    def __post_init__(self) -> None:
        if not isinstance(self.id, str) or not self.id:
            raise ScenarioError(f"vehicle id must be a non-empty string, got {self.id!r}")
        object.__setattr__(self, "start", point(self.start, f"vehicle {self.id}: start"))
        object.__setattr__(
            self, "rendezvous", point(self.rendezvous, f"vehicle {self.id}: rendezvous")
        )
        battery = finite(self.battery_s, f"vehicle {self.id}: battery_s")
        speed = finite(self.speed_mps, f"vehicle {self.id}: speed_mps")
        if battery <= 0:
            raise ScenarioError(f"vehicle {self.id}: battery_s must be positive, got {battery}")
        if speed <= 0:
            raise ScenarioError(f"vehicle {self.id}: speed_mps must be positive, got {speed}")
        object.__setattr__(self, "battery_s", battery)
        object.__setattr__(self, "speed_mps", speed)


@dataclass(frozen=True)
class Task:
    """One COTS spot to inject (eq. 2): position, priority rho and injection time t."""

    id: int
    pos: Point3
    priority: float
    service_s: float

    def __post_init__(self) -> None:
        if isinstance(self.id, bool) or not isinstance(self.id, int):
            raise ScenarioError(f"task id must be an integer, got {self.id!r}")
        object.__setattr__(self, "pos", point(self.pos, f"task {self.id}: pos"))
        priority = finite(self.priority, f"task {self.id}: priority")
        service = finite(self.service_s, f"task {self.id}: service_s")
        if priority < 0:
            raise ScenarioError(f"task {self.id}: priority must be >= 0, got {priority}")
        if service < 0:
            raise ScenarioError(f"task {self.id}: service_s must be >= 0, got {service}")
        object.__setattr__(self, "priority", priority)
        object.__setattr__(self, "service_s", service)


@dataclass(frozen=True, eq=False)
class Problem:
    """A team orienteering problem with service times: the whole planning input.

    Build with `Problem.build`, which validates ids and computes the distance matrix.
    """

    name: str
    vehicles: tuple[Vehicle, ...]
    tasks: tuple[Task, ...]
    forbidden: tuple[np.ndarray, ...]
    dist_m: np.ndarray
    xyz: np.ndarray = field(repr=False)  # (n + 2k, 3) node coordinates
    priority: np.ndarray = field(repr=False)  # (n,)
    service_s: np.ndarray = field(repr=False)  # (n,)
    task_index: dict[int, int] = field(repr=False)
    vehicle_index: dict[str, int] = field(repr=False)
    # Shortest paths around ``forbidden`` (None without land): distances from positions off
    # the nodes (replanning mid-route) and the waypoint path of every leg.
    land: LandMap | None = field(default=None, repr=False)
    # The water's current (None: still water) and what it makes of travel: the planning
    # times per vehicle (one shared array per distinct speed), times from any position.
    current: CurrentField | None = field(default=None, repr=False)
    travel: Travel | None = field(default=None, repr=False)
    travel_s: tuple[np.ndarray, ...] = field(default=(), repr=False)

    @staticmethod
    def build(
        name: str,
        vehicles: Sequence[Vehicle],
        tasks: Sequence[Task],
        forbidden: Sequence[Sequence[Sequence[float]]] = (),
        dist_m: np.ndarray | None = None,
        current: CurrentField | None = None,
    ) -> "Problem":
        """Validate and assemble a problem; ``dist_m`` defaults to the metric of
        `hfc_core.model.geometry.distance_matrix` (Euclidean, or around ``forbidden`` land);
        ``current`` (`hfc_core.model.current`) makes travel times those through moving water."""
        vehicles = tuple(vehicles)
        tasks = tuple(tasks)
        if not vehicles:
            raise ScenarioError("scenario has no vehicles")
        vehicle_index: dict[str, int] = {}
        for i, v in enumerate(vehicles):
            if v.id in vehicle_index:
                raise ScenarioError(f"duplicate vehicle id {v.id!r}")
            vehicle_index[v.id] = i
        task_index: dict[int, int] = {}
        for i, t in enumerate(tasks):
            if t.id in task_index:
                raise ScenarioError(f"duplicate task id {t.id}")
            task_index[t.id] = i
        polygons = tuple(_polygon(p, i) for i, p in enumerate(forbidden))
        n, k = len(tasks), len(vehicles)
        xyz = np.zeros((n + 2 * k, 3))
        for i, t in enumerate(tasks):
            xyz[i] = t.pos
        for v_idx, v in enumerate(vehicles):
            xyz[n + 2 * v_idx] = v.start
            xyz[n + 2 * v_idx + 1] = v.rendezvous
        land = None
        if polygons:
            land = LandMap(polygons)
            _require_water(land, xyz, tasks, vehicles)
        if dist_m is None:
            try:
                dist_m = land.distance_matrix(xyz) if land is not None else distance_matrix(xyz)
            except ValueError as err:  # e.g. a point walled in by land
                raise ScenarioError(f"forbidden: {err}") from None
        dist_m = np.asarray(dist_m, dtype=float)
        if dist_m.shape != (n + 2 * k, n + 2 * k):
            raise ScenarioError(
                f"distance matrix has shape {dist_m.shape}, need {(n + 2 * k,) * 2}")
        dist_m.setflags(write=False)
        xyz.setflags(write=False)
        priority = np.array([t.priority for t in tasks], dtype=float)
        service = np.array([t.service_s for t in tasks], dtype=float)
        priority.setflags(write=False)
        service.setflags(write=False)
        travel = Travel(current, (0.0, max(v.battery_s for v in vehicles)), land)
        by_speed: dict[float, np.ndarray] = {}
        for v in vehicles:
            if v.speed_mps not in by_speed:
                by_speed[v.speed_mps] = travel.matrix(xyz, dist_m, v.speed_mps)
                by_speed[v.speed_mps].setflags(write=False)
        travel_s = tuple(by_speed[v.speed_mps] for v in vehicles)
        if current is not None:
            _require_way_home(travel, xyz, n, vehicles, travel_s)
        return Problem(
            name=name,
            vehicles=vehicles,
            tasks=tasks,
            forbidden=polygons,
            dist_m=dist_m,
            xyz=xyz,
            priority=priority,
            service_s=service,
            task_index=task_index,
            vehicle_index=vehicle_index,
            land=land,
            current=current,
            travel=travel,
            travel_s=travel_s,
        )

    @property
    def n_tasks(self) -> int:
        return len(self.tasks)

    @property
    def n_vehicles(self) -> int:
        return len(self.vehicles)

    def start_node(self, v: int) -> int:
        return self.n_tasks + 2 * v

    def end_node(self, v: int) -> int:
        return self.n_tasks + 2 * v + 1

    def route_time_s(self, v: int, route: Sequence[int]) -> float:
        """Mission time T^M of vehicle ``v`` on ``route`` (task indices) as flown from mission
        time 0: travel start -> tasks -> rendezvous at the vehicle's speed (through the
        current, if any), plus each task's service once; ``inf`` if a leg is impossible."""
        nodes = [self.start_node(v), *route, self.end_node(v)]
        if self.current is not None and not self.current.steady:
            return self._flown_time_s(v, nodes)
        travel = float(self.travel_s[v][nodes[:-1], nodes[1:]].sum())
        service = float(self.service_s[list(route)].sum()) if len(route) else 0.0
        return travel + service

    def _flown_time_s(self, v: int, nodes: Sequence[int]) -> float:
        """Time-dependent current: each leg timed from the moment it starts."""
        assert self.travel is not None
        speed, t = self.vehicles[v].speed_mps, 0.0
        try:
            for a, b in zip(nodes[:-1], nodes[1:]):
                t += self.travel.leg_time_s(self.xyz[a], self.xyz[b], speed, t)
                if b < self.n_tasks:
                    t += float(self.service_s[b])
        except LegError:
            return math.inf
        return t

    @property
    def symmetric(self) -> bool:
        """Do all planning times read the same both ways (no current)?"""
        return self.current is None

    def route_priority(self, route: Sequence[int]) -> float:
        return float(self.priority[list(route)].sum()) if len(route) else 0.0

    def with_reserve(self, reserve_s: float) -> "Problem":
        """This problem with ``reserve_s`` kept back from every vehicle's battery: what a
        fleet that must reach the rendezvous with that margin plans for. The matrices are
        shared (a smaller budget stays inside the current's time horizon)."""
        reserve = finite(reserve_s, "reserve_s")
        if reserve < 0:
            raise ScenarioError(f"reserve_s must be >= 0, got {reserve}")
        if reserve == 0:
            return self
        short = [v.id for v in self.vehicles if v.battery_s <= reserve]
        if short:
            raise ScenarioError(f"reserve_s {reserve} leaves no battery to {', '.join(short)}")
        vehicles = tuple(replace(v, battery_s=v.battery_s - reserve) for v in self.vehicles)
        return replace(self, vehicles=vehicles)


def _require_way_home(travel: Travel, xyz: np.ndarray, n: int, vehicles: Sequence[Vehicle],
                      travel_s: Sequence[np.ndarray]) -> None:
    """Against a strong current a vehicle may not even reach its rendezvous: say why."""
    for v, vehicle in enumerate(vehicles):
        s, e = n + 2 * v, n + 2 * v + 1
        if travel_s[v][s, e] < IMPOSSIBLE_S:
            continue
        try:  # the planning bound is infinite: find the moment and the reason
            for t in np.arange(travel.window_s[0], travel.window_s[1] + 60.0, 60.0):
                travel.leg_time_s(xyz[s], xyz[e], vehicle.speed_mps, float(t))
        except LegError as err:
            raise ScenarioError(f"vehicle {vehicle.id}: cannot go from its start to its "
                                f"rendezvous: {err}") from None
        raise ScenarioError(f"vehicle {vehicle.id}: cannot go from its start to its rendezvous "
                            "against the current")


def _require_water(
    land: LandMap, xyz: np.ndarray, tasks: Sequence[Task], vehicles: Sequence[Vehicle]
) -> None:
    inside = land.inside(xyz)
    n = len(tasks)
    for i in np.flatnonzero(inside).tolist():
        if i < n:
            raise ScenarioError(f"task {tasks[i].id}: pos {tasks[i].pos} is on land (forbidden)")
        v = vehicles[(i - n) // 2]
        what = "start" if (i - n) % 2 == 0 else "rendezvous"
        raise ScenarioError(f"vehicle {v.id}: {what} {getattr(v, what)} is on land (forbidden)")


def _polygon(points: Sequence[Sequence[float]], i: int) -> np.ndarray:
    try:
        arr = np.asarray(points, dtype=float)
    except (TypeError, ValueError):
        raise ScenarioError(f"forbidden[{i}]: expected [[x, y], ...]") from None
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 3:
        raise ScenarioError(f"forbidden[{i}]: a polygon needs at least 3 [x, y] vertices")
    if not np.all(np.isfinite(arr)):
        raise ScenarioError(f"forbidden[{i}]: coordinates must be finite")
    arr.setflags(write=False)
    return arr
