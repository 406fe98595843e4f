"""Scenarios drawn from the paper's model (eq. 1-2, section IV-A), pure and seeded; the paper's
preset.

COTS spots are drawn from the eq. (1) probability map: a grid cell is chosen with probability
proportional to ``p ** concentration`` and the spot is placed uniformly inside it. The exponent
is ours: eq. (1)'s magnitude has a 1/d tail, so sampling ``p`` itself scatters most spots far
from any centre; ``p**6`` keeps them in compact aggregations like the paper's Fig. 4 and 6
(for a lone centre, 90% of the spots lie within 2.3 r). A centre's expected share of the spots
grows as ``density**6 / radius**4``, which is how the non-uniform cluster sizes are set.
Each spot gets a priority rho ~ U(1, 100) and an injection time t ~ U(60, 90) s, or a fixed
time (eq. 2).

Land (a coastline, or islands) has zero probability and never holds a spot. Depth (z, negative
down) follows the seabed of `reef_sim.scenarios.seabed`. Land goes into the scenario's
``"forbidden"`` polygons only when asked (``land_forbidden``): routing around land needs the
land metric of `hfc_core.model.geometry`. The paper preset instead cuts one corner off the
square along a straight coast, so the water is convex and no straight leg between two wet
points can cross land: its plans are valid with or without that metric.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from reef_sim.cotsmap import ProbabilityMap, VortexCentre, on_land
from reef_sim.scenarios.seabed import SeabedParams, seabed_depth_m

Point3 = tuple[float, float, float]


@dataclass(frozen=True)
class GeneratorParams:
    """Everything a generated scenario depends on besides the random stream."""

    name: str = "generated"
    n_tasks: int = 90
    n_vehicles: int = 3
    size_m: float = 1000.0  # the square operating field [0, size_m]^2
    battery_s: float = 3600.0
    speed_mps: float = 1.0
    service_s: float | None = None  # fixed injection time; None draws U(service_range_s)
    service_range_s: tuple[float, float] = (60.0, 90.0)
    priority_range: tuple[float, float] = (1.0, 100.0)
    centres: tuple[VortexCentre, ...] | None = None  # None: ``n_centres`` random centres
    n_centres: int | None = None  # default: one per vehicle
    centre_jitter_m: float = 0.0  # Gaussian displacement of given centres (Monte Carlo)
    land: tuple[tuple[tuple[float, float], ...], ...] = ()
    land_forbidden: bool = False  # also write land as the scenario's "forbidden" polygons
    start: Point3 | None = None  # default: near the (0, 0) corner, at the surface
    rendezvous: Point3 | None = None  # default: near the opposite corner
    concentration: float = 6.0
    resolution_m: float = 5.0  # sampling grid
    combine: str = "sum"
    seabed: SeabedParams = field(default_factory=SeabedParams)

    def __post_init__(self) -> None:
        if self.n_tasks < 0 or self.n_vehicles < 1:
            raise ValueError("need n_tasks >= 0 and n_vehicles >= 1")
        for name in ("size_m", "battery_s", "speed_mps", "resolution_m", "concentration"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be positive and finite, got {value}")
        lo, hi = self.service_range_s
        service = self.service_s
        if service is not None and not (math.isfinite(service) and service >= 0):
            raise ValueError(f"service_s must be >= 0, got {self.service_s}")
        if not (0 <= lo <= hi):
            raise ValueError(f"service_range_s needs 0 <= lo <= hi, got {self.service_range_s}")
        if not (0 <= self.priority_range[0] <= self.priority_range[1]):
            raise ValueError(f"priority_range needs 0 <= lo <= hi, got {self.priority_range}")
        if self.n_centres is not None and self.n_centres < 1:
            raise ValueError("n_centres must be >= 1")
        if self.centre_jitter_m < 0:
            raise ValueError("centre_jitter_m must be >= 0")


def _random_centres(params: GeneratorParams, rng: np.random.Generator) -> tuple[VortexCentre, ...]:
    """Centres spread over the field (not on land, not on top of each other), with unequal
    densities so that clusters differ in size, as in the paper's Fig. 6."""
    count = params.n_centres or params.n_vehicles
    size = params.size_m
    min_gap = size / (2.0 * math.sqrt(count) + 1.0)
    centres: list[VortexCentre] = []
    for _ in range(1000 * count):
        if len(centres) == count:
            break
        x, y = rng.uniform(0.15 * size, 0.85 * size, size=2)
        crowded = any(math.hypot(x - c.x_m, y - c.y_m) < min_gap for c in centres)
        if crowded or on_land(params.land, x, y):
            continue
        radius = rng.uniform(0.03, 0.05) * size
        # a share in U(0.3, 1) of the spots, relative to the other centres (see module doc)
        share = rng.uniform(0.3, 1.0)
        gamma = params.concentration
        density = (share * radius ** (gamma - 2.0)) ** (1.0 / gamma)
        centres.append(VortexCentre(x, y, radius, density))
    if len(centres) < count:
        raise ValueError(f"could not place {count} COTS centres on the water of this field")
    return tuple(centres)


def _jittered(
    centres: tuple[VortexCentre, ...], sigma_m: float, rng: np.random.Generator
) -> tuple[VortexCentre, ...]:
    if sigma_m == 0:
        return centres
    shift = rng.normal(0.0, sigma_m, size=(len(centres), 2))
    return tuple(replace(c, x_m=c.x_m + dx, y_m=c.y_m + dy) for c, (dx, dy) in zip(centres, shift))


def sample_spots_m(
    cots_map: ProbabilityMap, n: int, params: GeneratorParams, rng: np.random.Generator
) -> np.ndarray:
    """``(n, 2)`` spot positions drawn from the map (weights ``p ** concentration``), off land."""
    prob, (xmin, xmax, ymin, ymax) = cots_map.grid(params.resolution_m)
    weights = (prob**params.concentration).ravel()
    if n and not weights.sum() > 0:
        raise ValueError("the COTS map is zero everywhere: nowhere to put a spot")
    ny, nx = prob.shape
    cell_w, cell_h = (xmax - xmin) / nx, (ymax - ymin) / ny
    out = np.empty((0, 2))
    while len(out) < n:  # a spot jittered across a coastline is redrawn, never moved
        cells = rng.choice(weights.size, size=n - len(out), p=weights / weights.sum())
        iy, ix = np.divmod(cells, nx)
        x = xmin + (ix + rng.random(len(cells))) * cell_w
        y = ymin + (iy + rng.random(len(cells))) * cell_h
        wet = ~cots_map.on_land(x, y)
        out = np.vstack([out, np.column_stack([x[wet], y[wet]])])
    return out


def generate_doc(params: GeneratorParams, rng: np.random.Generator) -> dict[str, Any]:
    """A scenario document (see `hfc_core.formats.scenario`) plus its ``"cots_map"``."""
    size = params.size_m
    bounds = (0.0, size, 0.0, size)
    centres = params.centres or _random_centres(params, rng)
    centres = _jittered(centres, params.centre_jitter_m, rng)
    land = tuple(np.asarray(p, dtype=float) for p in params.land)
    cots_map = ProbabilityMap(bounds, centres, land, params.combine)
    xy = sample_spots_m(cots_map, params.n_tasks, params, rng)
    depth = seabed_depth_m(cots_map, xy[:, 0], xy[:, 1], params.seabed)
    lo, hi = params.priority_range
    priority = rng.uniform(lo, hi, size=params.n_tasks)
    if params.service_s is None:
        service = rng.uniform(*params.service_range_s, size=params.n_tasks)
    else:
        service = np.full(params.n_tasks, params.service_s)
    start = params.start or (0.05 * size, 0.05 * size, 0.0)
    rendezvous = params.rendezvous or (0.95 * size, 0.95 * size, 0.0)
    for name, point in (("start", start), ("rendezvous", rendezvous)):
        if cots_map.on_land(point[0], point[1]):
            raise ValueError(f"the {name} point {point} is on land")
    doc: dict[str, Any] = {
        "name": params.name,
        "speed_mps": params.speed_mps,
        "vehicles": [
            {
                "id": f"auv{i + 1}",
                "start": [float(c) for c in start],
                "rendezvous": [float(c) for c in rendezvous],
                "battery_s": params.battery_s,
            }
            for i in range(params.n_vehicles)
        ],
        "tasks": [
            {
                "id": i + 1,
                "pos": [round(float(x), 2), round(float(y), 2), -round(float(z), 2)],
                "priority": round(float(rho), 2),
                "service_s": round(float(t), 2),
            }
            for i, ((x, y), z, rho, t) in enumerate(zip(xy, depth, priority, service))
        ],
        "cots_map": cots_map.to_dict(),
    }
    if params.land_forbidden and params.land:
        doc["forbidden"] = cots_map.land_polygons()
    return doc


# The paper's section IV-A setting: 90 spots, 1 km^2, 3 AUVs, 3600 s battery, 1 m/s, 90 s
# injection, common start and rendezvous, non-uniform clusters (one small one, Fig. 6). The
# coast cuts the north-west corner along a straight line, so the water is convex.
PAPER_PRESET = GeneratorParams(
    name="paper",
    n_tasks=90,
    n_vehicles=3,
    size_m=1000.0,
    battery_s=3600.0,
    speed_mps=1.0,
    service_s=90.0,
    centres=(
        VortexCentre(300.0, 560.0, 40.0, 3.4),
        VortexCentre(760.0, 300.0, 32.0, 2.3),  # the small cluster (2) of Fig. 6
        VortexCentre(640.0, 740.0, 40.0, 3.3),
    ),
    centre_jitter_m=30.0,  # the Monte Carlo's "Gaussian deformation" of the topology
    land=(((0.0, 1000.0), (0.0, 760.0), (240.0, 1000.0)),),
    start=(80.0, 80.0, 0.0),
    rendezvous=(920.0, 920.0, 0.0),
)


def paper_preset_doc(seed: int) -> dict[str, Any]:
    """The paper's scenario (section IV-A) drawn with ``seed``; vehicles ``auv1..auv3``."""
    doc = generate_doc(PAPER_PRESET, np.random.default_rng(seed))
    doc["name"] = f"paper-seed{seed}"
    return doc
