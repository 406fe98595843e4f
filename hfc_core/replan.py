"""`replan`: new routes for the live vehicles, from where they are, with what battery they have.

The agents call this mid-mission: after a vehicle is lost (survivors share its spots), or for
the online cooperation operator (one vehicle with spare battery inserts free spots into its own
route: call it with that vehicle alone and mark the others' spots ``cleared`` or ``held``).

How the inputs become a `best` search (`hfc_core.engines.best`):
- each vehicle starts at its position (or, with ``locked`` spots, at the last of them: the
  locked chain is prepended unchanged and its time taken off the battery);
- spots ``cleared``, locked by a vehicle, or held by another live vehicle are off limits;
- travel from a position uses `Problem.land` when the scenario has land;
- stability: the current routes (minus what is now off limits, cut to fit the battery, topped
  up with free spots that fit) are the starting point, and they are returned unless the search
  beats them by more than ``stability`` times the mean priority. Within the search, treating a
  spot from another live vehicle's current route is worth that much less, so spots change
  vehicle only for a real gain. Reordering happens only when it shortens a route, which leaves
  a plan from `best` (already 2-opt/or-opt optimal) as it is.

With ``max_iterations`` and no time limit the result is a pure function of the inputs (the
order of ``cleared`` and ``held`` does not matter): agents on different machines agree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Collection, Mapping, Sequence

import numpy as np
from scipy.spatial.distance import cdist

from hfc_core.engines.best.construct import construct, screen
from hfc_core.engines.best.engine import SearchParams, local_search, search, shorten
from hfc_core.engines.best.insert import fill
from hfc_core.engines.best.instance import Instance, clocked
from hfc_core.engines.best.state import State
from hfc_core.model.current import TidalCurrent
from hfc_core.model.errors import ScenarioError
from hfc_core.model.problem import Problem
from hfc_core.model.tide_clock import TideClock
from hfc_core.stop import Stop

DEFAULT_ITERATIONS = 60
DEFAULT_STABILITY = 0.1


@dataclass(frozen=True)
class LiveVehicle:
    id: str  # scenario vehicle id
    pos: tuple[float, float, float]  # where it is now
    battery_s: float  # battery time left
    speed_mps: float | None = None  # None = the scenario vehicle's speed
    route: tuple[int, ...] = ()  # its current planned route (scenario task ids), for stability
    locked: tuple[int, ...] = ()  # tasks it must keep at the head of its route, in order


def replan(
    problem: Problem,
    vehicles: Sequence[LiveVehicle],
    *,
    cleared: Collection[int] = (),
    held: Mapping[int, str] = {},  # noqa: B006 - read only
    max_iterations: int | None = None,
    time_limit_s: float | None = None,
    seed: int = 0,
    stability: float = DEFAULT_STABILITY,
    now_s: float | None = None,
) -> dict[str, list[int]]:
    """Vehicle id -> new route (scenario task ids; the rendezvous follows) for ``vehicles``.

    Vehicles not passed are gone: their spots are free unless cleared. A spot held by one of
    ``vehicles`` goes to that vehicle or to none; a spot held by a gone vehicle is free. No
    route exceeds its vehicle's ``battery_s`` from ``pos``. Locked spots that are cleared or
    held by another live vehicle are dropped. If even the locked spots and the way to the
    rendezvous do not fit the battery, that vehicle gets its locked spots only (it cannot do
    better). Without a budget, ``DEFAULT_ITERATIONS`` iterations are run.

    ``now_s``: the mission time the vehicles are at; it matters only in a tidal current, where
    routes are then timed as flown from now (`hfc_core.model.tide_clock`). Without it a tide is
    planned with the longest leg times over the whole mission: safe, but it leaves battery
    unused.
    """
    if not stability >= 0:
        raise ValueError(f"stability must be >= 0, got {stability}")
    if max_iterations is None and time_limit_s is None:
        max_iterations = DEFAULT_ITERATIONS
    setup = _Setup(problem, vehicles, cleared, held, stability, now_s)
    inst = setup.instance()
    rng = np.random.default_rng(seed)
    stop = Stop(time_limit_s=time_limit_s, max_iterations=max_iterations)
    warm = setup.warm_start(inst, rng)
    tie = inst.tie_weight()
    start = warm
    if not any(v.route for v in vehicles):  # nothing to keep: build from scratch too
        scratch = construct(inst, rng)
        start = scratch if scratch.objective(tie) > warm.objective(tie) + 1e-12 else warm
    best, _ = search(start, rng, stop, SearchParams(restart=100))
    if best.objective(tie) <= warm.objective(tie) + setup.penalty:
        best = warm
    out = {}
    for v, live in enumerate(setup.vehicles):
        tail = best.routes[v] if setup.budget_s[v] > 0 else []
        out[live.id] = [problem.tasks[u].id for u in (*setup.locked[v], *tail)]
    return out


class _Setup:
    """Validated inputs, in task indices, and the instance built from them."""

    def __init__(
        self,
        problem: Problem,
        vehicles: Sequence[LiveVehicle],
        cleared: Collection[int],
        held: Mapping[int, str],
        stability: float,
        now_s: float | None = None,
    ) -> None:
        self.problem = problem
        if now_s is not None and not (math.isfinite(now_s) and now_s >= 0):
            raise ValueError(f"now_s must be a mission time >= 0, got {now_s}")
        # A tide is timed as flown only when we know when "now" is (and the problem is small
        # enough to clock); else its legs are planned with their longest times (a bound).
        self.now_s = now_s if now_s is not None and clocked(problem) else None
        self.vehicles = list(vehicles)
        ids = [v.id for v in self.vehicles]
        for vid in ids:
            if vid not in problem.vehicle_index:
                raise ScenarioError(f"unknown vehicle {vid!r}")
        if len(set(ids)) != len(ids):
            raise ScenarioError("a vehicle is listed twice")
        live = {vid: i for i, vid in enumerate(ids)}
        n = problem.n_tasks
        self.cleared = np.zeros(n, dtype=bool)
        self.cleared[[self._index(t) for t in cleared]] = True
        # holder[u]: index into vehicles of the live vehicle holding u, -1 if none is.
        self.holder = np.full(n, -1, dtype=np.int64)
        for t, vid in held.items():
            if vid in live:
                self.holder[self._index(t)] = live[vid]
        self.locked: list[list[int]] = []
        taken = np.zeros(n, dtype=bool)
        for i, v in enumerate(self.vehicles):
            chain = []
            for t in v.locked:
                u = self._index(t)
                if not (self.cleared[u] or taken[u] or self.holder[u] not in (-1, i)):
                    chain.append(u)
                    taken[u] = True
            self.locked.append(chain)
        self.locked_mask = taken
        # What moving one spot between vehicles (or changing the plan at all) must gain.
        self.penalty = stability * float(problem.priority.mean()) if n else 0.0

    def _index(self, task_id: int) -> int:
        try:
            return self.problem.task_index[task_id]
        except (KeyError, TypeError):
            raise ScenarioError(f"unknown task {task_id!r}") from None

    def instance(self) -> Instance:
        p, k, n = self.problem, len(self.vehicles), self.problem.n_tasks
        # Nodes: tasks, then per live vehicle its position and its rendezvous.
        dist = np.empty((n + 2 * k, n + 2 * k))
        dist[:n, :n] = p.dist_m[:n, :n]
        ends = [p.end_node(p.vehicle_index[v.id]) for v in self.vehicles]
        pos = np.array([v.pos for v in self.vehicles], dtype=float).reshape(k, 3)
        if p.land is not None:
            p.land.require_water(pos, "vehicle position")
        targets = np.vstack([p.xyz[:n], p.xyz[ends]])
        from_pos = np.array([self._from(pos[i], targets) for i in range(k)]).reshape(k, n + k)
        pos_pos = cdist(pos, pos)  # never travelled: no vehicle visits another's position
        for i in range(k):
            s, e = n + 2 * i, n + 2 * i + 1
            dist[s, :n] = dist[:n, s] = from_pos[i, :n]
            dist[e, :n] = dist[:n, e] = p.dist_m[ends[i], :n]
            for j in range(k):
                dist[s, n + 2 * j] = pos_pos[i, j]
                dist[s, n + 2 * j + 1] = dist[n + 2 * j + 1, s] = from_pos[i, n + j]
                dist[e, n + 2 * j + 1] = p.dist_m[ends[i], ends[j]]
        speed = np.array([v.speed_mps or p.vehicles[p.vehicle_index[v.id]].speed_mps
                          for v in self.vehicles], dtype=float)
        if np.any(speed <= 0):
            raise ScenarioError("a live vehicle has a non-positive speed")
        by_speed: dict[float, np.ndarray] = {}
        for s in speed:
            if float(s) not in by_speed:
                by_speed[float(s)] = self._times(dist, from_pos, pos, ends, float(s))
        travel = tuple(by_speed[float(s)] for s in speed)
        start = np.array([self.locked[i][-1] if self.locked[i] else n + 2 * i for i in range(k)])
        clock = self._clock(pos, ends, speed)
        self.budget_s = np.array([v.battery_s - self._locked_time(travel[i], i, clock)
                                  for i, v in enumerate(self.vehicles)], dtype=float)
        if clock is not None:  # each leaves its last locked spot when the chain is done
            assert self.now_s is not None
            clock.start_s = [self.now_s + float(v.battery_s - b)
                             for v, b in zip(self.vehicles, self.budget_s)]
        free = ~(self.cleared | self.locked_mask)
        allowed = np.repeat(free[None, :], k, axis=0)
        held_by = np.flatnonzero(self.holder >= 0)
        allowed[:, held_by] = False
        allowed[self.holder[held_by], held_by] = free[held_by]
        allowed[self.budget_s <= 0] = False
        value = np.broadcast_to(p.priority, (k, n)).copy()
        home = self._home()
        moved = (home[None, :] >= 0) & (home[None, :] != np.arange(k)[:, None])
        value[moved] -= self.penalty
        return Instance(
            dist_m=dist,
            travel_s=travel,
            clock=clock,
            service_s=np.asarray(p.service_s, dtype=float),
            budget_s=np.maximum(self.budget_s, 0.0),
            start=start,
            end=np.arange(k) * 2 + n + 1,
            value=value,
            allowed=allowed,
        )

    def _times(self, dist: np.ndarray, from_pos: np.ndarray, pos: np.ndarray, ends: list[int],
               speed: float) -> np.ndarray:
        """Travel times at water speed ``speed`` between the instance's nodes: the metric over
        the speed in still water; through the current, the scenario's planning times between
        spots and rendezvous, and fresh ones from each vehicle's position."""
        p = self.problem
        if p.current is None or p.travel is None:
            return dist / speed
        n, k = p.n_tasks, len(self.vehicles)
        full = next((t for t, v in zip(p.travel_s, p.vehicles) if v.speed_mps == speed), None)
        if full is None:  # a live speed no scenario vehicle has
            full = p.travel.matrix(p.xyz, p.dist_m, speed)
        kind = "bound"
        if self.now_s is not None:  # clocked: mean times, an estimate the clock re-checks
            kind = "mean"
            cache = p.__dict__.setdefault("_mean_travel", {})
            if speed not in cache:
                cache[speed] = p.travel.matrix(p.xyz, p.dist_m, speed, kind="mean")
            full = cache[speed]
        targets = np.vstack([p.xyz[:n], p.xyz[ends]])
        out = dist / speed  # entries no route uses (into a position) keep the still-water value
        out[:n, :n] = full[:n, :n]
        for i in range(k):
            s, e = n + 2 * i, n + 2 * i + 1
            row = p.travel.times_from(pos[i], targets, speed, from_pos[i], kind)
            out[s, :n] = row[:n]
            out[e, :n], out[:n, e] = full[ends[i], :n], full[:n, ends[i]]
            for j in range(k):
                out[s, n + 2 * j + 1] = row[n + j]
                out[e, n + 2 * j + 1] = full[ends[i], ends[j]]
        return out

    def _from(self, pos: np.ndarray, targets: np.ndarray) -> np.ndarray:
        if self.problem.land is not None:
            return self.problem.land.distances_from(pos, targets)
        return np.linalg.norm(targets - pos[None, :], axis=1)

    def _clock(self, pos: np.ndarray, ends: list[int], speed: np.ndarray) -> TideClock | None:
        """A clock over the instance's nodes (tasks, then each vehicle's position and
        rendezvous), everyone leaving at ``now_s`` (moved on by the locked chains later)."""
        p = self.problem
        if self.now_s is None:
            return None
        assert p.travel is not None and isinstance(p.current, TidalCurrent)
        k = len(self.vehicles)
        xyz = np.empty((p.n_tasks + 2 * k, 3))
        xyz[: p.n_tasks] = p.xyz[: p.n_tasks]
        xyz[p.n_tasks :: 2] = pos
        xyz[p.n_tasks + 1 :: 2] = p.xyz[ends]
        return TideClock(p.current, xyz, speed, [self.now_s] * k, np.asarray(p.service_s),
                         p.travel.window_s[1], p.land)

    def _locked_time(self, travel: np.ndarray, i: int, clock: TideClock | None = None) -> float:
        n = self.problem.n_tasks
        nodes = [n + 2 * i, *self.locked[i]]
        if clock is not None:
            return clock.route_time_s(i, nodes)
        time = sum(float(travel[a, b]) for a, b in zip(nodes[:-1], nodes[1:]))
        service = sum(float(self.problem.service_s[u]) for u in self.locked[i])
        return time + service

    def _home(self) -> np.ndarray:
        """Which live vehicle's current route each task is in (first one wins), -1 if none."""
        home = np.full(self.problem.n_tasks, -1, dtype=np.int64)
        for i, v in enumerate(self.vehicles):
            for t in v.route:
                u = self._index(t)
                if home[u] < 0:
                    home[u] = i
        return home

    def warm_start(self, inst: Instance, rng: np.random.Generator) -> State:
        """The current routes, minus what is off limits, cut to fit, then improved by local
        search only (shorten, swap in richer spots, insert what fits): no ruin."""
        home = self._home()
        routes = []
        for i, v in enumerate(self.vehicles):
            route = [u for u in (self._index(t) for t in v.route)
                     if home[u] == i and inst.allowed[i, u]]
            routes.append(screen(inst, i, route))
        state = State(inst, routes)
        shorten(state, list(range(inst.k)))
        return local_search(fill(state), State(inst), rng)
