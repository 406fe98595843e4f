"""Scenarios over large areas (a few km): compact COTS aggregations anywhere.

Eq. (1)'s field falls off as 1/d, so summed over many centres spread over kilometres the tails
outweigh every ring: with 24 centres on a 3 km square the summed tails in mid-field are about
four times one ring's peak, and `generate_doc` smears the spots into one broad blob whatever
the exponent. A large area is instead drawn as a *mixture* of aggregations: each cluster
draws its share of the spots from its own centre's eq. (1) map (the paper's model, one centre
at a time), so clusters stay as compact as the paper's at any area size. There is then no
single eq. (1) map of the whole area to store, so the document has no "cots_map".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from reef_sim.cotsmap import ProbabilityMap, VortexCentre
from reef_sim.scenarios.field import GeneratorParams, sample_spots_m
from reef_sim.scenarios.seabed import SeabedParams

Point3 = tuple[float, float, float]


@dataclass(frozen=True)
class AreaParams:
    """A square area of side ``area_m`` with ``n_clusters`` COTS aggregations spread over it and
    one station (start and rendezvous of every vehicle, a support vessel) at its centre."""

    name: str = "area"
    n_tasks: int = 90
    n_vehicles: int = 3
    area_m: float = 3000.0
    battery_s: float = 3600.0
    speed_mps: float = 1.0
    service_s: float | None = None  # fixed injection time; None draws U(service_range_s)
    service_range_s: tuple[float, float] = (60.0, 90.0)
    priority_range: tuple[float, float] = (1.0, 100.0)
    n_clusters: int | None = None  # default: one per vehicle
    # A cluster of ``cluster_spots`` spots has radius ``cluster_radius_m`` (the paper's: about
    # 30 spots within r = 32-40 m); radii grow as sqrt(spots) so the density stays the paper's.
    cluster_radius_m: float = 40.0
    cluster_spots: int = 30
    margin: float = 0.1  # cluster centres stay this share of the side away from the edges
    station: Point3 | None = None  # default: the centre of the area, at the surface
    concentration: float = 6.0
    seabed: SeabedParams = field(default_factory=SeabedParams)

    def __post_init__(self) -> None:
        if self.n_tasks < 0 or self.n_vehicles < 1:
            raise ValueError("need n_tasks >= 0 and n_vehicles >= 1")
        for name in ("area_m", "battery_s", "speed_mps", "cluster_radius_m", "concentration"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be positive and finite, got {value}")
        if self.service_s is not None and not (math.isfinite(self.service_s)
                                               and self.service_s >= 0):
            raise ValueError(f"service_s must be >= 0, got {self.service_s}")
        for name in ("service_range_s", "priority_range"):
            lo, hi = getattr(self, name)
            if not (0 <= lo <= hi):
                raise ValueError(f"{name} needs 0 <= lo <= hi, got {(lo, hi)}")
        if self.n_clusters is not None and self.n_clusters < 1:
            raise ValueError("n_clusters must be >= 1")
        if self.cluster_spots < 1:
            raise ValueError("cluster_spots must be >= 1")
        if not 0 <= self.margin < 0.5:
            raise ValueError(f"margin must be in [0, 0.5), got {self.margin}")
        if self.station is not None and not all(
                0 <= c <= self.area_m for c in self.station[:2]):
            raise ValueError(f"station {self.station} lies outside the area")

    @property
    def station_point(self) -> Point3:
        return self.station or (self.area_m / 2.0, self.area_m / 2.0, 0.0)


def _cluster_centres(params: AreaParams, count: int, rng: np.random.Generator) -> np.ndarray:
    """``(count, 2)`` centres uniform over the area within the margin, no two closer than
    a gap that shrinks with their number (as `reef_sim.scenarios.field` places its centres)."""
    lo, hi = params.margin * params.area_m, (1.0 - params.margin) * params.area_m
    min_gap = (hi - lo) / (2.0 * math.sqrt(count) + 1.0)
    centres: list[tuple[float, float]] = []
    for _ in range(1000 * count):
        if len(centres) == count:
            break
        x, y = rng.uniform(lo, hi, size=2)
        if all(math.hypot(x - cx, y - cy) >= min_gap for cx, cy in centres):
            centres.append((float(x), float(y)))
    if len(centres) < count:
        raise ValueError(f"could not place {count} COTS aggregations {min_gap:.0f} m apart")
    return np.array(centres)


def _aggregation_spots(centre: np.ndarray, radius_m: float, n: int, params: AreaParams,
                       rng: np.random.Generator) -> np.ndarray:
    """``(n, 2)`` spots of one aggregation: its own eq. (1) map, sampled as `sample_spots_m`
    does (weights p ** concentration) on a window of 6 radii around the centre (beyond it
    p ** 6 ~ (r/d) ** 6 leaves under a thousandth of the mass), clipped to the area."""
    half = 6.0 * radius_m
    x0, y0 = max(0.0, centre[0] - half), max(0.0, centre[1] - half)
    x1, y1 = min(params.area_m, centre[0] + half), min(params.area_m, centre[1] + half)
    cots_map = ProbabilityMap((x0, x1, y0, y1),
                              (VortexCentre(float(centre[0]), float(centre[1]), radius_m, 1.0),))
    sampling = GeneratorParams(resolution_m=radius_m / 8.0, concentration=params.concentration)
    return sample_spots_m(cots_map, n, sampling, rng)


def generate_area_doc(params: AreaParams, rng: np.random.Generator) -> dict[str, Any]:
    """A scenario document for a large area (see the module doc): ``n_clusters``
    aggregations of unequal sizes (shares U(0.3, 1), as in `reef_sim.scenarios.field`), spots
    with eq. (2)'s priorities and injection times, every vehicle starting and ending at the
    station."""
    count = params.n_clusters or params.n_vehicles
    centres = _cluster_centres(params, count, rng)
    shares = rng.uniform(0.3, 1.0, size=count)
    sizes = rng.multinomial(params.n_tasks, shares / shares.sum())
    radii = params.cluster_radius_m * rng.uniform(0.8, 1.0, size=count) * np.sqrt(
        np.maximum(sizes, 1) / params.cluster_spots)
    radii = np.maximum(radii, 0.25 * params.cluster_radius_m)
    xy = np.vstack([np.empty((0, 2))] + [
        _aggregation_spots(c, float(r), int(n), params, rng)
        for c, r, n in zip(centres, radii, sizes) if n > 0])
    xy = xy[rng.permutation(len(xy))]  # ids carry no cluster order
    lo, hi = params.priority_range
    priority = rng.uniform(lo, hi, size=params.n_tasks)
    if params.service_s is None:
        service = rng.uniform(*params.service_range_s, size=params.n_tasks)
    else:
        service = np.full(params.n_tasks, params.service_s)
    depth = params.seabed.deep_m  # open water: no coast to shelve towards
    station = [float(c) for c in params.station_point]
    return {
        "name": params.name,
        "speed_mps": params.speed_mps,
        "vehicles": [{"id": f"auv{i + 1}", "start": station, "rendezvous": list(station),
                      "battery_s": params.battery_s} for i in range(params.n_vehicles)],
        "tasks": [{"id": i + 1,
                   "pos": [round(float(x), 2), round(float(y), 2), -round(float(depth), 2)],
                   "priority": round(float(rho), 2), "service_s": round(float(t), 2)}
                  for i, ((x, y), rho, t) in enumerate(zip(xy, priority, service))],
    }


def out_of_reach(doc: dict[str, Any]) -> int:
    """How many spots no vehicle could treat even alone: station to spot, injection, spot to
    rendezvous beyond the battery (straight legs in still water)."""
    speed = float(doc["speed_mps"])
    worst = 0
    for v in doc["vehicles"]:
        start, end = np.array(v["start"], float), np.array(v["rendezvous"], float)
        pos = np.array([t["pos"] for t in doc["tasks"]], float).reshape(-1, 3)
        service = np.array([t["service_s"] for t in doc["tasks"]], float)
        need = (np.linalg.norm(pos - start, axis=1) + np.linalg.norm(pos - end, axis=1)) / speed
        worst = max(worst, int(np.count_nonzero(need + service > float(v["battery_s"]))))
    return worst
