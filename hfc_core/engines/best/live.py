"""The `best` search set up for vehicles at sea: the instance the replanner searches.

How live vehicles (`hfc_core.model.live.IndexedVehicle`) become an `Instance`:
- each vehicle starts at its position (or, with ``locked`` spots, at the last of them: the
  locked chain is prepended unchanged and its time taken off the battery);
- spots ``cleared``, locked by a vehicle, or held by another live vehicle are off limits;
- travel from a position uses `Problem.land` when the scenario has land, and the current's
  times from that position;
- treating a spot from another live vehicle's current route is worth ``penalty`` less, so
  spots change vehicle only for a real gain.

The warm start (`LiveSetup.warm_start`) is the current routes, minus what is off limits, cut to
fit, then improved by local search only. Indices throughout; `hfc_core.replan` runs the search.
"""

from __future__ import annotations

import math
from typing import Collection, Mapping, Sequence

import numpy as np
from scipy.spatial.distance import cdist

from hfc_core.engines.best.construct import screen
from hfc_core.engines.best.engine import local_search, shorten
from hfc_core.engines.best.insert import fill
from hfc_core.engines.best.instance import Instance, clocked
from hfc_core.engines.best.state import State
from hfc_core.model.current import TidalCurrent
from hfc_core.model.errors import ScenarioError
from hfc_core.model.live import IndexedVehicle
from hfc_core.model.problem import Problem
from hfc_core.model.tide_clock import TideClock


def _is_index(value: object, size: int) -> bool:
    return bool(isinstance(value, (int, np.integer)) and not isinstance(value, bool)
                and 0 <= value < size)


class LiveSetup:
    """Validated live inputs, in indices, and the instance built from them. ``held`` maps a
    task index to the vehicle index holding it; a holder not among ``vehicles`` is gone."""

    def __init__(
        self,
        problem: Problem,
        vehicles: Sequence[IndexedVehicle],
        cleared: Collection[int],
        held: Mapping[int, int],
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
        indices = [v.index for v in self.vehicles]
        for index in indices:
            if not _is_index(index, problem.n_vehicles):
                raise ScenarioError(f"no vehicle with index {index!r}")
        if len(set(indices)) != len(indices):
            raise ScenarioError("a vehicle is listed twice")
        live = {index: i for i, index in enumerate(indices)}
        n = problem.n_tasks
        self.cleared = np.zeros(n, dtype=bool)
        self.cleared[[self._task(u) for u in cleared]] = True
        # holder[u]: index into vehicles of the live vehicle holding u, -1 if none is.
        self.holder = np.full(n, -1, dtype=np.int64)
        for u, index in held.items():
            if index in live:
                self.holder[self._task(u)] = live[index]
        self.locked: list[list[int]] = []
        taken = np.zeros(n, dtype=bool)
        for i, v in enumerate(self.vehicles):
            chain = []
            for u in map(self._task, v.locked):
                if not (self.cleared[u] or taken[u] or self.holder[u] not in (-1, i)):
                    chain.append(u)
                    taken[u] = True
            self.locked.append(chain)
        self.locked_mask = taken
        # What moving one spot between vehicles (or changing the plan at all) must gain.
        self.penalty = stability * float(problem.priority.mean()) if n else 0.0

    def _task(self, u: int) -> int:
        if not _is_index(u, self.problem.n_tasks):
            raise ScenarioError(f"no task with index {u!r}")
        return int(u)

    def instance(self) -> Instance:
        p, k, n = self.problem, len(self.vehicles), self.problem.n_tasks
        # Nodes: tasks, then per live vehicle its position and its rendezvous.
        dist = np.empty((n + 2 * k, n + 2 * k))
        dist[:n, :n] = p.dist_m[:n, :n]
        ends = [p.end_node(v.index) for v in self.vehicles]
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
        speed = np.array([v.speed_mps or p.vehicles[v.index].speed_mps for v in self.vehicles],
                         dtype=float)
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
            for u in map(self._task, v.route):
                if home[u] < 0:
                    home[u] = i
        return home

    def warm_start(self, inst: Instance, rng: np.random.Generator) -> State:
        """The current routes, minus what is off limits, cut to fit, then improved by local
        search only (shorten, swap in richer spots, insert what fits): no ruin."""
        home = self._home()
        routes = []
        for i, v in enumerate(self.vehicles):
            route = [u for u in map(self._task, v.route) if home[u] == i and inst.allowed[i, u]]
            routes.append(screen(inst, i, route))
        state = State(inst, routes)
        shorten(state, list(range(inst.k)))
        return local_search(fill(state), State(inst), rng)
