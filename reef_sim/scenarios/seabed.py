"""The seabed of a drawn scenario: shallow at the coast, shelving to a depth offshore.

Depth (z, negative down in a scenario) follows a simple model: ``shallow_m`` at the coast,
deepening towards ``deep_m`` with the distance to the nearest land over ``shelf_m``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from reef_sim.cotsmap import ProbabilityMap


@dataclass(frozen=True)
class SeabedParams:
    """Depth below the surface: ``shallow_m`` at the coast, ``deep_m`` far from it."""

    shallow_m: float = 3.0
    deep_m: float = 18.0
    shelf_m: float = 250.0

    def __post_init__(self) -> None:
        if not (0 <= self.shallow_m <= self.deep_m and self.shelf_m > 0):
            raise ValueError("seabed: need 0 <= shallow_m <= deep_m and shelf_m > 0")


def boundary_distance_m(x: np.ndarray, y: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Distance from points to a polygon's boundary (vectorised over points)."""
    best = np.full(np.shape(x), np.inf)
    a, b = polygon, np.roll(polygon, -1, axis=0)
    for (ax, ay), (bx, by) in zip(a, b):
        ex, ey = bx - ax, by - ay
        t = np.clip(((x - ax) * ex + (y - ay) * ey) / max(ex * ex + ey * ey, 1e-12), 0.0, 1.0)
        best = np.minimum(best, np.hypot(x - ax - t * ex, y - ay - t * ey))
    return best


def seabed_depth_m(
    cots_map: ProbabilityMap, x: np.ndarray, y: np.ndarray, seabed: SeabedParams
) -> np.ndarray:
    """Positive depth of the seabed at (x, y): the shelf deepens away from the nearest land."""
    if not cots_map.land:
        return np.full(np.shape(x), seabed.deep_m)
    coast_m = np.min([boundary_distance_m(x, y, poly) for poly in cots_map.land], axis=0)
    shelf = -np.expm1(-coast_m / seabed.shelf_m)  # 0 at the coast, -> 1 far out
    return seabed.shallow_m + (seabed.deep_m - seabed.shallow_m) * shelf
