"""Travel through moving water: ground speed along a track, leg times, the planner's matrices.

A vehicle keeps its cruise speed ``s`` through the water (Assumption 1) and crabs into the
current so that its track over the ground follows the leg (the usual course-to-steer triangle).
With the current ``c`` (horizontal) and the unit direction ``d`` of the leg (3-D, eq. 5-7), the
water velocity ``w = g d - c`` must have length ``s``, so the ground speed is

    g = c.d + sqrt(s^2 - |c|^2 + (c.d)^2)

The leg is impossible when the current across the track, ``sqrt(|c|^2 - (c.d)^2)``, exceeds
``s`` (the vehicle cannot hold the track) or when ``g <= 0`` (it makes no headway): going
up-current costs more than coming back (an asymmetric travel time). Without a current
``g = s`` exactly (IEEE ``sqrt`` of a square), so still water gives the paper's eq. 7-8 times.

What a leg takes is integrated exactly over a piecewise-constant model of the water:

- uniform current: one piece, ``L / g``;
- gridded current (steady): the leg is cut into ``N = ceil(max(|dx|, |dy|) / piece_m)`` equal
  pieces (``piece_m = cell_m / 8``; the larger horizontal extent, because it is computed
  bit for bit alike by every part), each crossed at the ground speed of the current at its
  middle (midpoint rule: against the bilinear field, the error is second order in the piece:
  median 1e-4, at most 2e-3 relative on random legs through random fields up to 0.57 m/s;
  more where the current all but stops the vehicle);
- tidal current: constant over 60 s steps of mission time (`hfc_core.model.current.TIDE_STEP_S`), so
  the time of a leg depends on when it starts and is found by walking the steps.

Around land a leg is the land metric's waypoint path, each straight segment crossed as above.

The planner's travel-time matrices are static. For a steady current they are exact. For a
tidal current they hold, for each leg, the *longest* time it can take when started at any time
of the mission window ``[0, max battery]``: ``L / min(g(a_lo), g(a_hi))``, where ``a_lo..a_hi``
is the range of the tide factor over the window's steps (``g`` is concave in the factor, so its
minimum is at an end). A route the planner fits into its battery therefore fits whenever it is
flown; the checker and the vehicle model time it as flown (step by step from mission time 0),
which is shorter or equal. The cost is pessimism on legs whose tide changes during the window;
`benchmarks/currents.py` measures it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np

from hfc_core.model.current import (
    TIDE_STEP_S,
    CurrentField,
    GridCurrent,
    TidalCurrent,
    UniformCurrent,
)

if TYPE_CHECKING:
    from hfc_core.model.geometry import LandMap

Point3 = tuple[float, float, float]
PIECE_SHARE = 0.125  # grid legs are cut into pieces of at most this share of a cell
# Planning time of a leg the current makes impossible: fits no battery, yet finite, so that
# the search's sums and differences of times stay numbers (inf - inf would be NaN).
IMPOSSIBLE_S = 1e12
CHUNK = 400_000  # segments per vectorised block (bounds temporary memory)


class LegError(ValueError):
    """A leg the vehicle cannot make against the current; the message says why."""


def ground_speed(speed: float | np.ndarray, cu: np.ndarray | float, cv: np.ndarray | float,
                 dx: np.ndarray | float, dy: np.ndarray | float) -> np.ndarray:
    """Ground speed along unit track direction (dx, dy, .) with current (cu, cv): NaN where the
    leg is impossible (cross-current above ``speed``, or no headway). Vectorised."""
    along = cu * dx + cv * dy
    disc = speed * speed - (cu * cu + cv * cv - along * along)
    with np.errstate(invalid="ignore"):
        g = along + np.sqrt(np.where(disc >= 0.0, disc, np.nan))
    return np.where(g > 0.0, g, np.nan)


def why_impossible(speed: float, cu: float, cv: float, d: Sequence[float]) -> str:
    """The reason ``ground_speed`` is NaN, in words."""
    along = cu * d[0] + cv * d[1]
    across = math.sqrt(max(0.0, cu * cu + cv * cv - along * along))
    if across > speed:
        return (f"the current ({cu:.2f}, {cv:.2f}) m/s sets {across:.2f} m/s across the track, "
                f"more than the vehicle's {speed:.2f} m/s through the water")
    return (f"the current ({cu:.2f}, {cv:.2f}) m/s runs {-along:.2f} m/s against the track: "
            f"at {speed:.2f} m/s through the water the vehicle makes no headway")


def piece_m(current: GridCurrent) -> float:
    return PIECE_SHARE * current.cell_m


# --- one straight segment, as flown ------------------------------------------------------------
def segment_pieces(current: CurrentField | None, p: Sequence[float], q: Sequence[float],
                   speed: float, t0_s: float = 0.0) -> list[tuple[float, float]]:
    """How a vehicle crosses the straight segment p -> q starting at mission time ``t0_s``:
    ``[(duration_s, length_m), ...]`` in order, each at constant ground speed. Raises
    `LegError` if the current makes it impossible."""
    length = math.dist(p, q)
    if length == 0.0:
        return []
    if current is None:  # still water: no heading needed (an agent times every leg it weighs)
        return [(length / speed, length)]
    d = [(b - a) / length for a, b in zip(p, q)]
    if isinstance(current, UniformCurrent):
        return [(length / _speed_on(speed, current.velocity_mps, d), length)]
    if isinstance(current, TidalCurrent):
        return _tidal_pieces(current, length, d, speed, t0_s)
    n = grid_piece_count(current, p, q)
    out = []
    for k in range(n):
        f = (k + 0.5) / n
        mid = [a + (b - a) * f for a, b in zip(p[:2], q[:2])]
        cu, cv = current.velocity(np.array([mid]))[0]
        out.append(((length / n) / _speed_on(speed, (float(cu), float(cv)), d), length / n))
    return out


def _speed_on(speed: float, c: Sequence[float], d: Sequence[float]) -> float:
    g = float(ground_speed(speed, c[0], c[1], d[0], d[1]))
    if not g > 0.0:
        raise LegError(why_impossible(speed, c[0], c[1], d))
    return g


def grid_piece_count(current: GridCurrent, p: Sequence[float], q: Sequence[float]) -> int:
    """How many pieces the straight segment p -> q is cut into in a gridded current."""
    extent = max(abs(q[0] - p[0]), abs(q[1] - p[1]))
    return max(1, math.ceil(extent / piece_m(current)))


def _tidal_pieces(current: TidalCurrent, length: float, d: Sequence[float], speed: float,
                  t0_s: float) -> list[tuple[float, float]]:
    out = []
    left, t = length, t0_s
    step = current.step(t0_s)
    while True:
        a = current.factor(step)
        c = (current.velocity_mps[0] * a, current.velocity_mps[1] * a)
        g = _speed_on(speed, c, d)
        end = (step + 1) * TIDE_STEP_S
        run = g * (end - t)
        if run >= left:
            out.append((left / g, left))
            return out
        out.append((end - t, run))
        left -= run
        t, step = end, step + 1


def path_time_s(current: CurrentField | None, points: Sequence[Sequence[float]], speed: float,
                t0_s: float = 0.0) -> float:
    """Time to fly the polyline ``points`` from mission time ``t0_s`` (`LegError` if impossible)."""
    t = t0_s
    for p, q in zip(points[:-1], points[1:]):
        for duration, _ in segment_pieces(current, p, q, speed, t):
            t += duration
    return t - t0_s


# --- the planner's static times ------------------------------------------------------------------
def tide_range(current: TidalCurrent, window_s: tuple[float, float]) -> tuple[float, float]:
    """(lowest, highest) tide factor over the steps the window touches."""
    first, last = current.step(window_s[0]), current.step(window_s[1])
    factors = [current.factor(k) for k in range(first, last + 1)]
    return min(factors), max(factors)


def segment_times(current: CurrentField | None, p: np.ndarray, q: np.ndarray, speed: float,
                  window_s: tuple[float, float], kind: str = "bound") -> np.ndarray:
    """Planning time of each straight segment ``p[i] -> q[i]`` ((N, 3) each): exact for a steady
    current; for a tidal one the longest over the window (``kind="bound"``) or the mean over
    the window's steps (``"mean"``: an estimate for a planner that times routes as flown,
    `hfc_core.model.tide_clock`); `IMPOSSIBLE_S` where impossible."""
    out = np.empty(len(p))
    for lo in range(0, len(p), CHUNK):
        out[lo : lo + CHUNK] = _segment_block(current, p[lo : lo + CHUNK], q[lo : lo + CHUNK],
                                              speed, window_s, kind)
    return out


def _segment_block(current: CurrentField | None, p: np.ndarray, q: np.ndarray, speed: float,
                   window_s: tuple[float, float], kind: str = "bound") -> np.ndarray:
    delta = q - p
    length = np.sqrt((delta * delta).sum(axis=1))
    safe = np.where(length > 0.0, length, 1.0)
    dx, dy = delta[:, 0] / safe, delta[:, 1] / safe
    if current is None:
        return length / speed
    if isinstance(current, UniformCurrent):
        g = ground_speed(speed, *current.velocity_mps, dx, dy)
    elif isinstance(current, TidalCurrent) and kind == "mean":
        return np.where(length > 0.0, _mean_tidal(current, length, dx, dy, speed, window_s), 0.0)
    elif isinstance(current, TidalCurrent):
        (a_lo, a_hi), (vu, vv) = tide_range(current, window_s), current.velocity_mps
        g_lo = ground_speed(speed, vu * a_lo, vv * a_lo, dx, dy)
        g_hi = ground_speed(speed, vu * a_hi, vv * a_hi, dx, dy)
        g = np.where(np.isnan(g_lo) | np.isnan(g_hi), np.nan, np.fmin(g_lo, g_hi))
    else:
        return np.where(length > 0.0, _grid_times(current, p, q, length, dx, dy, speed), 0.0)
    with np.errstate(invalid="ignore"):
        times = length / g
    return np.where(length > 0.0, np.where(np.isnan(times), IMPOSSIBLE_S, times), 0.0)


def _mean_tidal(current: TidalCurrent, length: np.ndarray, dx: np.ndarray, dy: np.ndarray,
                speed: float, window_s: tuple[float, float]) -> np.ndarray:
    """Mean over the window's tide steps of length / ground speed (impossible at any step:
    `IMPOSSIBLE_S`, as `hfc_core.model.tide_clock` counts it)."""
    steps = range(current.step(window_s[0]), current.step(window_s[1]) + 1)
    total = np.zeros(len(length))
    for k in steps:
        a = current.factor(k)
        g = ground_speed(speed, current.velocity_mps[0] * a, current.velocity_mps[1] * a, dx, dy)
        with np.errstate(invalid="ignore", divide="ignore"):
            total += np.where(np.isnan(g), IMPOSSIBLE_S, length / g)
    return np.minimum(total / len(steps), IMPOSSIBLE_S)


def _grid_times(current: GridCurrent, p: np.ndarray, q: np.ndarray, length: np.ndarray,
                dx: np.ndarray, dy: np.ndarray, speed: float) -> np.ndarray:
    """Sum over each segment's pieces of piece length / ground speed at its middle, piece
    by piece in order (the order `segment_pieces` and the checker sum in)."""
    extent = np.maximum(np.abs(q[:, 0] - p[:, 0]), np.abs(q[:, 1] - p[:, 1]))
    n = np.maximum(1, np.ceil(extent / piece_m(current))).astype(np.int64)
    piece = length / n
    total = np.zeros(len(p))
    for k in range(int(n.max()) if len(n) else 0):
        live = np.flatnonzero(k < n)
        f = (k + 0.5) / n[live]
        mid = p[live, :2] + (q[live, :2] - p[live, :2]) * f[:, None]
        c = current.velocity(mid)
        g = ground_speed(speed, c[:, 0], c[:, 1], dx[live], dy[live])
        with np.errstate(invalid="ignore"):
            total[live] += np.where(np.isnan(g), IMPOSSIBLE_S, piece[live] / g)
    return np.minimum(total, IMPOSSIBLE_S)


@dataclass(frozen=True, eq=False)
class Travel:
    """Travel times of one scenario: its current, its mission window, its land."""

    current: CurrentField | None
    window_s: tuple[float, float]  # mission times the planner's tidal bound covers
    land: "LandMap | None" = None

    def matrix(self, xyz: np.ndarray, dist_m: np.ndarray, speed: float, kind: str = "bound"
               ) -> np.ndarray:
        """(m, m) planning times between the rows of ``xyz`` at water speed ``speed``;
        ``dist_m`` is the scenario's metric (its straight or around-land lengths); ``kind``:
        see `segment_times`."""
        if self.current is None:
            return dist_m / speed
        m = len(xyz)
        i, j = np.divmod(np.arange(m * m), m)
        times = segment_times(self.current, xyz[i], xyz[j], speed, self.window_s,
                              kind).reshape(m, m)
        if self.land is not None:
            self._around_land(times, xyz, xyz, speed, kind)
        np.fill_diagonal(times, 0.0)
        return times

    def times_from(self, pos: Sequence[float], targets: np.ndarray, speed: float,
                   dist_m: np.ndarray, kind: str = "bound") -> np.ndarray:
        """(t,) planning times from ``pos`` to each target (``dist_m``: their metric lengths)."""
        if self.current is None:
            return dist_m / speed
        p = np.broadcast_to(np.asarray(pos, dtype=float), targets.shape)
        times = segment_times(self.current, p, targets, speed, self.window_s, kind)
        if self.land is not None:
            row = times[None, :]
            self._around_land(row, np.asarray([pos], dtype=float), targets, speed, kind)
            times = row[0]
        return times

    def _around_land(self, times: np.ndarray, sources: np.ndarray, targets: np.ndarray,
                     speed: float, kind: str = "bound") -> None:
        """Replace the straight times of pairs that cross land by the time along their
        waypoint path (each straight piece as in `segment_times`)."""
        assert self.land is not None
        si, ti = np.divmod(np.arange(len(sources) * len(targets)), len(targets))
        seen = self.land.visible(sources[si], targets[ti])
        for s, t in zip(si[~seen], ti[~seen]):
            _, path = self.land.shortest_path(sources[s], targets[t])
            pts = np.asarray(path, dtype=float)
            times[s, t] = min(IMPOSSIBLE_S, float(segment_times(
                self.current, pts[:-1], pts[1:], speed, self.window_s, kind).sum()))

    def straight_or_land_path(self, p: Sequence[float], q: Sequence[float]) -> list[Point3]:
        """The points a leg p -> q passes through (its ends included)."""
        if self.land is None:
            return [(float(p[0]), float(p[1]), float(p[2])),
                    (float(q[0]), float(q[1]), float(q[2]))]
        return self.land.shortest_path(p, q)[1]

    def leg_time_s(self, p: Sequence[float], q: Sequence[float], speed: float,
                   t0_s: float) -> float:
        """The time the leg p -> q takes when flown from mission time ``t0_s``."""
        return path_time_s(self.current, self.straight_or_land_path(p, q), speed, t0_s)


