"""A reef in GeoJSON (longitude/latitude) -> a scenario document in local metres.

Each feature's ``role`` property says what it is (see `ROLES`). Land and no-go polygons become
the scenario's ``forbidden`` polygons, COTS points its tasks, start and rendezvous points its
vehicles' stations, truth points its hidden ``truth`` section; the projection goes into its
``geo`` section (`cotsfleet.geo.frame.LocalFrame`) so that plans can be put back on the globe.
Every error is a `ScenarioError` naming the feature (its index in ``features``) and why.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
import shapely
from shapely.geometry import Point, Polygon
from shapely.validation import explain_validity

from cotsfleet.geo.frame import LocalFrame
from fleet_agent.wire import MAX_VEHICLES
from hfc_core.model.errors import ScenarioError

ROLES = {
    "land": "Polygon or MultiPolygon: land (an island, a cay, the coast)",
    "no_go": "Polygon or MultiPolygon: water the vehicles must not enter (reef flat, moorings)",
    "cots": "Point: a COTS spot to inject; properties priority, optional service_s and id",
    "start": "Point: where vehicles start (one shared, or one per vehicle in order)",
    "rendezvous": "Point: where vehicles are recovered (default: the start)",
    "truth": "Point: what is really there (emulation); properties priority, optional "
             "service_s, optional task (the id of the predicted cots spot, or null)",
}
POLYGON_ROLES = ("land", "no_go")
# GeoJSON (RFC 7946) is WGS 84 longitude/latitude; files from before it may name their CRS.
LONLAT_CRS_NAMES = {"urn:ogc:def:crs:OGC:1.3:CRS84", "urn:ogc:def:crs:OGC::CRS84",
                    "urn:ogc:def:crs:EPSG::4326", "EPSG:4326", "CRS84"}
MANY_VERTICES = 400  # beyond this the land visibility graph gets slow: suggest --simplify-m


@dataclass(frozen=True)
class ReefOptions:
    """What the GeoJSON does not say: the fleet, defaults for spots, the truth sensor."""

    name: str | None = None
    vehicles: int | None = None  # default: one per start point if several, else 3
    battery_s: float = 3600.0
    speed_mps: float = 1.0
    service_s: float | None = None  # for spots without service_s; None: U(service_range_s)
    service_range_s: tuple[float, float] = (60.0, 90.0)  # the paper's eq. (2)
    seed: int = 0  # draws the default service times
    detect_radius_m: float = 25.0  # truth: the camera sees a spot within this range
    p_detect: float = 0.9  # truth: chance a pass within range sees it
    inspect_s: float = 20.0  # truth: time to look at a predicted spot
    simplify_m: float = 0.0  # simplify polygons to this tolerance (never shrinking them)

    def __post_init__(self) -> None:
        for name in ("battery_s", "speed_mps"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be positive and finite, got {value}")
        for name in ("detect_radius_m", "inspect_s", "simplify_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be >= 0, got {value}")
        if self.service_s is not None and not (math.isfinite(self.service_s)
                                               and self.service_s >= 0):
            raise ValueError(f"service_s must be >= 0, got {self.service_s}")
        if not 0.0 <= self.p_detect <= 1.0:
            raise ValueError(f"p_detect must be in 0..1, got {self.p_detect}")
        if self.vehicles is not None and not 1 <= self.vehicles <= MAX_VEHICLES:
            raise ValueError(f"vehicles must be 1..{MAX_VEHICLES}, got {self.vehicles}")


@dataclass(frozen=True)
class _Feature:
    index: int
    role: str
    props: Mapping[str, Any]
    geometry: Mapping[str, Any]

    @property
    def label(self) -> str:
        name = self.props.get("name")
        return f"feature {self.index}" + (f" ({name!r})" if isinstance(name, str) else "")


def scenario_from_geojson(doc: Any, options: ReefOptions,
                          fallback_name: str = "reef") -> dict[str, Any]:
    """The scenario document of a GeoJSON reef (raises `ScenarioError`). Its name is
    ``options.name``, else the FeatureCollection's ``name``, else ``fallback_name``."""
    features = _features(doc)
    by_role: dict[str, list[_Feature]] = {r: [] for r in ROLES}
    for f in features:
        by_role[f.role].append(f)
    if not by_role["cots"]:
        raise ScenarioError("no feature with role 'cots': nothing to plan")
    if not by_role["start"]:
        raise ScenarioError("no feature with role 'start': where do the vehicles start?")
    points = {f.index: _point(f) for r in ROLES if r not in POLYGON_ROLES for f in by_role[r]}
    rings = {f.index: _polygons(f) for r in POLYGON_ROLES for f in by_role[r]}
    every = [p[:2] for p in points.values()] + [xy for polys in rings.values()
                                                for ring in polys for xy in ring]
    lonlat = np.array(every, dtype=float)
    frame = LocalFrame.around(lonlat[:, 0], lonlat[:, 1])

    forbidden, roles = _forbidden([f for f in features if f.role in POLYGON_ROLES], rings,
                                  frame, options.simplify_m)
    local = {i: _local(frame, p) for i, p in points.items()}
    _require_water(points, local, forbidden, roles, features)

    rng = np.random.default_rng(options.seed)
    tasks = _tasks(by_role["cots"], local, options, rng)
    vehicles = _vehicles(by_role, local, options)
    scenario: dict[str, Any] = {
        "name": options.name or _name(doc) or fallback_name,
        "speed_mps": options.speed_mps,
        "vehicles": vehicles,
        "tasks": tasks,
        "forbidden": [[[round(x, 2), round(y, 2)] for x, y in poly.exterior.coords[:-1]]
                      for poly in forbidden],
        "geo": {**frame.to_dict(), "forbidden_roles": roles},
    }
    if not forbidden:
        del scenario["forbidden"]
    if by_role["truth"]:
        scenario["truth"] = _truth(by_role["truth"], local, tasks, options, rng)
    return scenario


def polygon_vertices(scenario: Mapping[str, Any]) -> int:
    """How many vertices the scenario's forbidden polygons have in all."""
    return sum(len(p) for p in scenario.get("forbidden", []))


# --- reading the GeoJSON ---------------------------------------------------------------------

def _features(doc: Any) -> list[_Feature]:
    if isinstance(doc, Mapping) and doc.get("type") == "Feature":
        doc = {"type": "FeatureCollection", "features": [doc]}
    if not isinstance(doc, Mapping) or doc.get("type") != "FeatureCollection":
        kind = doc.get("type") if isinstance(doc, Mapping) else type(doc).__name__
        raise ScenarioError(f"not a GeoJSON FeatureCollection (type {kind!r})")
    _require_lonlat_crs(doc.get("crs"))
    raw = doc.get("features")
    if not isinstance(raw, list):
        raise ScenarioError("not GeoJSON: 'features' must be a list")
    out = []
    for i, f in enumerate(raw):
        if not isinstance(f, Mapping) or f.get("type") != "Feature":
            raise ScenarioError(f"feature {i}: not a GeoJSON Feature")
        props = f.get("properties") or {}
        geometry = f.get("geometry")
        if not isinstance(props, Mapping):
            raise ScenarioError(f"feature {i}: properties must be an object")
        if not isinstance(geometry, Mapping):
            raise ScenarioError(f"feature {i}: no geometry")
        role = props.get("role")
        if role is None:
            raise ScenarioError(f"feature {i}: no 'role' property; give one of "
                                f"{', '.join(ROLES)}")
        if role not in ROLES:
            raise ScenarioError(f"feature {i}: unknown role {role!r}; known: {', '.join(ROLES)}")
        out.append(_Feature(i, role, props, geometry))
    return out


def _require_lonlat_crs(crs: Any) -> None:
    if crs is None:
        return
    name = crs.get("properties", {}).get("name") if isinstance(crs, Mapping) else None
    if name not in LONLAT_CRS_NAMES:
        raise ScenarioError(
            f"the file declares crs {name or crs!r}; GeoJSON must be WGS 84 longitude/latitude "
            "(RFC 7946): reproject it, e.g. ogr2ogr -f GeoJSON -t_srs EPSG:4326 out.geojson in")


def _position(value: Any, where: str) -> tuple[float, float, float]:
    """``[lon, lat]`` or ``[lon, lat, altitude]`` checked for range (altitude: metres,
    negative below the sea surface, as GeoJSON altitudes are)."""
    if not isinstance(value, (list, tuple)) or len(value) not in (2, 3) or not all(
            isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c)
            for c in value):
        raise ScenarioError(f"{where}: expected [longitude, latitude] numbers, got {value!r}")
    lon, lat = float(value[0]), float(value[1])
    if not (-180.0 <= lon <= 180.0 and -90.0 <= lat <= 90.0):
        raise ScenarioError(
            f"{where}: {list(value)} is not longitude/latitude (lon -180..180, lat -90..90); "
            "GeoJSON is WGS 84 lon/lat: is the file in projected metres?")
    return lon, lat, float(value[2]) if len(value) == 3 else 0.0


def _point(f: _Feature) -> tuple[float, float, float]:
    if f.geometry.get("type") != "Point":
        raise ScenarioError(f"{f.label}: role {f.role!r} needs a Point, got "
                            f"{f.geometry.get('type')!r}")
    return _position(f.geometry.get("coordinates"), f.label)


def _polygons(f: _Feature) -> list[list[tuple[float, float]]]:
    """The outer rings (lon/lat) of a Polygon or MultiPolygon feature."""
    kind, coords = f.geometry.get("type"), f.geometry.get("coordinates")
    if kind == "Polygon":
        parts = [coords]
    elif kind == "MultiPolygon" and isinstance(coords, list):
        parts = coords
    else:
        raise ScenarioError(f"{f.label}: role {f.role!r} needs a Polygon or MultiPolygon, "
                            f"got {kind!r}")
    rings = []
    for p, part in enumerate(parts):
        where = f"{f.label} polygon {p}" if kind == "MultiPolygon" else f.label
        if not isinstance(part, list) or not part:
            raise ScenarioError(f"{where}: expected a list of rings")
        if len(part) > 1:
            raise ScenarioError(f"{where}: has {len(part) - 1} hole(s); forbidden areas are "
                                "simple polygons: drop the holes or split the polygon")
        if not isinstance(part[0], list):
            raise ScenarioError(f"{where}: expected a ring of positions")
        ring = [_position(c, where)[:2] for c in part[0]]
        if len(ring) > 1 and ring[0] == ring[-1]:
            ring = ring[:-1]  # GeoJSON closes rings by repeating the first position
        if len(ring) < 3:
            raise ScenarioError(f"{where}: a polygon needs at least 3 distinct positions")
        rings.append(ring)
    return rings


# --- building the scenario -----------------------------------------------------------------

def _local(frame: LocalFrame, p: tuple[float, float, float]) -> tuple[float, float, float]:
    x, y = frame.to_local(p[0], p[1])
    return float(x), float(y), p[2]


def _forbidden(features: Sequence[_Feature], rings: dict[int, list], frame: LocalFrame,
               simplify_m: float) -> tuple[list[Polygon], list[str]]:
    """Local polygons of the land and no-go features (in file order) and their roles."""
    polygons, roles = [], []
    for f in features:
        for ring in rings[f.index]:
            lon, lat = np.array(ring).T
            x, y = frame.to_local(lon, lat)
            poly = Polygon(np.column_stack([x, y]))
            if not poly.is_valid:
                raise ScenarioError(f"{f.label}: invalid polygon: {explain_validity(poly)}")
            if simplify_m > 0:
                poly = _simplified(poly, simplify_m)
            polygons.append(poly)
            roles.append(f.role)
    return polygons, roles


def _simplified(poly: Polygon, tolerance_m: float) -> Polygon:
    """Fewer vertices, never less area: grown by the tolerance before simplifying (so the
    simplified outline still holds the original), the original added back in the rare case
    it pokes out."""
    grown = poly.buffer(tolerance_m, join_style="mitre").simplify(tolerance_m)
    if not grown.contains(poly):
        grown = shapely.union(grown, poly)
    return grown if isinstance(grown, Polygon) else poly


def _require_water(points: Mapping[int, tuple], local: Mapping[int, tuple],
                   forbidden: Sequence[Polygon], roles: Sequence[str],
                   features: Sequence[_Feature]) -> None:
    for i, (x, y, _) in local.items():
        for poly, role in zip(forbidden, roles):
            if poly.contains(Point(x, y)):
                f = features[i]
                lon, lat, _ = points[i]
                raise ScenarioError(f"{f.label}: the {f.role} point at lon {lon:.6f}, lat "
                                    f"{lat:.6f} is inside a {role} polygon")


def _number(f: _Feature, key: str, default: float | None) -> float:
    value = f.props.get(key, default)
    if value is None:
        raise ScenarioError(f"{f.label}: role {f.role!r} needs a numeric {key!r} property")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or \
            not math.isfinite(value) or value < 0:
        raise ScenarioError(f"{f.label}: {key} must be a number >= 0, got {value!r}")
    return float(value)


def _service_draws(n: int, options: ReefOptions, rng: np.random.Generator) -> np.ndarray:
    # Drawn for every spot, used only where the file gives none: adding a service_s to one
    # spot does not change the others'.
    if options.service_s is not None:
        return np.full(n, options.service_s)
    return rng.uniform(*options.service_range_s, size=n)


def _tasks(cots: Sequence[_Feature], local: Mapping[int, tuple], options: ReefOptions,
           rng: np.random.Generator) -> list[dict[str, Any]]:
    given = []
    for f in cots:
        tid = f.props.get("id")
        if tid is not None and (isinstance(tid, bool) or not isinstance(tid, int)):
            raise ScenarioError(f"{f.label}: id must be an integer, got {tid!r}")
        given.append(tid)
    taken = [t for t in given if t is not None]
    if len(set(taken)) != len(taken):
        dup = next(t for t in taken if taken.count(t) > 1)
        raise ScenarioError(f"two cots features have id {dup}")
    taken_ids = set(taken)
    free = (t for t in range(1, len(cots) + len(taken) + 2) if t not in taken_ids)
    default_service = _service_draws(len(cots), options, rng)
    tasks = []
    for f, tid, service in zip(cots, given, default_service):
        x, y, z = local[f.index]
        tasks.append({
            "id": tid if tid is not None else next(free),
            "pos": [round(x, 2), round(y, 2), round(z, 2)],
            "priority": _number(f, "priority", None),
            "service_s": round(_number(f, "service_s", float(service)), 2),
        })
    return tasks


def _stations(features: Sequence[_Feature], k: int, role: str) -> list[_Feature]:
    if len(features) == 1:
        return list(features) * k
    if len(features) == k:
        return list(features)
    raise ScenarioError(f"{len(features)} {role} points for {k} vehicles: give one shared "
                        f"{role} point or one per vehicle")


def _vehicles(by_role: dict[str, list[_Feature]], local: Mapping[int, tuple],
              options: ReefOptions) -> list[dict[str, Any]]:
    n_starts = len(by_role["start"])
    k = options.vehicles or (n_starts if n_starts > 1 else 3)
    starts = _stations(by_role["start"], k, "start")
    ends = _stations(by_role["rendezvous"], k, "rendezvous") if by_role["rendezvous"] else starts
    vehicles = []
    for v, (s, e) in enumerate(zip(starts, ends)):
        vehicles.append({
            "id": f"auv{v + 1}",
            "start": [round(c, 2) for c in local[s.index]],
            "rendezvous": [round(c, 2) for c in local[e.index]],
            "battery_s": options.battery_s,
        })
    return vehicles


def _truth(truth: Sequence[_Feature], local: Mapping[int, tuple], tasks: Sequence[dict],
           options: ReefOptions, rng: np.random.Generator) -> dict[str, Any]:
    index = {t["id"]: i for i, t in enumerate(tasks)}
    default_service = _service_draws(len(truth), options, rng)
    spots = []
    for f, service in zip(truth, default_service):
        task = f.props.get("task")
        if task is not None and task not in index:
            raise ScenarioError(f"{f.label}: task {task!r} is not the id of a cots feature")
        x, y, z = local[f.index]
        spots.append({
            "pos": [round(x, 2), round(y, 2), round(z, 2)],
            "priority": _number(f, "priority", None),
            "service_s": round(_number(f, "service_s", float(service)), 2),
            "task": None if task is None else index[task],
        })
    return {"detect_radius_m": options.detect_radius_m, "p_detect": options.p_detect,
            "inspect_s": options.inspect_s, "spots": spots}


def _name(doc: Any) -> str | None:
    name = doc.get("name") if isinstance(doc, Mapping) else None
    return name if isinstance(name, str) and name else None
