"""The agent's planner: `hfc_core` behind task indices, with iteration budgets only.

Everything the fleet must agree on is computed with an iteration budget and a shared seed,
never a time limit, so every agent gets the same answer from the same inputs. Results are
memoised on their inputs: the in-process simulation runs many agents on one interpreter, and
a pure function computed once serves them all (the multi-process fleet computes it in each
process, as the vehicles would).
"""

from __future__ import annotations

import math
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Callable, Collection, Iterator, Mapping, Sequence

import numpy as np

from fleet_bus.tdma import Track
from hfc_core.model.paths import as_point3
from hfc_core.model.problem import Problem

if TYPE_CHECKING:
    from fleet_agent.config import AgentConfig

Point3 = tuple[float, float, float]

# Told when this process starts and ends a replanner run (True, then False). The deployment
# sets it (`fleet_agent.node`: one agent per process) so that the launcher holds the shared
# clock while an agent plans: a planner burst of b wall seconds would otherwise be b x warp
# mission seconds of silence, enough for a false alarm at high warp (docs/fleet_agent.md).
# The in-process simulation leaves it unset: there planning takes no mission time anyway.
_on_planning: Callable[[bool], None] | None = None


def set_planning_hook(hook: Callable[[bool], None] | None) -> None:
    """Call ``hook(True)`` before and ``hook(False)`` after every replanner run."""
    global _on_planning
    _on_planning = hook


@contextmanager
def _planning() -> Iterator[None]:
    hook = _on_planning
    if hook is not None:
        hook(True)
    try:
        yield
    finally:
        if hook is not None:
            hook(False)


@dataclass(frozen=True)
class Live:
    """A vehicle as the replanner sees it (task indices)."""

    index: int
    pos: Point3
    battery_s: float
    route: tuple[int, ...] = ()
    locked: tuple[int, ...] = ()  # spots that must stay first (being injected)


class Planner:
    """Plans for the battery less ``reserve_s`` (the agent's `battery_reserve_s`): every route
    it returns reaches the rendezvous with that margin, so fitting a fresh plan to the battery
    (`fleet_agent.routing.fit_route`) drops nothing.

    Its cost grows with the fleet, not faster: a fleet of more than ``region_vehicles`` is
    planned region by region (`regions`: sectors of spots around the fleet's starts, each with
    its share of the vehicles), and a replan given a ``scope`` (the spots it may touch) works
    on the sub-problem of those spots and its vehicles alone (`subproblem`)."""

    def __init__(self, problem: Problem, seed: int, plan_iterations: int,
                 replan_iterations: int, reserve_s: float = 0.0, polish: bool = True,
                 region_vehicles: int = 0) -> None:
        self.problem = problem
        self.reserve_s = float(reserve_s)
        self.polish = polish  # polish the initial plan (`AgentConfig.plan_polish`)
        self.seed = seed
        self.plan_iterations = plan_iterations
        self.replan_iterations = replan_iterations
        self.region_vehicles = region_vehicles  # 0: one region whatever the fleet's size
        self._initial: tuple[tuple[int, ...], ...] | None = None
        self._memo: dict[tuple, dict[int, list[int]]] = {}
        self.calls = 0  # replanner runs (not memo hits), for benchmarks

    @classmethod
    def from_config(cls, problem: Problem, seed: int, config: "AgentConfig") -> "Planner":
        """The planner an agent with ``config`` uses (its budgets, reserve and polishing)."""
        return cls(problem, seed, config.plan_iterations, config.replan_iterations,
                   config.battery_reserve_s, config.plan_polish, config.plan_region_vehicles)

    def initial_routes(self) -> tuple[tuple[int, ...], ...]:
        """The fleet plan every agent computes alone at start: solve("best") on the shared
        scenario with the shared seed and an iteration budget; region by region beyond
        ``region_vehicles`` vehicles (the same regions for every agent: `regions`)."""
        if self._initial is None:
            problem = self.problem.with_reserve(self.reserve_s)
            parts = regions(problem, self.region_vehicles)
            routes: list[tuple[int, ...]] = [()] * problem.n_vehicles
            for j, (tasks, vehicles) in enumerate(parts):
                sub = problem if len(parts) == 1 else subproblem(problem, tasks, vehicles)
                budget = self.region_budget(len(vehicles), len(parts))
                for v, r in zip(vehicles, self._solve(sub, self.seed + 7919 * j, budget)):
                    routes[v] = tuple(tasks[t] for t in r) if len(parts) > 1 else r
            self._initial = tuple(routes)
        return self._initial

    def region_budget(self, vehicles: int, regions: int) -> int:
        """A region's iterations when the fleet is cut in ``regions``: ``plan_iterations``
        per ``region_vehicles`` of its vehicles, so the fleet's budget follows its size (at
        100 vehicles nine regions of 8 to 14 vehicles get 333 to 583, 4,167 in all; 500 each
        made 4,500); one region (a fleet no larger than ``region_vehicles``, or regions off)
        gets the whole budget."""
        if regions <= 1:
            return self.plan_iterations
        return max(1, round(self.plan_iterations * vehicles / self.region_vehicles))

    def _solve(self, problem: Problem, seed: int, iterations: int) -> list[tuple[int, ...]]:
        from hfc_core.solve import solve

        if problem.n_tasks == 0:
            return [()] * problem.n_vehicles
        polish: dict[str, Any] = {} if self.polish else {"polish": None}  # None: no polish
        result = solve(problem, "best", max_iterations=iterations, seed=seed, **polish)
        return [tuple(int(t) for t in r) for r in result.plan.routes]

    def replan(self, vehicles: Sequence[Live], unavailable: frozenset[int],
               held: Mapping[int, int], seed: int,
               scope: Collection[int] | None = None) -> dict[int, list[int]]:
        """Routes (task indices) for ``vehicles`` over the spots not ``unavailable``; a spot in
        ``held`` goes to its holder only. Vehicles not listed are gone. With a ``scope``,
        only spots in it are planned (and the problem the replanner sees is theirs alone)."""
        spots = None if scope is None else tuple(sorted({int(t) for t in scope}
                                                        - unavailable))
        key = (tuple(vehicles), unavailable if spots is None else spots,
               tuple(sorted(held.items())), seed)
        hit = self._memo.get(key)
        if hit is not None:
            return {v: list(r) for v, r in hit.items()}
        if spots is None:
            out = self._replan(self.problem, vehicles, unavailable, held, seed)
        else:
            out = self._replan_scoped(vehicles, spots, held, seed)
        self.calls += 1
        if len(self._memo) > 256:
            self._memo.clear()
        self._memo[key] = out
        return {v: list(r) for v, r in out.items()}

    def _replan_scoped(self, vehicles: Sequence[Live], spots: tuple[int, ...],
                       held: Mapping[int, int], seed: int) -> dict[int, list[int]]:
        """The replan on the sub-problem of ``spots`` and ``vehicles`` (indices mapped in and
        out): its cost is that of the scope, whatever the fleet's size."""
        index = {t: i for i, t in enumerate(spots)}
        order = sorted({lv.index for lv in vehicles})
        vmap = {v: j for j, v in enumerate(order)}
        sub = subproblem(self.problem, spots, order)
        live = [Live(vmap[lv.index], lv.pos, lv.battery_s,
                     tuple(index[t] for t in lv.route if t in index),
                     tuple(index[t] for t in lv.locked if t in index)) for lv in vehicles]
        sub_held = {index[t]: vmap[h] for t, h in held.items() if t in index and h in vmap}
        out = self._replan(sub, live, frozenset(), sub_held, seed)
        return {order[j]: [spots[t] for t in r] for j, r in out.items()}

    def _replan(self, problem: Problem, vehicles: Sequence[Live], unavailable: frozenset[int],
                held: Mapping[int, int], seed: int) -> dict[int, list[int]]:
        from hfc_core.model.live import IndexedVehicle
        from hfc_core.replan import replan_indexed

        # Every position here is an estimate (own dead reckoning, a peer's pose carried
        # forward along its route): near a coast it may lie on land, where the vehicle is
        # not; the planner takes it at the nearest sea (`LandMap.to_water`).
        sea = (lambda q: q) if problem.land is None else problem.land.to_water
        live = [IndexedVehicle(v.index, as_point3(sea(v.pos)),
                               max(0.0, v.battery_s - self.reserve_s),
                               route=v.route, locked=v.locked) for v in vehicles]
        with _planning():
            return replan_indexed(problem, live, cleared=unavailable, held=held,
                                  max_iterations=self.replan_iterations, seed=seed)


def subproblem(problem: Problem, tasks: Sequence[int], vehicles: Sequence[int]) -> Problem:
    """``problem`` restricted to ``tasks`` and ``vehicles`` (indices, in the order given: task
    ``i`` of the result is ``tasks[i]``, vehicle ``j`` is ``vehicles[j]``). The matrices are
    cut from the problem's own, so every leg costs what it costs in the whole problem; land
    and the current are shared (they are positions, not indices)."""
    n = problem.n_tasks
    tasks, vehicles = [int(t) for t in tasks], [int(v) for v in vehicles]
    nodes = np.array(tasks + [n + 2 * v + e for v in vehicles for e in (0, 1)], dtype=np.intp)
    grid = np.ix_(nodes, nodes)

    def frozen(a: np.ndarray) -> np.ndarray:
        a.setflags(write=False)
        return a

    cut: dict[int, np.ndarray] = {}  # one cut per distinct matrix (per speed)
    travel_s = tuple(cut.setdefault(id(problem.travel_s[v]), frozen(problem.travel_s[v][grid]))
                     for v in vehicles) if problem.travel_s else ()
    sub_tasks = tuple(problem.tasks[t] for t in tasks)
    sub_vehicles = tuple(problem.vehicles[v] for v in vehicles)
    return replace(problem, vehicles=sub_vehicles, tasks=sub_tasks,
                   dist_m=frozen(problem.dist_m[grid]), xyz=frozen(problem.xyz[nodes]),
                   priority=frozen(problem.priority[tasks]),
                   service_s=frozen(problem.service_s[tasks]),
                   task_index={t.id: i for i, t in enumerate(sub_tasks)},
                   vehicle_index={v.id: j for j, v in enumerate(sub_vehicles)},
                   travel_s=travel_s)


def regions(problem: Problem, per_region: int) -> list[tuple[list[int], list[int]]]:
    """The fleet cut into regions of at most about ``per_region`` vehicles (one region when
    ``per_region`` is 0 or the fleet is no larger): ``(tasks, vehicles)`` per region, index
    lists, every vehicle in exactly one, every spot some vehicle can reach (`reachable`) in
    exactly one (the others are in no plan anyway, and cost the planner time).

    Spots are cut into angular sectors around the mean of the vehicles' starts (a support
    vessel the fleet fans out from), each sector cut at the widest angular gap near an
    equal share of the spots (an aggregation is seldom cut in two); each sector gets vehicles
    in proportion to its spots (at least one), taken in the order of their starts' angles,
    then their indices. The same inputs give the same regions on every vehicle."""
    k, n = problem.n_vehicles, problem.n_tasks
    g = 1 if per_region <= 0 or k <= per_region else min(math.ceil(k / per_region), max(n, 1))
    if g <= 1:
        return [(list(range(n)), list(range(k)))]
    starts = np.array([v.start[:2] for v in problem.vehicles], dtype=float)
    centre = starts.mean(axis=0)
    spots = reachable(problem)  # a spot no vehicle can reach alone is in no plan
    n = len(spots)
    xy = problem.xyz[spots, :2] - centre
    angle = np.arctan2(xy[:, 1], xy[:, 0])
    order = np.lexsort((np.arange(n), angle))
    gaps = np.diff(np.append(angle[order], angle[order[0]] + 2.0 * math.pi))
    first = (int(np.argmax(gaps)) + 1) % n  # start after the widest gap: no seam in a cluster
    order = np.roll(order, -first)
    gaps = np.roll(gaps, -first)  # gaps[i]: between order[i] and order[i + 1]
    cuts, share = [0], n / g
    for j in range(1, g):
        lo = max(cuts[-1] + 1, int(round((j - 0.25) * share)))
        hi = min(n - (g - j), int(round((j + 0.25) * share)))
        cuts.append(lo + int(np.argmax(gaps[lo - 1:hi])) if hi > lo else lo)
    cuts.append(n)
    sizes = [cuts[j + 1] - cuts[j] for j in range(g)]
    quota = _shares(k, sizes)
    v_angle = np.arctan2(starts[:, 1] - centre[1], starts[:, 0] - centre[0])
    v_angle = np.where(np.hypot(starts[:, 0] - centre[0], starts[:, 1] - centre[1]) < 1.0,
                       0.0, v_angle)
    v_order = [int(v) for v in np.lexsort((np.arange(k), v_angle))]
    out, at = [], 0
    for j in range(g):
        out.append((sorted(int(spots[t]) for t in order[cuts[j]:cuts[j + 1]]),
                    sorted(v_order[at:at + quota[j]])))
        at += quota[j]
    return out


def reachable(problem: Problem) -> np.ndarray:
    """Indices of the spots some vehicle could treat alone: from its start, the injection,
    then to its rendezvous within its battery (the planner's leg times)."""
    n = problem.n_tasks
    ok = np.zeros(n, dtype=bool)
    for v, veh in enumerate(problem.vehicles):
        t = problem.travel_s[v]
        need = t[problem.start_node(v), :n] + problem.service_s + t[:n, problem.end_node(v)]
        ok |= need <= veh.battery_s
    return np.flatnonzero(ok)


def _shares(k: int, sizes: Sequence[int]) -> list[int]:
    """``k`` vehicles in proportion to ``sizes``, at least one each (largest remainders)."""
    total = sum(sizes) or 1
    raw = [max(1.0, k * s / total) for s in sizes]
    quota = [int(r) for r in raw]
    for j in sorted(range(len(sizes)), key=lambda j: (-(raw[j] - quota[j]), j)):
        if sum(quota) >= k:
            break
        quota[j] += 1
    while sum(quota) > k:
        j = max(range(len(quota)), key=lambda j: (quota[j], j))
        quota[j] -= 1
    return quota


def nominal_tracks(problem: Problem, routes: Sequence[Sequence[int]]) -> list[Track]:
    """Where the fleet plan puts each vehicle over time: from its start at time 0 along its
    route (the planner's leg times, each spot's injection), then at its rendezvous, done. What
    every vehicle knows of every other before the first message (`fleet_bus.tdma`)."""
    tracks = []
    for v, route in enumerate(routes):
        nodes = [problem.start_node(v), *route, problem.end_node(v)]
        t, times, xy = 0.0, [0.0], [problem.xyz[nodes[0], :2]]
        for a, b in zip(nodes[:-1], nodes[1:]):
            t += float(problem.travel_s[v][a, b])
            times.append(t)
            xy.append(problem.xyz[b, :2])
            if b < problem.n_tasks:
                t += float(problem.service_s[b])
                times.append(t)
                xy.append(problem.xyz[b, :2])
        tracks.append(Track(np.array(times), np.array(xy), t))
    return tracks
