"""The array view the `best` engine searches: travel times per vehicle, budgets and values.

`Problem` is the scenario; `Instance` is what the search needs, and it is general enough for
replanning too: a vehicle's start node may be any node (its current position, or the last of
the tasks it is locked to), its budget is whatever battery is left, and ``value[v, u]`` (what
vehicle ``v`` earns by treating task ``u``) carries the stability penalty of the replanner.

Times are in seconds from ``travel_s[v]`` (the vehicle's speed, and the current if any: then
asymmetric); ``dist_m`` only says which spots are near which (ruin, clustering).

In a tidal stream a leg's time depends on when it starts. Then ``clock`` (a
`hfc_core.model.tide_clock.TideClock`) times every route as flown, and that is what feasibility and
the objective use; ``travel_s`` holds each leg's mean time over the mission, an estimate for
choosing moves, which are then re-checked by the clock. Without a clock (still water, a steady
current, or a tide on a problem too large to clock) ``travel_s`` is exact or a bound.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hfc_core.model.current import TidalCurrent
from hfc_core.model.problem import Problem
from hfc_core.model.tide_clock import TideClock

# A tide is clocked when its problem has at most this many (leg x tide step) entries; larger
# ones plan with the longest leg times over the mission (`hfc_core.model.travel`), a safe bound.
CLOCK_LIMIT = 50_000_000


@dataclass(frozen=True, eq=False)
class Instance:
    """Nodes ``0..n-1`` are tasks; ``start``/``end`` index each vehicle's terminal nodes."""

    dist_m: np.ndarray  # (m, m) symmetric metric, m >= n: nearness only
    travel_s: tuple[np.ndarray, ...]  # k arrays (m, m): travel time of vehicle v (shared)
    service_s: np.ndarray  # (n,)
    budget_s: np.ndarray  # (k,)
    start: np.ndarray  # (k,) node index
    end: np.ndarray  # (k,) node index
    value: np.ndarray  # (k, n) gain of vehicle v treating task u
    allowed: np.ndarray  # (k, n) bool: may vehicle v treat task u
    clock: TideClock | None = None  # routes timed as flown through a tide (see above)

    def __post_init__(self) -> None:
        n, k = len(self.service_s), len(self.budget_s)
        m = self.dist_m.shape[0]
        if self.dist_m.shape != (m, m) or m < n:
            raise ValueError(f"dist_m has shape {self.dist_m.shape}, need square with >= {n} rows")
        if len(self.travel_s) != k or any(t.shape != (m, m) for t in self.travel_s):
            raise ValueError(f"travel_s needs {k} arrays of shape {(m, m)}")
        for name in ("budget_s", "start", "end"):
            if getattr(self, name).shape != (k,):
                raise ValueError(f"{name} needs shape ({k},)")
        for name in ("value", "allowed"):
            if getattr(self, name).shape != (k, n):
                raise ValueError(f"{name} needs shape ({k}, {n})")
        if any(np.any(t < 0) for t in self.travel_s):
            raise ValueError("travel times must be >= 0")

    @property
    def n(self) -> int:
        return len(self.service_s)

    @property
    def k(self) -> int:
        return len(self.budget_s)

    @property
    def symmetric(self) -> bool:
        """Every vehicle's travel times read the same both ways (still water): the 2-opt and
        or-opt shortcuts that assume it apply (cached)."""
        if "_symmetric" not in self.__dict__:
            distinct = {id(t): t for t in self.travel_s}.values()
            self.__dict__["_symmetric"] = all(np.array_equal(t, t.T) for t in distinct)
        return self.__dict__["_symmetric"]

    def stacked(self) -> tuple[np.ndarray, np.ndarray]:
        """(c, m, m) the distinct travel arrays and (k,) which one each vehicle uses (cached):
        for moves evaluated across all routes at once."""
        if "_stacked" not in self.__dict__:
            ids: dict[int, int] = {}
            arrays: list[np.ndarray] = []
            for t in self.travel_s:
                if id(t) not in ids:
                    ids[id(t)] = len(arrays)
                    arrays.append(t)
            which = np.array([ids[id(t)] for t in self.travel_s], dtype=np.int64)
            stack = arrays[0][None] if len(arrays) == 1 else np.stack(arrays)
            self.__dict__["_stacked"] = (stack, which)
        return self.__dict__["_stacked"]

    def twins(self) -> np.ndarray:
        """(k,) for each vehicle the first vehicle that flies any tail alike: the same travel
        times into the same rendezvous (by position, not node number), values and allowed
        tasks (cached). In the COTSbot fleet, which shares its stations, that is every
        vehicle."""
        if "_twins" not in self.__dict__:
            _, which = self.stacked()
            first: dict[tuple[int, bytes, bytes, bytes], int] = {}
            self.__dict__["_twins"] = np.array([first.setdefault(
                (int(which[v]), self.travel_s[v][:, self.end[v]].tobytes(),
                 self.value[v].tobytes(), self.allowed[v].tobytes()), v)
                for v in range(self.k)])
        return self.__dict__["_twins"]

    def doubles(self) -> np.ndarray:
        """(k,) for each vehicle the first that flies any *whole* route alike: a twin whose
        start has the same travel times too (cached). Two such vehicles' routes exchanged
        whole keep every figure, bit for bit (`State.exchanged`)."""
        if "_doubles" not in self.__dict__:
            twin = self.twins()
            first: dict[tuple[int, bytes], int] = {}
            self.__dict__["_doubles"] = np.array([first.setdefault(
                (int(twin[v]), self.travel_s[v][self.start[v]].tobytes()), v)
                for v in range(self.k)])
        return self.__dict__["_doubles"]

    def route_time_s(self, v: int, route: list[int]) -> float:
        """Travel start -> route -> end at ``v``'s speed plus service, summed as `State` sums
        it (so both judge a route alike)."""
        nodes = [int(self.start[v]), *route, int(self.end[v])]
        if self.clock is not None:
            return self.clock.route_time_s(v, nodes)
        travel = float(self.travel_s[v][nodes[:-1], nodes[1:]].sum())
        service = float(self.service_s[route].sum()) if route else 0.0
        return travel + service

    def nearest_tasks(self, m: int) -> np.ndarray:
        """(n, min(m, n-1)) the nearest other tasks of each task, nearest first (cached)."""
        cache = self.__dict__.setdefault("_nearest", {})
        if m not in cache:
            d = self.dist_m[: self.n, : self.n].copy()
            np.fill_diagonal(d, np.inf)
            m_eff = max(0, min(m, self.n - 1))
            if m_eff:
                part = np.argpartition(d, m_eff - 1, axis=1)[:, :m_eff]
            else:
                part = np.zeros((self.n, 0), dtype=np.int64)
            keys = np.take_along_axis(d, part, axis=1)
            cache[m] = np.take_along_axis(part, np.argsort(keys, axis=1, kind="stable"), axis=1)
        return cache[m]

    def tie_weight(self) -> float:
        """Weight of one second of mission time in the objective: small enough that saving the
        whole fleet's budget is worth less than a thousandth of the smallest positive value,
        so time only ever breaks ties between plans of equal value."""
        positive = self.value[self.value > 0]
        smallest = float(positive.min()) if positive.size else 1.0
        return 1e-3 * smallest / max(float(self.budget_s.sum()), 1e-9)


def clocked(problem: Problem) -> bool:
    """Is ``problem``'s current a tide small enough to time routes as flown?"""
    if problem.current is None or problem.current.steady or problem.travel is None:
        return False
    steps = problem.travel.window_s[1] / 60.0 + 2
    return problem.dist_m.size * steps <= CLOCK_LIMIT


def instance_from_problem(problem: Problem) -> Instance:
    """The whole scenario: every vehicle at its start station with a full battery."""
    k = problem.n_vehicles
    priority = np.asarray(problem.priority, dtype=float)
    travel_s, clock = problem.travel_s, None
    if clocked(problem):
        # only a tide is unsteady (`clocked`)
        assert problem.travel is not None and isinstance(problem.current, TidalCurrent)
        cache = problem.__dict__.setdefault("_mean_travel", {})
        for v in problem.vehicles:
            if v.speed_mps not in cache:
                cache[v.speed_mps] = problem.travel.matrix(problem.xyz, problem.dist_m,
                                                           v.speed_mps, kind="mean")
        travel_s = tuple(cache[v.speed_mps] for v in problem.vehicles)
        clock = TideClock(problem.current, problem.xyz,
                          [v.speed_mps for v in problem.vehicles], [0.0] * k,
                          np.asarray(problem.service_s), problem.travel.window_s[1], problem.land)
    return Instance(
        dist_m=problem.dist_m,
        travel_s=travel_s,
        clock=clock,
        service_s=np.asarray(problem.service_s, dtype=float),
        budget_s=np.array([v.battery_s for v in problem.vehicles]),
        start=np.array([problem.start_node(v) for v in range(k)]),
        end=np.array([problem.end_node(v) for v in range(k)]),
        value=np.broadcast_to(priority, (k, problem.n_tasks)),
        allowed=np.ones((k, problem.n_tasks), dtype=bool),
    )
