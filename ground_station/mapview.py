"""The static map of a scenario, ready to draw (pure: scenario document -> arrays).

Under everything the COTS probability field of eq. (1) (when the scenario carries a
``cots_map``), land in black, forbidden zones tinted; on top the start and rendezvous stations
and the spots with their priorities. World coordinates stay in scenario metres: the renderer
flips the y axis once, at the map root, so what is stored equals what the fleet reported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from dataclasses import field as dc_field
from typing import Any, Mapping

import numpy as np

from ground_station import palette
from hfc_core.model.current import CurrentField, current_from_dict, peak_speed_mps
from hfc_core.model.current import sample as sample_current
from hfc_core.model.errors import ScenarioError
from reef_sim.cotsmap import ProbabilityMap, cots_map_of, points_in_polygon

FIELD_CELLS = 200  # cells along the longer side of the field image
SPOT_RADIUS_M = (4.0, 14.0)  # radius of the lowest and highest priority spot
CURRENT_ARROWS = 12  # current arrows along each side of the map
CURRENT_ARROW_SHARE = 0.8  # the fastest water's arrow spans this share of the arrow spacing


@dataclass(frozen=True)
class Station:
    xy: tuple[float, float]
    label: str  # e.g. "start" or "rendezvous auv2"


@dataclass(frozen=True)
class FieldImage:
    rgb: np.ndarray  # (ny, nx, 3) uint8, row 0 at ymin
    extent: tuple[float, float, float, float]  # xmin, xmax, ymin, ymax

    @property
    def cell_m(self) -> tuple[float, float]:
        ny, nx = self.rgb.shape[:2]
        xmin, xmax, ymin, ymax = self.extent
        return (xmax - xmin) / nx, (ymax - ymin) / ny


@dataclass(frozen=True)
class CurrentLayer:
    """Where the current's arrows stand (a grid over the map, none on land) and how long
    they are: ``velocity x scale_s`` metres, so the fastest water fills most of a cell."""

    field: CurrentField
    bounds: tuple[float, float, float, float]
    n: int
    sea: np.ndarray  # (n * n,) bool: grid points off land, in `hfc_core.model.current.sample` order
    scale_s: float
    peak_mps: float

    def sample(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Arrow origins and velocities at mission time ``t_s``."""
        xy, uv = sample_current(self.field, self.bounds, self.n, t_s)
        return xy[self.sea], uv[self.sea]


@dataclass(frozen=True)
class MapLayers:
    vehicle_ids: tuple[str, ...]
    spot_ids: np.ndarray  # (n,) scenario task ids
    spot_xy: np.ndarray  # (n, 2)
    spot_priority: np.ndarray  # (n,)
    stations: tuple[Station, ...]
    land: tuple[np.ndarray, ...] = ()
    forbidden: tuple[np.ndarray, ...] = ()
    field: FieldImage | None = None
    bounds: tuple[float, float, float, float] = (0.0, 1.0, 0.0, 1.0)
    spot_index: dict[int, int] = dc_field(default_factory=dict)  # task id -> row
    rendezvous: dict[str, tuple[float, float]] = dc_field(default_factory=dict)  # per vehicle
    current: CurrentLayer | None = None
    # Dynamic scenarios: the hidden reef (`truth`), for the layer a user may switch on and the
    # fleet's share of the real priority; truth_of_spot: predicted spot id -> its truth spot.
    truth_pos: np.ndarray = dc_field(default_factory=lambda: np.zeros((0, 3)))  # x, y, z
    truth_priority: np.ndarray = dc_field(default_factory=lambda: np.zeros(0))
    truth_of_spot: dict[int, int] = dc_field(default_factory=dict)
    truth_unmapped: frozenset[int] = frozenset()  # truth spots the map missed
    # the scenario's projection (``geo``: a projected CRS and the local origin in it), for
    # longitude/latitude on the map (`ground_station.graticule`)
    geo: tuple[str, tuple[float, float]] | None = None

    @property
    def truth_xy(self) -> np.ndarray:
        return self.truth_pos[:, :2]

    @property
    def dynamic(self) -> bool:
        return len(self.truth_priority) > 0

    def spot_radius_m(self) -> np.ndarray:
        """Priority as size: linear from the smallest to the largest radius."""
        if len(self.spot_priority) == 0:
            return np.zeros(0)
        top = float(self.spot_priority.max()) or 1.0
        lo, hi = SPOT_RADIUS_M
        return lo + (hi - lo) * np.clip(self.spot_priority / top, 0.0, 1.0)

    def spot_xy_of(self, task_ids: list[int]) -> np.ndarray:
        """Positions of the known spots among ``task_ids`` (unknown ids are skipped)."""
        rows = [self.spot_index[t] for t in task_ids if t in self.spot_index]
        return self.spot_xy[rows] if rows else np.zeros((0, 2))


def _xy(value: Any, where: str) -> tuple[float, float]:
    if not isinstance(value, (list, tuple)) or len(value) < 2:
        raise ScenarioError(f"{where}: expected [x, y, ...], got {value!r}")
    x, y = float(value[0]), float(value[1])
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ScenarioError(f"{where}: coordinates must be finite")
    return x, y


def _polygons(raw: Any, where: str) -> tuple[np.ndarray, ...]:
    out = []
    for i, poly in enumerate(raw or []):
        arr = np.asarray(poly, dtype=float)
        if arr.ndim != 2 or arr.shape[1] != 2 or len(arr) < 3 or not np.isfinite(arr).all():
            raise ScenarioError(f"{where}[{i}]: a polygon needs at least 3 [x, y] vertices")
        out.append(arr)
    return tuple(out)


def _stations(vehicles: list[Mapping[str, Any]]) -> tuple[Station, ...]:
    """One marker per distinct point, labelled with who starts or meets there."""
    by_point: dict[tuple[float, float], list[str]] = {}
    for i, v in enumerate(vehicles):
        vid = str(v.get("id", f"v{i}"))
        for kind in ("start", "rendezvous"):
            p = _xy(v.get(kind), f"vehicles[{i}].{kind}")
            by_point.setdefault(p, []).append(f"{kind} {vid}")
    stations = []
    for p, names in by_point.items():
        kinds = sorted({n.split()[0] for n in names})
        whom = sorted({n.split()[1] for n in names})
        label = " + ".join(kinds) + ("" if len(whom) == len(vehicles) else " " + ",".join(whom))
        stations.append(Station(p, label))
    return tuple(stations)


def _field_image(pmap: ProbabilityMap, forbidden: tuple[np.ndarray, ...]) -> FieldImage:
    xmin, xmax, ymin, ymax = pmap.bounds
    prob, extent = pmap.grid(max(xmax - xmin, ymax - ymin) / FIELD_CELLS)
    rgb = palette.sea_colormap(prob)
    ny, nx = prob.shape
    gx, gy = np.meshgrid(xmin + (np.arange(nx) + 0.5) * (xmax - xmin) / nx,
                         ymin + (np.arange(ny) + 0.5) * (ymax - ymin) / ny)
    land = pmap.on_land(gx, gy)
    rgb[land] = palette.LAND
    for poly in forbidden:
        inside = points_in_polygon(gx, gy, poly) & ~land
        tint = np.asarray(palette.FORBIDDEN, float)
        rgb[inside] = (0.5 * rgb[inside] + 0.5 * tint).astype(np.uint8)
    x0, x1, y0, y1 = (float(v) for v in extent)
    return FieldImage(rgb, (x0, x1, y0, y1))


def _bounds(*xy_sets: np.ndarray, field: FieldImage | None) -> tuple[float, float, float, float]:
    pts = np.concatenate([s.reshape(-1, 2) for s in xy_sets if s.size] or [np.zeros((1, 2))])
    xmin, ymin = pts.min(axis=0)
    xmax, ymax = pts.max(axis=0)
    if field is not None:
        fx0, fx1, fy0, fy1 = field.extent
        xmin, xmax, ymin, ymax = min(xmin, fx0), max(xmax, fx1), min(ymin, fy0), max(ymax, fy1)
    pad = 0.03 * max(xmax - xmin, ymax - ymin, 1.0)
    return float(xmin - pad), float(xmax + pad), float(ymin - pad), float(ymax + pad)


def _current_layer(raw: Any, bounds: tuple[float, float, float, float],
                   land: tuple[np.ndarray, ...]) -> CurrentLayer | None:
    """The scenario's ``current`` section as arrows over the map; None for still water."""
    if raw is None:
        return None
    current = current_from_dict(raw)
    peak = peak_speed_mps(current)
    if not peak > 0.0:
        return None
    xmin, xmax, ymin, ymax = bounds
    n = CURRENT_ARROWS
    # arrows at the centres of an n x n tiling, so none sits on the map's edge
    inner = (xmin + (xmax - xmin) / (2 * n), xmax - (xmax - xmin) / (2 * n),
             ymin + (ymax - ymin) / (2 * n), ymax - (ymax - ymin) / (2 * n))
    xy, _ = sample_current(current, inner, n, 0.0)
    sea = np.ones(len(xy), bool)
    for poly in land:
        sea &= ~points_in_polygon(xy[:, 0], xy[:, 1], poly)
    spacing = min(xmax - xmin, ymax - ymin) / n
    return CurrentLayer(current, inner, n, sea, CURRENT_ARROW_SHARE * spacing / peak, peak)


def map_layers(doc: Mapping[str, Any]) -> MapLayers:
    """Everything static about a scenario document; raises `ScenarioError` if malformed."""
    if not isinstance(doc, Mapping):
        raise ScenarioError("scenario: expected an object")
    try:
        vehicles = list(doc.get("vehicles") or [])
        tasks = list(doc.get("tasks") or [])
        ids = np.array([int(t["id"]) for t in tasks], dtype=np.int64)
        xy = np.array([_xy(t["pos"], f"tasks[{i}].pos") for i, t in enumerate(tasks)], float)
        prio = np.array([float(t.get("priority", 0.0)) for t in tasks], float)
        vehicle_ids = tuple(str(v["id"]) for v in vehicles)
        rendezvous = {str(v["id"]): _xy(v["rendezvous"], f"vehicles[{i}].rendezvous")
                      for i, v in enumerate(vehicles)}
    except (KeyError, TypeError, ValueError) as exc:
        raise ScenarioError(f"scenario: {exc!r}") from None
    xy = xy.reshape(-1, 2)
    truth_pos, truth_prio, truth_of_spot, unmapped = _truth(doc.get("truth"), ids)
    forbidden = _polygons(doc.get("forbidden"), "forbidden")
    pmap = cots_map_of(doc)
    field_img = _field_image(pmap, forbidden) if pmap is not None else None
    land = pmap.land if pmap is not None else ()
    stations = _stations(vehicles)
    station_xy = np.array([s.xy for s in stations], float).reshape(-1, 2)
    bounds = _bounds(xy, station_xy, *land, *forbidden, field=field_img)
    return MapLayers(
        vehicle_ids=vehicle_ids,
        spot_ids=ids,
        spot_xy=xy,
        spot_priority=np.nan_to_num(prio),
        stations=stations,
        land=tuple(land),
        forbidden=forbidden,
        field=field_img,
        bounds=bounds,
        spot_index={int(t): i for i, t in enumerate(ids)},
        rendezvous=rendezvous,
        current=_current_layer(doc.get("current"), field_img.extent if field_img else bounds,
                               tuple(land)),
        truth_pos=truth_pos,
        truth_priority=truth_prio,
        truth_of_spot=truth_of_spot,
        truth_unmapped=unmapped,
        geo=_geo(doc.get("geo")),
    )


def _geo(raw: Any) -> tuple[str, tuple[float, float]] | None:
    """The scenario's ``geo`` section (`cotsfleet.geo.frame`): CRS and origin, or None."""
    if not isinstance(raw, Mapping):
        return None
    try:
        e0, n0 = (float(c) for c in raw["origin_m"])
        crs = str(raw["crs"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ScenarioError(f"scenario: geo: {exc!r}") from None
    if not (math.isfinite(e0) and math.isfinite(n0)):
        raise ScenarioError("scenario: geo: origin_m must be finite")
    return crs, (e0, n0)


def _truth(raw: Any, ids: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray, dict[int, int], frozenset[int]]:
    """The hidden reef's positions (x, y, z), priorities, which predicted spot each one is
    (``task`` is an index in ``tasks``, `reef_sim.truth`) and which ones the map missed (no
    task); empty without a ``truth`` section."""
    if not isinstance(raw, Mapping):
        return np.zeros((0, 3)), np.zeros(0), {}, frozenset()
    try:
        spots = list(raw.get("spots") or [])
        pos = np.array([(*_xy(s["pos"], f"truth.spots[{i}].pos"),
                         float(s["pos"][2]) if len(s["pos"]) > 2 else 0.0)
                        for i, s in enumerate(spots)], float).reshape(-1, 3)
        prio = np.array([float(s.get("priority", 0.0)) for s in spots], float)
        of_spot = {int(ids[int(s["task"])]): i for i, s in enumerate(spots)
                   if s.get("task") is not None and 0 <= int(s["task"]) < len(ids)}
        unmapped = frozenset(i for i, s in enumerate(spots) if s.get("task") is None)
    except (KeyError, TypeError, ValueError) as exc:
        raise ScenarioError(f"scenario: truth: {exc!r}") from None
    return pos, np.nan_to_num(prio), of_spot, unmapped
