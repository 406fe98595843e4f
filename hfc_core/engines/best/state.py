"""The search state: routes with cached travel times, and cached best insertions per route.

Routes hold task nodes only; a vehicle's terminals come from the instance. Each route's travel
time is recomputed from the vehicle's travel times whenever the route changes (never
accumulated), so feasibility never drifts. ``ins_s[v, u]`` / ``ins_pos[v, u]`` cache the
cheapest insertion of every task into route ``v`` (extra travel seconds, position); a route's
row is refreshed lazily after it changes, which is what makes repeated greedy insertion cheap.
"""

from __future__ import annotations

import numpy as np

from hfc_core.engines.best.instance import Instance
from hfc_core.model.feasibility import fits, room_s

UNASSIGNED = -1


class State:
    """Mutable; operators work on a `copy` and return it."""

    __slots__ = ("inst", "routes", "travel_s", "service_s", "owner", "ins_s", "ins_pos", "stale",
                 "_nodes", "_values", "_score")

    def __init__(self, inst: Instance, routes: list[list[int]] | None = None) -> None:
        self.inst = inst
        k, n = inst.k, inst.n
        self.routes = [list(r) for r in routes] if routes else [[] for _ in range(k)]
        self.owner = np.full(n, UNASSIGNED, dtype=np.int64)
        for v, route in enumerate(self.routes):
            self.owner[route] = v
        figures = [self._figures(v, self.routes[v]) for v in range(k)]
        self._nodes = [f[0] for f in figures]
        self._values = [f[1] for f in figures]
        self.service_s = [f[2] for f in figures]
        self.travel_s = [f[3] for f in figures]
        self.ins_s = np.zeros((k, n))
        self.ins_pos = np.zeros((k, n), dtype=np.int64)
        self.stale = np.ones(k, dtype=bool)
        self._score: tuple[float, float] | None = None  # (tie weight, objective) until a change

    def copy(self) -> "State":
        other = State.__new__(State)
        other.inst = self.inst
        other.routes = [list(r) for r in self.routes]
        other._nodes = list(self._nodes)  # arrays are never modified in place
        other._values = list(self._values)
        other.travel_s = list(self.travel_s)
        other.service_s = list(self.service_s)
        other.owner = self.owner.copy()
        other.ins_s = self.ins_s.copy()
        other.ins_pos = self.ins_pos.copy()
        other.stale = self.stale.copy()
        other._score = self._score
        return other

    # --- figures -------------------------------------------------------------------------
    def nodes(self, v: int) -> np.ndarray:
        """Route ``v`` with its terminals: start, tasks..., end (read only)."""
        return self._nodes[v]

    def _figures(self, v: int, route: list[int]
                 ) -> tuple[np.ndarray, np.ndarray, float, float]:
        """What vehicle ``v`` flying ``route`` caches: (its nodes with the terminals, the
        tasks' values, service seconds, travel seconds)."""
        inst = self.inst
        nodes = np.array([inst.start[v], *route, inst.end[v]], dtype=np.int64)
        service = float(inst.service_s[route].sum()) if route else 0.0
        if inst.clock is not None:  # as flown through the tide, less the injections
            travel = inst.clock.route_time_s(v, nodes) - service
        else:
            travel = float(inst.travel_s[v][nodes[:-1], nodes[1:]].sum())
        return nodes, inst.value[v, route], service, travel

    def _changed(self, v: int) -> None:
        (self._nodes[v], self._values[v], self.service_s[v],
         self.travel_s[v]) = self._figures(v, self.routes[v])
        self.stale[v] = True
        self._score = None

    def time_s(self, v: int) -> float:
        return self.travel_s[v] + self.service_s[v]

    def slack_s(self, v: int) -> float:
        """Extra time route ``v`` may take and still fit (`hfc_core.model.feasibility.room_s`)."""
        return room_s(self.time_s(v), float(self.inst.budget_s[v]))

    def fits(self, v: int) -> bool:
        """Route ``v`` fits its budget, by its own sum (`hfc_core.model.feasibility.fits`)."""
        return bool(fits(self.time_s(v), float(self.inst.budget_s[v])))

    def value(self) -> float:
        """Value collected, summed task after task in route order (a sequential cumsum: the
        same bits on every Python, where builtin ``sum`` of floats changed in 3.12)."""
        picked = np.concatenate(self._values)
        return float(np.cumsum(picked)[-1]) if len(picked) else 0.0

    def total_time_s(self) -> float:
        return sum(self.time_s(v) for v in range(self.inst.k))

    def objective(self, tie_weight: float) -> float:
        """Value collected, less a tie-breaking touch of mission time (`Instance.tie_weight`);
        kept until a route changes (the inter-route moves judge many trials against one
        state)."""
        if self._score is None or self._score[0] != tie_weight:
            self._score = (tie_weight, self.value() - tie_weight * self.total_time_s())
        return self._score[1]

    def feasible(self) -> bool:
        return all(self.fits(v) for v in range(self.inst.k))

    def positions(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Every routed task, route after route: (task, its vehicle, its index in the route,
        the node before it, the node after it; terminals included)."""
        terms = [self.nodes(v) for v in range(self.inst.k)]
        lengths = [len(r) for r in self.routes]
        return (np.concatenate([t[1:-1] for t in terms]),
                np.repeat(np.arange(self.inst.k), lengths),
                np.concatenate([np.arange(n) for n in lengths]),
                np.concatenate([t[:-2] for t in terms]),
                np.concatenate([t[2:] for t in terms]))

    # --- trials ---------------------------------------------------------------------------
    def trial(self, routes: dict[int, list[int]]) -> "Trial":
        """What setting ``routes`` (vehicle -> new route) would make of their cached figures,
        the state untouched: the inter-route moves reject most of what they try (an estimated
        gain the routes' own sums do not confirm), and setting then restoring two routes cost
        eight `set_route` calls per rejection."""
        out = {v: (list(route), *self._figures(v, route)) for v, route in routes.items()}
        return Trial(self, out)

    def exchanged(self, a: int, b: int) -> "Trial":
        """The trial of routes ``a`` and ``b`` exchanged whole, for two vehicles that fly any
        whole route alike (`Instance.doubles`: same travel times from the start and into the
        rendezvous, values, allowed tasks): each route's cached figures hold for the other
        vehicle bit for bit, so only the terminals of its nodes change (the many whole-route
        exchanges an oversubscribed reef's search tries and rejects cost no travel sums).
        Raises ValueError for two vehicles that are not doubles."""
        double = self.inst.doubles()
        if double[a] != double[b]:
            raise ValueError(f"vehicles {a} and {b} do not fly every route alike: use trial()")
        parts = {}
        for v, u in ((a, b), (b, a)):
            nodes = self._nodes[u].copy()
            nodes[0], nodes[-1] = self.inst.start[v], self.inst.end[v]
            parts[v] = (list(self.routes[u]), nodes, self._values[u], self.service_s[u],
                        self.travel_s[u])
        return Trial(self, parts)

    # --- edits ---------------------------------------------------------------------------
    def set_route(self, v: int, route: list[int]) -> None:
        """Replace route ``v`` (its tasks must be unassigned or already its own)."""
        self.owner[self.routes[v]] = UNASSIGNED
        self.routes[v] = list(route)
        self.owner[route] = v
        self._changed(v)

    def insert(self, v: int, u: int, pos: int) -> None:
        self.routes[v].insert(pos, u)
        self.owner[u] = v
        self._changed(v)

    def try_insert(self, v: int, u: int) -> bool:
        """Insert ``u`` at its cached cheapest position in route ``v`` if the route's own sum
        still fits; the cached estimate can fit where the sum does not (rounding): undone."""
        self.insert(v, u, int(self.ins_pos[v, u]))
        if self.fits(v):
            return True
        self.remove([u])
        return False

    def remove(self, tasks: list[int]) -> None:
        """Unassign ``tasks`` from whatever routes hold them."""
        drop = set(tasks)
        for v in {int(self.owner[u]) for u in drop if self.owner[u] >= 0}:
            self.routes[v] = [u for u in self.routes[v] if u not in drop]
            self._changed(v)
        self.owner[list(drop)] = UNASSIGNED

    # --- insertion cache -----------------------------------------------------------------
    def refresh_route(self, v: int) -> None:
        """Recompute the cheapest insertion of every task into route ``v``."""
        n = self.inst.n
        time = self.inst.travel_s[v]
        nodes = self.nodes(v)
        to_tasks = time[nodes, :n]  # (L, n)
        if self.inst.symmetric:
            extra = to_tasks[:-1] + to_tasks[1:]
        else:  # edge a -> b becomes a -> u -> b
            extra = to_tasks[:-1] + time[:n, nodes[1:]].T
        extra -= time[nodes[:-1], nodes[1:]][:, None]
        pos = extra.argmin(axis=0)
        self.ins_pos[v] = pos
        self.ins_s[v] = extra[pos, np.arange(n)]
        self.stale[v] = False

    def refresh(self) -> None:
        """Recompute the cheapest insertions into each changed route."""
        for v in np.flatnonzero(self.stale):
            self.refresh_route(int(v))

    def insertion_time_s(self) -> np.ndarray:
        """(k, n) extra mission time of each task's cheapest insertion into each route."""
        self.refresh()
        return self.ins_s + self.inst.service_s[None, :]


class Trial:
    """New routes for some vehicles of a `State`, with the figures `State._changed` would
    cache for them; judged with the same float operations in the same order as the state's
    own (`fits`, `objective`), so accepting a trial is bit-identical to setting its routes."""

    __slots__ = ("state", "parts")

    def __init__(self, state: State,
                 parts: dict[int, tuple[list[int], np.ndarray, np.ndarray, float, float]]
                 ) -> None:
        self.state, self.parts = state, parts

    def fits(self) -> bool:
        budget = self.state.inst.budget_s
        return all(bool(fits(travel + service, float(budget[v])))
                   for v, (_, _, _, service, travel) in self.parts.items())

    def objective(self, tie_weight: float) -> float:
        """`State.objective` of the state with these routes set."""
        s, parts = self.state, self.parts
        values = [parts[v][2] if v in parts else s._values[v] for v in range(s.inst.k)]
        picked = np.concatenate(values)
        value = float(np.cumsum(picked)[-1]) if len(picked) else 0.0
        total = sum(parts[v][4] + parts[v][3] if v in parts else s.time_s(v)
                    for v in range(s.inst.k))
        return value - tie_weight * total

    def accept(self) -> None:
        """Set the routes (what `State.set_route` on each would leave)."""
        s = self.state
        for v in self.parts:
            s.owner[s.routes[v]] = UNASSIGNED
        for v, (route, nodes, values, service, travel) in self.parts.items():
            s.routes[v] = route
            s.owner[route] = v
            s._nodes[v], s._values[v] = nodes, values
            s.service_s[v], s.travel_s[v] = service, travel
            s.stale[v] = True
        s._score = None
