"""The a-priori COTS probability map of the operating field (paper eq. 1, Fig. 3 and 6).

Eq. (1) gives, for one high-density centre O with radius r and density T, a Lamb-Oseen-vortex
field at a point V (d = |V - O|)::

    tau_x = T (y - y_O) (exp(-d^2 / r^2) - 1) / (2 pi d^2)
    tau_y = T (x - x_O) (1 - exp(-d^2 / r^2)) / (2 pi d^2)

whose magnitude is ``T (1 - exp(-d^2/r^2)) / (2 pi d)``: zero at the centre, a ring of highest
density at d ~ 1.12 r, and a 1/d tail. The paper does not say how several centres combine. We
read the field's magnitude as a COTS density, and since densities of separate aggregations add,
the default combines centres as the **sum of per-centre magnitudes** (``"sum"``). The literal
vector reading, the **magnitude of the summed field** (``"vector"``), lets neighbouring vortices
cancel or reinforce; it is available for comparison. Either way the map is normalised to [0, 1]
by its maximum over a fixed reference grid and is zero on land (coastline and islands, given as
polygons), as in the paper's black shore areas.

Pure and JSON-able: the scenario generator stores ``to_dict()`` under the scenario's
``"cots_map"`` field, and the dashboard draws ``grid()``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from hfc_core.model.errors import ScenarioError, finite

COMBINE_MODES = ("sum", "vector")
_REFERENCE_CELLS = 400  # cells per side of the grid that fixes the normalisation


@dataclass(frozen=True)
class VortexCentre:
    """One high-density COTS area of eq. (1): centre O (m), radius r (m), density T."""

    x_m: float
    y_m: float
    radius_m: float
    density: float

    def __post_init__(self) -> None:
        for name in ("x_m", "y_m", "radius_m", "density"):
            object.__setattr__(self, name, finite(getattr(self, name), f"cots centre {name}"))
        if self.radius_m <= 0:
            raise ScenarioError(f"cots centre radius_m must be positive, got {self.radius_m}")
        if self.density <= 0:
            raise ScenarioError(f"cots centre density must be positive, got {self.density}")

    def field(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(tau_x, tau_y) of eq. (1); the removable singularity at O is filled with its limit 0."""
        dx, dy = x - self.x_m, y - self.y_m
        d2 = dx * dx + dy * dy
        with np.errstate(invalid="ignore", divide="ignore"):
            # (1 - e^{-d^2/r^2}) / d^2 -> 1/r^2 as d -> 0
            g = np.where(d2 > 0, -np.expm1(-d2 / self.radius_m**2) / d2, 1.0 / self.radius_m**2)
        scale = self.density * g / (2.0 * math.pi)
        return -scale * dy, scale * dx


def points_in_polygon(x: np.ndarray, y: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Even-odd rule, vectorised over points; ``polygon`` is ``(m, 2)``, open or closed."""
    inside = np.zeros(np.broadcast(x, y).shape, dtype=bool)
    xs, ys = polygon[:, 0], polygon[:, 1]
    for (x0, y0), (x1, y1) in zip(zip(xs, ys), zip(np.roll(xs, -1), np.roll(ys, -1))):
        if y0 == y1:
            continue  # a horizontal edge never crosses a horizontal ray
        crosses = (y0 > y) != (y1 > y)
        x_cross = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
        inside ^= crosses & (x < x_cross)
    return inside


def on_land(polygons: Sequence[ArrayLike], x: Any, y: Any) -> np.ndarray:
    """True where (x, y) lies inside any of ``polygons`` (vectorised)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    mask = np.zeros(np.broadcast(x, y).shape, dtype=bool)
    for poly in polygons:
        mask |= points_in_polygon(x, y, np.asarray(poly, dtype=float))
    return mask


def _polygon(points: Any, where: str) -> np.ndarray:
    try:
        arr = np.asarray(points, dtype=float)
    except (TypeError, ValueError):
        raise ScenarioError(f"{where}: expected [[x, y], ...]") from None
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 3 or not np.all(np.isfinite(arr)):
        raise ScenarioError(f"{where}: a polygon needs at least 3 finite [x, y] vertices")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class ProbabilityMap:
    """COTS probability over ``bounds = (xmin, xmax, ymin, ymax)`` in metres (eq. 1)."""

    bounds: tuple[float, float, float, float]
    centres: tuple[VortexCentre, ...]
    land: tuple[np.ndarray, ...] = ()
    combine: str = "sum"
    _peak: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if len(self.bounds) != 4:
            raise ScenarioError("cots_map bounds: expected [xmin, xmax, ymin, ymax]")
        b = tuple(finite(v, "cots_map bounds") for v in self.bounds)
        if not (b[0] < b[1] and b[2] < b[3]):
            raise ScenarioError(f"cots_map bounds: need xmin < xmax and ymin < ymax, got {b}")
        if not self.centres:
            raise ScenarioError("cots_map: needs at least one centre")
        if self.combine not in COMBINE_MODES:
            raise ScenarioError(f"cots_map combine must be one of {COMBINE_MODES}")
        object.__setattr__(self, "bounds", b)
        object.__setattr__(self, "centres", tuple(self.centres))
        land = tuple(_polygon(p, f"cots_map land[{i}]") for i, p in enumerate(self.land))
        object.__setattr__(self, "land", land)
        xs, ys = self._cell_centres(max(b[1] - b[0], b[3] - b[2]) / _REFERENCE_CELLS)
        peak = float(self._raw(*np.meshgrid(xs, ys)).max())
        object.__setattr__(self, "_peak", peak if peak > 0 else 1.0)

    def _raw(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Unnormalised eq. (1) magnitude, land not yet masked."""
        if self.combine == "sum":
            return sum(np.hypot(*c.field(x, y)) for c in self.centres)
        tx, ty = np.zeros_like(x, dtype=float), np.zeros_like(y, dtype=float)
        for c in self.centres:
            fx, fy = c.field(x, y)
            tx, ty = tx + fx, ty + fy
        return np.hypot(tx, ty)

    def _cell_centres(self, resolution_m: float) -> tuple[np.ndarray, np.ndarray]:
        xmin, xmax, ymin, ymax = self.bounds
        nx = max(1, int(math.ceil((xmax - xmin) / resolution_m - 1e-9)))
        ny = max(1, int(math.ceil((ymax - ymin) / resolution_m - 1e-9)))
        return xmin + (np.arange(nx) + 0.5) * (xmax - xmin) / nx, ymin + (
            np.arange(ny) + 0.5
        ) * (ymax - ymin) / ny

    def on_land(self, x: Any, y: Any) -> np.ndarray:
        """True where (x, y) lies inside a land polygon (vectorised)."""
        return on_land(self.land, x, y)

    def density(self, x: Any, y: Any) -> np.ndarray:
        """COTS probability in [0, 1] at (x, y), vectorised; 0 on land and outside ``bounds``."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        p = np.clip(self._raw(x, y) / self._peak, 0.0, 1.0)
        xmin, xmax, ymin, ymax = self.bounds
        outside = (x < xmin) | (x > xmax) | (y < ymin) | (y > ymax)
        return np.where(outside | self.on_land(x, y), 0.0, p)

    def grid(self, resolution_m: float) -> tuple[np.ndarray, tuple[float, float, float, float]]:
        """``(prob[ny, nx], (xmin, xmax, ymin, ymax))`` sampled at cell centres, row 0 at ymin."""
        if not (math.isfinite(resolution_m) and resolution_m > 0):
            raise ValueError(f"resolution_m must be positive, got {resolution_m}")
        xs, ys = self._cell_centres(resolution_m)
        gx, gy = np.meshgrid(xs, ys)
        return self.density(gx, gy), self.bounds

    def land_polygons(self) -> list[list[list[float]]]:
        """Land as ``[[x, y], ...]`` lists: the shape of a scenario's ``forbidden`` field."""
        return [poly.tolist() for poly in self.land]

    def to_dict(self) -> dict[str, Any]:
        return {
            "bounds": list(self.bounds),
            "combine": self.combine,
            "centres": [
                {"x_m": c.x_m, "y_m": c.y_m, "radius_m": c.radius_m, "density": c.density}
                for c in self.centres
            ],
            "land": self.land_polygons(),
        }

    @staticmethod
    def from_dict(doc: Mapping[str, Any]) -> "ProbabilityMap":
        """Inverse of `to_dict` (raises `ScenarioError` on a malformed document)."""
        if not isinstance(doc, Mapping):
            raise ScenarioError("cots_map: expected an object")
        try:
            bounds = doc["bounds"]
            raw_centres = doc["centres"]
        except KeyError as exc:
            raise ScenarioError(f"cots_map: missing field {exc.args[0]!r}") from None
        if not isinstance(bounds, Sequence) or not isinstance(raw_centres, Sequence):
            raise ScenarioError("cots_map: bounds and centres must be lists")
        centres = []
        for i, c in enumerate(raw_centres):
            if not isinstance(c, Mapping):
                raise ScenarioError(f"cots_map centres[{i}]: expected an object")
            try:
                centres.append(
                    VortexCentre(c["x_m"], c["y_m"], c["radius_m"], c["density"])
                )
            except KeyError as exc:
                raise ScenarioError(f"cots_map centres[{i}]: missing {exc.args[0]!r}") from None
        land = doc.get("land", [])
        if not isinstance(land, Sequence):
            raise ScenarioError("cots_map land: expected a list of polygons")
        return ProbabilityMap(
            bounds=tuple(bounds),
            centres=tuple(centres),
            land=tuple(land),
            combine=str(doc.get("combine", "sum")),
        )


def cots_map_of(scenario_doc: Mapping[str, Any]) -> ProbabilityMap | None:
    """The map the generator stored in a scenario document, or None if it has none."""
    if not isinstance(scenario_doc, Mapping) or scenario_doc.get("cots_map") is None:
        return None
    return ProbabilityMap.from_dict(scenario_doc["cots_map"])
