"""Water currents: the scenario's optional ``current`` section (a uniform current, a tidal
stream, or a gridded field) and a sampler for drawing it.

The paper's vehicles sense the current (H-ADCP, DVL; section III) but plan as if the water were
still (Assumption 1). On the Great Barrier Reef tidal streams are of the order of a COTSbot's
cruise speed, so the planner accounts for them: `hfc_core.model.travel` turns a field from here into
travel times. Velocities are horizontal, in m/s, ``(u, v)`` = (east, north), in the scenario's
local metres; time is mission time in seconds (0 at the start of the mission).

JSON shapes (``ScenarioError`` names the field on anything else)::

    {"kind": "uniform", "velocity_mps": [u, v]}
    {"kind": "tidal", "velocity_mps": [u, v], "period_s": 44712.0, "phase_s": 0.0}
    {"kind": "grid", "origin": [x0, y0], "cell_m": 50.0,
     "u": [[...], ...], "v": [[...], ...]}

- uniform: the same velocity everywhere, always;
- tidal: ``velocity_mps * cos(2 pi (t - phase_s) / period_s)``: the flood's peak velocity,
  reversing into the ebb (a rectilinear tidal stream, the principal lunar semi-diurnal M2
  constituent by default: 12.42 h). The stream is held constant over steps of
  ``TIDE_STEP_S`` = 60 s of mission time, at its value in the middle of the step: that is the
  model every part (planner, checker, vehicle model) integrates exactly. Against the smooth
  cosine, the leg time differs by less than ``(2 pi 60 / period)^2 / 24`` relative (4e-6 for
  M2);
- grid: node ``u[j][i], v[j][i]`` is at ``(x0 + i cell_m, y0 + j cell_m)`` (rows south to
  north), at least 2 x 2 nodes; bilinear in between; beyond the grid, the value at its nearest
  edge. Steady.

Everything here is pure: the tidal cosine is evaluated with IEEE arithmetic only (`ieee_cos`),
so that agents on different machines compute the same travel times bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any, ClassVar, Mapping, Union

import numpy as np

from hfc_core.model.errors import ScenarioError, finite

M2_PERIOD_S = 44712.0  # principal lunar semi-diurnal tide, 12.42 h
TIDE_STEP_S = 60.0  # a tidal stream is constant over each step of this much mission time

Bounds = tuple[float, float, float, float]  # xmin, xmax, ymin, ymax


@dataclass(frozen=True)
class UniformCurrent:
    """The same velocity everywhere, at all times."""

    velocity_mps: tuple[float, float]
    kind: ClassVar[str] = "uniform"
    steady: ClassVar[bool] = True

    def velocity(self, xy: np.ndarray, t_s: float = 0.0) -> np.ndarray:
        """(N, 2) velocity at the points ``xy`` (N, >= 2) at mission time ``t_s``."""
        xy = np.atleast_2d(np.asarray(xy, dtype=float))
        return np.broadcast_to(np.asarray(self.velocity_mps, dtype=float), (len(xy), 2)).copy()

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "velocity_mps": list(self.velocity_mps)}


@dataclass(frozen=True)
class TidalCurrent:
    """A rectilinear tidal stream: ``velocity_mps`` at peak flood (mission time ``phase_s``),
    ``cos``-shaped in time, held constant over steps of `TIDE_STEP_S`."""

    velocity_mps: tuple[float, float]
    period_s: float = M2_PERIOD_S
    phase_s: float = 0.0
    kind: ClassVar[str] = "tidal"
    steady: ClassVar[bool] = False

    def step(self, t_s: float) -> int:
        """The index of the tide step holding mission time ``t_s``."""
        return math.floor(t_s / TIDE_STEP_S)

    def factor(self, step: int) -> float:
        """The share of the peak velocity flowing during tide step ``step`` (-1..1)."""
        return _tide_factor(self.period_s, self.phase_s, step)

    def velocity(self, xy: np.ndarray, t_s: float = 0.0) -> np.ndarray:
        xy = np.atleast_2d(np.asarray(xy, dtype=float))
        peak = np.asarray(self.velocity_mps, dtype=float) * self.factor(self.step(t_s))
        return np.broadcast_to(peak, (len(xy), 2)).copy()

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "velocity_mps": list(self.velocity_mps),
                "period_s": self.period_s, "phase_s": self.phase_s}


@dataclass(frozen=True, eq=False)
class GridCurrent:
    """A steady field on a regular grid, bilinear between nodes, the edge value beyond."""

    origin: tuple[float, float]
    cell_m: float
    u: np.ndarray = field(repr=False)  # (ny, nx), row j at y0 + j * cell_m
    v: np.ndarray = field(repr=False)
    kind: ClassVar[str] = "grid"
    steady: ClassVar[bool] = True

    def velocity(self, xy: np.ndarray, t_s: float = 0.0) -> np.ndarray:
        xy = np.atleast_2d(np.asarray(xy, dtype=float))
        ny, nx = self.u.shape
        # Fractional grid coordinates, clamped to the grid: beyond it, the edge value.
        fx = np.clip((xy[:, 0] - self.origin[0]) / self.cell_m, 0.0, nx - 1.0)
        fy = np.clip((xy[:, 1] - self.origin[1]) / self.cell_m, 0.0, ny - 1.0)
        i = np.minimum(np.floor(fx).astype(np.int64), nx - 2)
        j = np.minimum(np.floor(fy).astype(np.int64), ny - 2)
        ax, ay = fx - i, fy - j
        out = np.empty((len(xy), 2))
        for c, grid in enumerate((self.u, self.v)):
            low = grid[j, i] * (1.0 - ax) + grid[j, i + 1] * ax
            high = grid[j + 1, i] * (1.0 - ax) + grid[j + 1, i + 1] * ax
            out[:, c] = low * (1.0 - ay) + high * ay
        return out

    def bounds(self) -> Bounds:
        ny, nx = self.u.shape
        x0, y0 = self.origin
        return (x0, x0 + (nx - 1) * self.cell_m, y0, y0 + (ny - 1) * self.cell_m)

    def max_speed_mps(self) -> float:
        return float(np.hypot(self.u, self.v).max())

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "origin": list(self.origin), "cell_m": self.cell_m,
                "u": self.u.tolist(), "v": self.v.tolist()}


CurrentField = Union[UniformCurrent, TidalCurrent, GridCurrent]


def peak_speed_mps(current: CurrentField) -> float:
    """The largest current speed the field ever has."""
    if isinstance(current, GridCurrent):
        return current.max_speed_mps()
    return math.hypot(*current.velocity_mps)


# --- JSON ---------------------------------------------------------------------------------
def current_from_dict(doc: Any) -> CurrentField:
    """Validate a scenario's ``current`` section (raises `ScenarioError`)."""
    if not isinstance(doc, Mapping):
        raise ScenarioError(f"current: expected an object, got {type(doc).__name__}")
    kind = doc.get("kind")
    if kind == "uniform":
        _only(doc, {"kind", "velocity_mps"})
        return UniformCurrent(_vector(doc, "velocity_mps"))
    if kind == "tidal":
        _only(doc, {"kind", "velocity_mps", "period_s", "phase_s"})
        period = finite(doc.get("period_s", M2_PERIOD_S), "current: period_s")
        if period <= 0:
            raise ScenarioError(f"current: period_s must be positive, got {period}")
        phase = finite(doc.get("phase_s", 0.0), "current: phase_s")
        return TidalCurrent(_vector(doc, "velocity_mps"), period, phase)
    if kind == "grid":
        _only(doc, {"kind", "origin", "cell_m", "u", "v"})
        origin = _vector(doc, "origin")
        cell = finite(_required(doc, "cell_m"), "current: cell_m")
        if cell <= 0:
            raise ScenarioError(f"current: cell_m must be positive, got {cell}")
        u, v = _grid(doc, "u"), _grid(doc, "v")
        if u.shape != v.shape:
            raise ScenarioError(f"current: u has shape {u.shape} but v has {v.shape}")
        return GridCurrent(origin, cell, u, v)
    raise ScenarioError(f"current: kind must be 'uniform', 'tidal' or 'grid', got {kind!r}")


def _required(doc: Mapping[str, Any], key: str) -> Any:
    if key not in doc:
        raise ScenarioError(f"current: missing field {key!r}")
    return doc[key]


def _only(doc: Mapping[str, Any], known: set[str]) -> None:
    # A misspelt field (say "phase" for "phase_s") must not silently fall back to a default.
    unknown = sorted(set(doc) - known)
    if unknown:
        raise ScenarioError(f"current ({doc['kind']}): unknown field(s) {unknown}; "
                            f"known: {sorted(known)}")


def _vector(doc: Mapping[str, Any], key: str) -> tuple[float, float]:
    value = _required(doc, key)
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise ScenarioError(f"current: {key} must be [x, y], got {value!r}")
    return (finite(value[0], f"current: {key}[0]"), finite(value[1], f"current: {key}[1]"))


def _grid(doc: Mapping[str, Any], key: str) -> np.ndarray:
    rows = _required(doc, key)
    if (not isinstance(rows, list) or not rows
            or not all(isinstance(r, list) for r in rows) or len({len(r) for r in rows}) != 1):
        raise ScenarioError(f"current: {key} must be a rectangular list of rows of numbers")
    values = [[finite(x, f"current: {key}[{j}][{i}]") for i, x in enumerate(r)]
              for j, r in enumerate(rows)]
    grid = np.array(values, dtype=float)
    if grid.shape[0] < 2 or grid.shape[1] < 2:
        raise ScenarioError(f"current: {key} needs at least 2 x 2 nodes, got {grid.shape} "
                            "(use kind 'uniform' for a single value)")
    grid.setflags(write=False)
    return grid


# --- drawing --------------------------------------------------------------------------------
def sample(current: CurrentField, bounds: Bounds, n: int, t_s: float = 0.0
           ) -> tuple[np.ndarray, np.ndarray]:
    """The field on an ``n`` x ``n`` grid over ``bounds`` (xmin, xmax, ymin, ymax) at mission
    time ``t_s``: ``(xy, uv)``, each ``(n * n, 2)``, row-major from (xmin, ymin) eastwards.
    For the ground station to draw arrows."""
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    xmin, xmax, ymin, ymax = bounds
    xs = np.linspace(xmin, xmax, n) if n > 1 else np.array([(xmin + xmax) / 2])
    ys = np.linspace(ymin, ymax, n) if n > 1 else np.array([(ymin + ymax) / 2])
    gx, gy = np.meshgrid(xs, ys)
    xy = np.column_stack([gx.ravel(), gy.ravel()])
    return xy, current.velocity(xy, t_s)


# --- an IEEE-only cosine ---------------------------------------------------------------------
_TWO_PI = 2.0 * math.pi
_HALF_PI = 0.5 * math.pi


def ieee_cos(x: float) -> float:
    """cos(x) to ~1e-15 with +, -, *, / and fmod only (all exactly rounded by IEEE 754), so the
    result is the same bit for bit on every machine, unlike the platform's libm ``cos``."""
    r = math.fmod(abs(x), _TWO_PI)  # exact
    if r > math.pi:
        r = _TWO_PI - r  # cos is even about pi
    sign = 1.0
    if r > _HALF_PI:
        r, sign = math.pi - r, -1.0  # cos(pi - r) = -cos(r)
    # |r| <= pi/2: Taylor series to r^26 (error < (pi/2)^28 / 28! ~ 1e-20), Horner's scheme.
    r2 = r * r
    total = 1.0
    for n in range(26, 0, -2):
        total = 1.0 - total * r2 / (n * (n - 1))
    return sign * total


@lru_cache(maxsize=4096)
def _tide_factor(period_s: float, phase_s: float, step: int) -> float:
    middle = (step + 0.5) * TIDE_STEP_S
    return ieee_cos(_TWO_PI * (middle - phase_s) / period_s)
