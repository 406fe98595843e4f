"""Where the map is and how big: a scale bar, and a metre grid or, when the scenario is on
the globe (its ``geo`` section: a projected CRS and the local origin, `cotsfleet.geo.frame`),
lines of longitude and latitude (pure: bounds in, polylines and labels out).

Steps are round numbers (1, 2 or 5 times a power of ten, of metres or of degrees) giving a
handful of lines across the map, as on a chart; labels sit on the map's bottom and left
edges, so they never cover the reef in the middle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

Bounds = tuple[float, float, float, float]  # xmin, xmax, ymin, ymax (local metres)
LINES_ACROSS = 5  # about this many grid lines along the map's longer side
SCALE_SHARE = 0.2  # the scale bar spans about this share of the map's width
SAMPLES = 64  # points per line of longitude or latitude (straight in UTM to well under a metre)
# Labels keep out of the bottom-left corner, where the two edges' labels would meet.
CORNER = (0.12, 0.06)  # share of the width (for bottom labels) and height (for left ones)


@dataclass(frozen=True)
class Graticule:
    lines: tuple[np.ndarray, ...]  # (m, 2) polylines, local metres
    label_xy: np.ndarray  # (k, 2) where each line's label is anchored
    labels: tuple[str, ...]
    scale: tuple[np.ndarray, ...]  # the scale bar and its end ticks
    scale_label_xy: np.ndarray  # (1, 2)
    scale_label: str
    lonlat: bool  # lines of longitude and latitude (else metres)


def nice_step(span: float, across: int = LINES_ACROSS) -> float:
    """The round step (1, 2 or 5 x 10^k) nearest (in ratio) to ``span / across``."""
    if not span > 0:
        return 1.0
    raw = span / across
    power = 10.0 ** math.floor(math.log10(raw))
    return min((m * power for m in (1.0, 2.0, 5.0, 10.0)),
               key=lambda step: abs(math.log(step / raw)))


def _ticks(lo: float, hi: float, step: float) -> list[float]:
    first = math.ceil(lo / step - 1e-9) * step
    return [first + i * step for i in range(int((hi - first) / step + 1e-9) + 1)]


def metres(value: float) -> str:
    """``250 m``, ``1.5 km``: a distance as a chart labels it."""
    if abs(value) >= 1000.0:
        return f"{value / 1000.0:g} km"
    return f"{value:g} m"


def scale_bar(bounds: Bounds) -> tuple[tuple[np.ndarray, ...], np.ndarray, str]:
    """A bar of a round length near the bottom-right corner (the grid labels are on the
    bottom and left edges), with end ticks, and its label above it."""
    xmin, xmax, ymin, ymax = bounds
    width, height = xmax - xmin, ymax - ymin
    length = nice_step(width * SCALE_SHARE, 1)
    x0, y0 = xmax - 0.04 * width - length, ymin + 0.11 * height  # above the bottom labels
    tick = 0.012 * max(width, height)
    bar = np.array([[x0, y0], [x0 + length, y0]])
    ticks = tuple(np.array([[x, y0 - tick], [x, y0 + tick]]) for x in (x0, x0 + length))
    return (bar, *ticks), np.array([[x0 + length / 2.0, y0 + 2.5 * tick]]), metres(length)


def metre_grid(bounds: Bounds) -> Graticule:
    """Lines every round number of metres, labelled on the bottom and left edges."""
    xmin, xmax, ymin, ymax = bounds
    step = nice_step(max(xmax - xmin, ymax - ymin))
    xs, ys = _ticks(xmin, xmax, step), _ticks(ymin, ymax, step)
    lines = [np.array([[x, ymin], [x, ymax]]) for x in xs]
    lines += [np.array([[xmin, y], [xmax, y]]) for y in ys]
    bottom_y, left_x = _edges(bounds)
    bottom = [x for x in xs if x > xmin + CORNER[0] * (xmax - xmin)]
    left = [y for y in ys if y > ymin + CORNER[1] * (ymax - ymin)]
    anchors = [[x, bottom_y] for x in bottom] + [[left_x, y] for y in left]
    labels = [f"x {metres(x)}" for x in bottom] + [f"y {metres(y)}" for y in left]
    scale, scale_xy, scale_text = scale_bar(bounds)
    return Graticule(tuple(lines), np.array(anchors, float).reshape(-1, 2), tuple(labels),
                     scale, scale_xy, scale_text, False)


def degrees(value: float, positive: str, negative: str, step: float) -> str:
    """``146.015° E``: as many decimals as the step needs."""
    decimals = max(0, -math.floor(math.log10(step) + 1e-9))
    return f"{abs(value):.{decimals}f}° {positive if value >= 0 else negative}"


def lonlat_grid(bounds: Bounds, crs: str, origin_m: tuple[float, float]) -> Graticule:
    """Lines of longitude and latitude over the map, computed through the scenario's
    projection (pyproj), labelled on the bottom and left edges."""
    from pyproj import Transformer

    to_lonlat = Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
    to_local = Transformer.from_crs("EPSG:4326", crs, always_xy=True)
    xmin, xmax, ymin, ymax = bounds
    e0, n0 = origin_m
    cx, cy = np.meshgrid(np.linspace(xmin, xmax, 5), np.linspace(ymin, ymax, 5))
    lon, lat = to_lonlat.transform(cx.ravel() + e0, cy.ravel() + n0)
    lon_lo, lon_hi, lat_lo, lat_hi = lon.min(), lon.max(), lat.min(), lat.max()
    step = nice_step(max(lon_hi - lon_lo, lat_hi - lat_lo))
    lines, anchors, labels = [], [], []
    bottom_y, left_x = _edges(bounds)
    for value in _ticks(lon_lo, lon_hi, step):
        lats = np.linspace(lat_lo, lat_hi, SAMPLES)
        x, y = to_local.transform(np.full(SAMPLES, value), lats)
        line = _clip(np.column_stack([x - e0, y - n0]), bounds)
        if line is not None:
            lines.append(line)
            x_at = float(line[np.argmin(line[:, 1]), 0])
            if x_at > xmin + CORNER[0] * (xmax - xmin):
                anchors.append([x_at, bottom_y])
                labels.append(degrees(value, "E", "W", step))
    for value in _ticks(lat_lo, lat_hi, step):
        lons = np.linspace(lon_lo, lon_hi, SAMPLES)
        x, y = to_local.transform(lons, np.full(SAMPLES, value))
        line = _clip(np.column_stack([x - e0, y - n0]), bounds)
        if line is not None:
            lines.append(line)
            y_at = float(line[np.argmin(line[:, 0]), 1])
            if y_at > ymin + CORNER[1] * (ymax - ymin):
                anchors.append([left_x, y_at])
                labels.append(degrees(value, "N", "S", step))
    scale, scale_xy, scale_text = scale_bar(bounds)
    return Graticule(tuple(lines), np.array(anchors, float).reshape(-1, 2), tuple(labels),
                     scale, scale_xy, scale_text, True)


def _edges(bounds: Bounds) -> tuple[float, float]:
    """Where labels stand along the bottom edge (a y) and the left edge (an x): inside the
    map, since the viewer writes a label centred under its anchor."""
    xmin, xmax, ymin, ymax = bounds
    return ymin + 0.045 * (ymax - ymin), xmin + 0.06 * (xmax - xmin)


def _clip(line: np.ndarray, bounds: Bounds) -> np.ndarray | None:
    """The points of ``line`` inside the map (None if fewer than two)."""
    xmin, xmax, ymin, ymax = bounds
    inside = ((line[:, 0] >= xmin) & (line[:, 0] <= xmax) & (line[:, 1] >= ymin)
              & (line[:, 1] <= ymax))
    return line[inside] if inside.sum() >= 2 else None


def graticule(bounds: Bounds, geo: tuple[str, tuple[float, float]] | None) -> Graticule:
    """Lines of longitude and latitude on a scenario with a projection, metres otherwise (a
    projection pyproj does not know falls back to metres rather than no map at all)."""
    if geo is not None:
        try:
            return lonlat_grid(bounds, *geo)
        except Exception:  # pyproj's CRSError and friends: metres will do
            pass
    return metre_grid(bounds)
