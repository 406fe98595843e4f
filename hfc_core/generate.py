"""Scenario generator from the paper's model (eq. 1-2, section IV-A), pure and seeded.

COTS spots are drawn from the eq. (1) probability map: a grid cell is chosen with probability
proportional to ``p ** concentration`` and the spot is placed uniformly inside it. The exponent
is ours: eq. (1)'s magnitude has a 1/d tail, so sampling ``p`` itself scatters most spots far
from any centre; ``p**6`` keeps them in compact aggregations like the paper's Fig. 4 and 6
(for a lone centre, 90% of the spots lie within 2.3 r). A centre's expected share of the spots
grows as ``density**6 / radius**4``, which is how the non-uniform cluster sizes are set.
Each spot gets a priority rho ~ U(1, 100) and an injection time t ~ U(60, 90) s, or a fixed
time (eq. 2).

Land (a coastline, or islands) has zero probability and never holds a spot. Depth (z, negative
down) follows a simple seabed model: shallow at the coast, shelving to ``deep_m`` over
``shelf_m``. Land goes into the scenario's ``"forbidden"`` polygons only when asked
(``land_forbidden``): routing around land needs the land metric of `hfc_core.geometry`. The
paper preset instead cuts one corner off the square along a straight coast, so the water is
convex and no straight leg between two wet points can cross land: its plans are valid with or
without that metric.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from hfc_core.cotsmap import ProbabilityMap, VortexCentre, on_land

Point3 = tuple[float, float, float]


@dataclass(frozen=True)
class SeabedParams:
    """Depth below the surface: ``shallow_m`` at the coast, ``deep_m`` far from it."""

    shallow_m: float = 3.0
    deep_m: float = 18.0
    shelf_m: float = 250.0

    def __post_init__(self) -> None:
        if not (0 <= self.shallow_m <= self.deep_m and self.shelf_m > 0):
            raise ValueError("seabed: need 0 <= shallow_m <= deep_m and shelf_m > 0")


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


def _segment_distance_m(x: np.ndarray, y: np.ndarray, polygon: np.ndarray) -> np.ndarray:
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
    coast_m = np.min([_segment_distance_m(x, y, poly) for poly in cots_map.land], axis=0)
    shelf = -np.expm1(-coast_m / seabed.shelf_m)  # 0 at the coast, -> 1 far out
    return seabed.shallow_m + (seabed.deep_m - seabed.shallow_m) * shelf


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
    """A scenario document (see `hfc_core.scenario`) plus its ``"cots_map"``."""
    size = params.size_m
    bounds = (0.0, size, 0.0, size)
    centres = params.centres or _random_centres(params, rng)
    centres = _jittered(centres, params.centre_jitter_m, rng)
    cots_map = ProbabilityMap(bounds, centres, params.land, params.combine)
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


# -- Large areas (a few km): compact aggregations anywhere ------------------------------------
#
# Eq. (1)'s field falls off as 1/d, so summed over many centres spread over kilometres the tails
# outweigh every ring: with 24 centres on a 3 km square the summed tails in mid-field are about
# four times one ring's peak, and `generate_doc` smears the spots into one broad blob whatever
# the exponent. A large area is instead drawn as a *mixture* of aggregations: each cluster
# draws its share of the spots from its own centre's eq. (1) map (the paper's model, one centre
# at a time), so clusters stay as compact as the paper's at any area size. There is then no
# single eq. (1) map of the whole area to store, so the document has no "cots_map".


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
    a gap that shrinks with their number (as `_random_centres`)."""
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
    """A scenario document for a large area (see the section comment): ``n_clusters``
    aggregations of unequal sizes (shares U(0.3, 1), as `_random_centres`), spots with eq. (2)'s
    priorities and injection times, every vehicle starting and ending at the station."""
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


# -- Dynamic scenarios: the map, and the reef it predicts imperfectly --------------------------
#
# The prior is drawn exactly as above (the same calls on the same stream, first), so a dynamic
# scenario's tasks and map are those of the static scenario of the same seed. The hidden reef
# (`hfc_core.truth`) is drawn after it from the same stream: which predicted spots are empty, the
# real priority and injection time of the others, and aggregations the map missed.

DEFAULT_UNMAPPED_PER_90 = 12  # unmapped aggregations per 90 predicted spots (the paper's count)


@dataclass(frozen=True)
class DynamicParams:
    """A scenario drawn as the paper does (``base``: the eq. 1 field, or a large area) and the
    hidden reef it predicts: ``empty_share`` of the predicted spots hold nothing; the others
    hold a real priority ``predicted * exp(e * z - e**2 / 2)``, z ~ N(0, 1), e =
    ``priority_error`` (lognormal, right on average); ``n_unmapped`` aggregations the map missed
    lie at a Gaussian offset (``unmapped_spread_m`` per axis) from a predicted spot chosen at
    random, in the water and the area, with eq. (2)'s priority. Real injection times are drawn
    U(``service_range_s``) (eq. 2; None: the predicted one). ``detect_radius_m``, ``p_detect``
    and ``inspect_s`` are the simulated camera's (see `hfc_core.truth.Reef`)."""

    base: GeneratorParams | AreaParams = PAPER_PRESET
    empty_share: float = 0.25
    priority_error: float = 0.3
    n_unmapped: int | None = None  # None: 12 per 90 predicted spots (12 for the paper preset)
    unmapped_spread_m: float = 50.0
    service_range_s: tuple[float, float] | None = (60.0, 90.0)
    detect_radius_m: float = 25.0
    p_detect: float = 0.9
    inspect_s: float = 20.0

    def __post_init__(self) -> None:
        if not isinstance(self.base, (GeneratorParams, AreaParams)):
            raise ValueError(f"base must be GeneratorParams or AreaParams, got {self.base!r}")
        if not (math.isfinite(self.empty_share) and 0.0 <= self.empty_share <= 1.0):
            raise ValueError(f"empty_share must be in 0..1, got {self.empty_share}")
        if not (math.isfinite(self.priority_error) and self.priority_error >= 0):
            raise ValueError(f"priority_error must be >= 0, got {self.priority_error}")
        if self.n_unmapped is not None and (isinstance(self.n_unmapped, bool)
                                            or not isinstance(self.n_unmapped, int)
                                            or self.n_unmapped < 0):
            raise ValueError(f"n_unmapped must be an integer >= 0, got {self.n_unmapped}")
        if not (math.isfinite(self.unmapped_spread_m) and self.unmapped_spread_m > 0):
            raise ValueError(f"unmapped_spread_m must be positive, got {self.unmapped_spread_m}")
        if self.service_range_s is not None:
            lo, hi = self.service_range_s
            if not (0 <= lo <= hi and math.isfinite(hi)):
                raise ValueError(f"service_range_s needs 0 <= lo <= hi, got {(lo, hi)}")
        for name in ("detect_radius_m", "inspect_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be >= 0, got {value}")
        if not (math.isfinite(self.p_detect) and 0.0 <= self.p_detect <= 1.0):
            raise ValueError(f"p_detect must be in 0..1, got {self.p_detect}")

    @property
    def unmapped_count(self) -> int:
        if self.n_unmapped is not None:
            return self.n_unmapped
        return round(self.base.n_tasks * DEFAULT_UNMAPPED_PER_90 / 90)


def _water(doc: dict[str, Any], base: GeneratorParams | AreaParams) -> tuple[
        tuple[float, float, float, float], list[np.ndarray]]:
    """The area's bounds and every polygon a spot may not lie in (map land, forbidden)."""
    side = base.size_m if isinstance(base, GeneratorParams) else base.area_m
    land = [np.asarray(p, dtype=float) for p in doc.get("cots_map", {}).get("land", [])]
    land += [np.asarray(p, dtype=float) for p in doc.get("forbidden", [])]
    return (0.0, side, 0.0, side), land


def _unmapped_xy(anchors: np.ndarray, count: int, spread_m: float, doc: dict[str, Any],
                 base: GeneratorParams | AreaParams, rng: np.random.Generator) -> np.ndarray:
    """``(count, 2)`` positions near ``anchors`` (Gaussian offsets), redrawn until each lies in
    the area and at least a metre from any land (so rounding never puts one ashore)."""
    if count and not len(anchors):
        raise ValueError("no predicted spot to put the unmapped aggregations near")
    (xmin, xmax, ymin, ymax), land = _water(doc, base)
    out = np.empty((0, 2))
    for _ in range(1000):
        if len(out) >= count:
            break
        need = count - len(out)
        xy = anchors[rng.integers(len(anchors), size=need)] + rng.normal(0.0, spread_m,
                                                                         size=(need, 2))
        x, y = xy[:, 0], xy[:, 1]
        ok = (x >= xmin) & (x <= xmax) & (y >= ymin) & (y <= ymax)
        if land:
            ok &= ~on_land(land, x, y)
            ok &= np.min([_segment_distance_m(x, y, poly) for poly in land], axis=0) >= 1.0
        out = np.vstack([out, xy[ok]])
    if len(out) < count:
        raise ValueError(f"could not place {count} unmapped aggregations in the water near "
                         "the predicted spots (a smaller unmapped_spread_m?)")
    return out[:count]


def _depth_m(doc: dict[str, Any], base: GeneratorParams | AreaParams, xy: np.ndarray
             ) -> np.ndarray:
    """Positive seabed depth at ``xy``, as the predicted spots got theirs."""
    if isinstance(base, AreaParams) or "cots_map" not in doc:
        return np.full(len(xy), base.seabed.deep_m)
    cots_map = ProbabilityMap.from_dict(doc["cots_map"])
    return seabed_depth_m(cots_map, xy[:, 0], xy[:, 1], base.seabed)


def draw_truth(doc: dict[str, Any], params: DynamicParams, rng: np.random.Generator
               ) -> dict[str, Any]:
    """The hidden reef of a drawn scenario ``doc`` (its ``truth`` section; see DynamicParams).
    Draws are made for every predicted spot whatever the knobs, so the empty spots at a share
    include those at any smaller share, and the priority error only scales the same draws."""
    from hfc_core.truth import Reef, TruthSpot

    tasks = doc["tasks"]
    n = len(tasks)
    order = rng.permutation(n)
    empty = set(order[: math.floor(params.empty_share * n + 0.5)].tolist())  # halves round up
    z = rng.standard_normal(n)
    e = params.priority_error
    factor = np.exp(e * z - 0.5 * e * e)
    service_range = params.service_range_s
    real_service = rng.uniform(*service_range, size=n) if service_range else None
    spots = [TruthSpot(tuple(t["pos"]), round(float(t["priority"] * factor[i]), 2),
                       round(float(real_service[i]) if real_service is not None
                             else float(t["service_s"]), 2), i)
             for i, t in enumerate(tasks) if i not in empty]
    m = params.unmapped_count
    base = params.base
    priority = rng.uniform(*base.priority_range, size=m)
    if service_range:
        service = rng.uniform(*service_range, size=m)
    elif base.service_s is not None:
        service = np.full(m, base.service_s)
    else:
        service = rng.uniform(*base.service_range_s, size=m)
    anchors = np.array([t["pos"][:2] for t in tasks], dtype=float).reshape(-1, 2)
    xy = _unmapped_xy(anchors, m, params.unmapped_spread_m, doc, base, rng)
    depth = _depth_m(doc, base, xy)
    spots += [TruthSpot((round(float(x), 2), round(float(y), 2), -round(float(d), 2)),
                        round(float(rho), 2), round(float(t), 2), None)
              for (x, y), d, rho, t in zip(xy, depth, priority, service)]
    reef = Reef(params.detect_radius_m, params.p_detect, params.inspect_s, tuple(spots))
    return reef.to_dict()


def generate_dynamic_doc(params: DynamicParams, rng: np.random.Generator) -> dict[str, Any]:
    """A scenario drawn as `generate_doc` (or `generate_area_doc` for an `AreaParams` base)
    draws it, the same draws first, plus its hidden ``truth`` (see `DynamicParams`)."""
    base = params.base
    doc = generate_doc(base, rng) if isinstance(base, GeneratorParams) else generate_area_doc(
        base, rng)
    doc["truth"] = draw_truth(doc, params, rng)
    return doc


DYNAMIC_PRESET = DynamicParams()  # the paper's field with the defaults: the demo's scenario


def dynamic_preset_doc(seed: int) -> dict[str, Any]:
    """`paper_preset_doc(seed)` (the same tasks and map) plus a hidden reef with the defaults
    of `DynamicParams`; vehicles ``auv1..auv3``."""
    doc = generate_dynamic_doc(DYNAMIC_PRESET, np.random.default_rng(seed))
    doc["name"] = f"paper-dynamic-seed{seed}"
    return doc
