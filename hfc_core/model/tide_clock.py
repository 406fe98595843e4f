"""Routes timed as flown through a tidal stream: the time each leg takes from when it starts.

In a tidal stream (`hfc_core.model.current.TidalCurrent`) the stream is constant over 60 s steps, so
along a straight leg the ground speed is constant within each step and the distance run since
mission time 0 is a piecewise-linear function of time, ``G(t)``, with knots at the step
boundaries. A leg of length ``L`` started at ``t`` ends when ``G`` has grown by ``L``: one
binary search over the knots. The knots of a leg are built the first time the leg is timed
(numpy, over the whole horizon) and kept as Python lists (``bisect`` is ten times faster than
``numpy.searchsorted`` on one short row), so only the legs the search touches cost memory.

This is the same model the checker and the vehicle model fly step by step
(`hfc_core.model.travel.segment_pieces`), so a route the planner times as fitting fits when flown
(to rounding, far below `hfc_core.model.feasibility.FEASIBILITY_TOL_S`). A leg whose stream makes it
impossible at any step of the horizon counts as impossible whenever it starts (conservative:
the checker would only reject it at those steps). Legs around land are flown segment by
segment instead (`hfc_core.model.travel.path_time_s`, slower, exact). Pure: IEEE operations only.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from typing import TYPE_CHECKING, Sequence

import numpy as np

from hfc_core.model.current import TIDE_STEP_S, TidalCurrent
from hfc_core.model.travel import LegError, ground_speed, path_time_s

if TYPE_CHECKING:
    from hfc_core.model.geometry import LandMap

# (knots G_k, ground speeds g_k, leg length), or None for a leg the stream makes impossible
_Row = tuple[list[float], list[float], float] | None


class TideClock:
    """Flown route times for ``k`` vehicles over the nodes ``xyz``; vehicle ``v`` leaves its
    first node at mission time ``start_s[v]`` at water speed ``speed_mps[v]``."""

    def __init__(self, current: TidalCurrent, xyz: np.ndarray,
                 speed_mps: Sequence[float] | np.ndarray, start_s: Sequence[float] | np.ndarray,
                 service_s: np.ndarray, horizon_s: float,
                 land: "LandMap | None" = None) -> None:
        self.current = current
        self.xyz = np.asarray(xyz, dtype=float)
        self.speed_mps = [float(s) for s in speed_mps]
        self.start_s = [float(t) for t in start_s]
        self.service_s = [float(s) for s in service_s]
        self.n = len(self.service_s)
        self.land = land
        self.steps = max(1, math.ceil(horizon_s / TIDE_STEP_S) + 1)
        factors = np.array([current.factor(k) for k in range(self.steps)])
        self._cu = factors * current.velocity_mps[0]
        self._cv = factors * current.velocity_mps[1]
        self._rows: dict[tuple[float, int, int], _Row] = {}
        self._visible: dict[tuple[int, int], bool] = {}

    def route_time_s(self, v: int, nodes: Sequence[int] | np.ndarray) -> float:
        """Mission time of vehicle ``v`` along ``nodes`` (its first node to its last; the
        service of every task node reached), as flown; ``inf`` if it cannot be flown."""
        t0 = self.start_s[v]
        t = t0
        for a, b in zip(nodes[:-1], nodes[1:]):
            t = self.leg_end_s(v, int(a), int(b), t)
            if b < self.n:
                t += self.service_s[b]
        return t - t0

    def leg_end_s(self, v: int, a: int, b: int, t_s: float) -> float:
        """When vehicle ``v``'s leg a -> b started at ``t_s`` ends (``inf`` if it cannot)."""
        if a == b or not math.isfinite(t_s):
            return t_s
        speed = self.speed_mps[v]
        if self.land is not None and not self._straight(a, b):
            try:
                return t_s + path_time_s(self.current, self.land.shortest_path(
                    self.xyz[a], self.xyz[b])[1], speed, t_s)
            except LegError:
                return math.inf
        row = self._row(speed, a, b)
        if row is None:
            return math.inf
        knots, g, length = row
        if length == 0.0:  # already there (a vehicle replanning at a spot)
            return t_s
        k = math.floor(t_s / TIDE_STEP_S)
        if not 0 <= k < self.steps:
            return math.inf
        target = knots[k] + g[k] * (t_s - k * TIDE_STEP_S) + length
        j = bisect_right(knots, target, k + 1) - 1
        if j >= self.steps:
            return math.inf  # beyond the horizon: no route that fits gets there
        return j * TIDE_STEP_S + (target - knots[j]) / g[j]

    def _straight(self, a: int, b: int) -> bool:
        key = (a, b) if a < b else (b, a)
        if key not in self._visible:
            assert self.land is not None
            self._visible[key] = bool(self.land.visible(self.xyz[a], self.xyz[b])[0])
        return self._visible[key]

    def _row(self, speed: float, a: int, b: int) -> _Row:
        key = (speed, a, b)
        if key not in self._rows:
            delta = self.xyz[b] - self.xyz[a]
            length = math.sqrt(float(delta @ delta))
            if length == 0.0:
                self._rows[key] = ([], [], 0.0)
                return self._rows[key]
            g = ground_speed(speed, self._cu, self._cv, delta[0] / length, delta[1] / length)
            if np.isnan(g).any():
                self._rows[key] = None
            else:
                knots = np.concatenate([[0.0], np.cumsum(g * TIDE_STEP_S)])
                self._rows[key] = (knots.tolist(), g.tolist(), length)
        return self._rows[key]
