"""The Rerun entity layout and the logging calls (the only module that knows Rerun archetypes).

Entity layout (timeline ``sim_time``, seconds of simulation time)::

    map                          static y-flip so north is up on screen; data stays in metres
    map/field                    static Image of eq. (1) + its placement transform
    map/land, map/forbidden      static LineStrips2D
    map/current                  Arrows2D: the water current (static unless tidal)
    map/stations                 Points2D: start and rendezvous, labels naming who is there
    map/spots                    static positions, radii (priority) and labels; colours by state
                                 (grey: a predicted spot found empty, dynamic missions)
    map/predictions              static LineStrips2D: a ring per predicted spot (dynamic
                                 missions: a spot nobody has looked at is filled with the
                                 sea's colour, so it reads hollow)
    map/reef                     static Points2D: the hidden reef (dynamic missions), hidden by
                                 default: switch it on to see what the fleet cannot
    map/finds                    Points2D: aggregations the map missed, from when reported
    map/grid                     static LineStrips2D + Points2D: a metre grid, or lines of
                                 longitude and latitude when the scenario has a projection,
                                 labelled on the bottom and left edges
    map/scale                    static LineStrips2D + Points2D: a scale bar and its length
    map/vehicles                 Points2D + Arrows2D: every vehicle's position and heading
    map/vehicle_labels           Points2D: their labels (stacked where they would pile up)
    map/vehicles/<id>/mark       red/orange cross when aborted, lost, silent or dead (+ label)
    map/trails                   LineStrips2D: each vehicle's recent stretch of trail
    map/trails/earlier           LineStrips2D: the finished stretches
    map/routes                   LineStrips2D: remaining planned routes to the rendezvous
    map/links                    LineStrips2D: the latest frame of each link (colour: SNR;
                                 dropped: red) + Points2D: a dropped one's reason and SNR
    series/<metric>              Scalars, a line per vehicle: battery_s, t_diff_s, spots_treated
    series/fleet/spots           Scalars: spots_cleared, duplicates
    series/fleet/priority        Scalars: priority_collected
    series/fleet/messages        Scalars: delivered, dropped
    series/fleet/drops/<reason>  Scalars: frames dropped for that reason (one entity each: a
                                 plot's lines are fixed from its first row)
    series/fleet/bytes           Scalars: bytes/delivered
    series/fleet/reef            Scalars: reef_share, the real reef's priority treated (0..1)
    series/ground_station/dropped/<why>  Scalars: samples refused (malformed), failed on (error)
    events                       TextLog: what happened, as sentences (`fleet_bus.event_text`)
    mission                      static TextDocument: run, scenario
    legend/...                   static swatches: vehicles, spot states, links, marks, current
    legend/labels                static Points2D: the swatches' names

What never changes on an entity (radii, draw order, label visibility) is logged once, static;
the rows carry only what changes. Every label is white, on a point of its own (radius 0)
where the geometry it names has a colour: the viewer writes a label in its entity's colour,
unreadable on its grey label box (`palette.LABEL_TEXT`).
"""

from __future__ import annotations

from typing import Callable, Iterable

import numpy as np
import rerun as rr

from ground_station import palette
from ground_station.drawing import (
    Current,
    Drawing,
    Finds,
    Links,
    LogLine,
    Mark,
    Routes,
    SeriesRow,
    Spots,
    Stations,
    Trails,
    Vehicles,
)
from ground_station.graticule import graticule
from ground_station.mapview import MapLayers

TIMELINE = "sim_time"
SERIES = "series"
LINEAR_PLOTS = ("battery_s", "t_diff_s")  # the rest are counts: drawn as steps
STEP = rr.components.InterpolationMode.StepAfter
UI = rr.components.Radius.ui_points  # radii that stay readable at any zoom

VEHICLES = "map/vehicles"
TRAILS = "map/trails"
ROUTES = "map/routes"
LINKS = "map/links"
CURRENT = "map/current"
STATIONS = "map/stations"
REEF = "map/reef"
FINDS = "map/finds"
VEHICLE_LABELS = "map/vehicle_labels"
LABEL_ORDER = 60.0  # labels on top of everything


def text_points(xy: np.ndarray | list, labels: list[str], draw_order: float = LABEL_ORDER
                ) -> rr.Points2D:
    """Labels alone: white text on points of no size (see the module's docstring)."""
    return rr.Points2D(np.asarray(xy, float).reshape(-1, 2), labels=labels,
                       colors=palette.LABEL_TEXT, radii=UI(0.0), show_labels=True,
                       draw_order=draw_order)


def vehicle_path(vid: str) -> str:
    return f"{VEHICLES}/{rr.escape_entity_path_part(vid)}"


def _closed(poly: np.ndarray) -> np.ndarray:
    return np.vstack([poly, poly[:1]])


def arrow_length_m(layers: MapLayers) -> float:
    """Heading arrows and marks scale with the map, so they read the same on any reef."""
    xmin, xmax, ymin, ymax = layers.bounds
    return 0.04 * max(xmax - xmin, ymax - ymin)


def _ring(xy: np.ndarray, r: float, n: int = 16) -> np.ndarray:
    a = np.linspace(0.0, 2.0 * np.pi, n + 1)
    return np.column_stack([xy[0] + r * np.cos(a), xy[1] + r * np.sin(a)])


def log_map(rec: rr.RecordingStream, layers: MapLayers, live: bool = False) -> None:
    """Everything that never changes during a mission, logged static. ``live``: the station
    labels are left to `Stations` (they name the vehicles at each station)."""
    rec.log("map", rr.Transform3D(scale=[1.0, -1.0, 1.0]), static=True)
    if layers.field is not None:
        xmin, _, ymin, _ = layers.field.extent
        cx, cy = layers.field.cell_m
        rec.log("map/field", rr.Image(layers.field.rgb, draw_order=-100.0),
                rr.Transform3D(translation=[xmin, ymin, 0.0], scale=[cx, cy, 1.0]), static=True)
    if layers.land:
        rec.log("map/land", rr.LineStrips2D([_closed(p) for p in layers.land], colors=palette.LAND,
                                            radii=UI(1.0), draw_order=-90.0), static=True)
    if layers.forbidden:
        rec.log("map/forbidden", rr.LineStrips2D(
            [_closed(p) for p in layers.forbidden], colors=palette.FORBIDDEN, radii=UI(1.5),
            draw_order=-80.0),
            text_points([p.mean(axis=0) for p in layers.forbidden],
                        ["forbidden"] * len(layers.forbidden)), static=True)
    log_graticule(rec, layers)
    if layers.stations:
        rec.log(STATIONS, rr.Points2D.from_fields(
            positions=[s.xy for s in layers.stations], colors=palette.STATION, radii=UI(6.0),
            labels=None if live else [s.label for s in layers.stations], show_labels=True,
            draw_order=35.0), static=True)
    labels = [f"spot {t} (priority {p:.0f})"
              for t, p in zip(layers.spot_ids.tolist(), layers.spot_priority.tolist())]
    rec.log("map/spots", rr.Points2D(layers.spot_xy, radii=layers.spot_radius_m(), labels=labels,
                                     show_labels=False, draw_order=30.0), static=True)
    if layers.dynamic:  # predictions as rings: a pending one is drawn hollow (palette)
        rec.log("map/predictions", rr.LineStrips2D(
            [_ring(xy, r) for xy, r in zip(layers.spot_xy, layers.spot_radius_m())],
            colors=palette.SPOT_PENDING, radii=UI(1.0), draw_order=30.5), static=True)
        rec.log(REEF, rr.Points2D(layers.truth_xy, radii=UI(4.0), colors=palette.REEF,
                                  labels=[f"real spot {i} (priority {p:.0f})" for i, p in
                                          enumerate(layers.truth_priority.tolist())],
                                  show_labels=False, draw_order=31.0), static=True)


def log_graticule(rec: rr.RecordingStream, layers: MapLayers) -> None:
    """The metre grid (or lines of longitude and latitude) and the scale bar, static."""
    g = graticule(layers.bounds, layers.geo)
    rec.log("map/grid", rr.LineStrips2D(list(g.lines), colors=palette.GRID, radii=UI(0.5),
                                        draw_order=-88.0),
            text_points(g.label_xy, list(g.labels)), static=True)
    rec.log("map/scale", rr.LineStrips2D(list(g.scale), colors=palette.SCALE_BAR,
                                         radii=UI(1.5), draw_order=55.0),
            text_points(g.scale_label_xy, [g.scale_label]), static=True)


def log_text(rec: rr.RecordingStream, markdown: str) -> None:
    rec.log("mission", rr.TextDocument(markdown, media_type="text/markdown"), static=True)


# -- legend ------------------------------------------------------------------------------------
# Swatches in a small view of their own: a point, line, cross or arrow in the colour drawn on
# the map, its name written under it. Columns of rows, one unit apart (y grows downwards).
# The view keeps the aspect ratio, so columns are spaced for their longest label.
LEGEND_COLUMN_W = 6.0


def legend_rows(layers: MapLayers) -> int:
    return max(len(layers.vehicle_ids), 5 + layers.dynamic, 5 + (layers.current is not None))


def legend_bounds(layers: MapLayers) -> tuple[float, float, float, float]:
    """xmin, xmax, ymin, ymax of the legend, for its view."""
    return (-2.8, 2 * LEGEND_COLUMN_W + 2.8, -0.8, legend_rows(layers) - 0.1)


def log_legend(rec: rr.RecordingStream, layers: MapLayers) -> None:
    """Swatches in the map's colours, their names in white beside them (`legend/labels`)."""
    vids = list(layers.vehicle_ids)
    names: list[tuple[float, float, str]] = []
    rec.log("legend/vehicles", rr.Points2D(
        [[0.0, float(i)] for i in range(len(vids))],
        colors=[palette.vehicle_color(i) for i in range(len(vids))], radii=UI(6.0)),
        static=True)
    names += [(0.0, float(i), f"{vid}, its planned spots") for i, vid in enumerate(vids)]
    spots = [(palette.SPOT_PENDING, "spot (size: priority)"),
             (palette.SPOT_CLAIMED, "claimed spot"), (palette.SPOT_CLEARED, "cleared spot"),
             (palette.SPOT_ABANDONED, "abandoned spot"), (palette.STATION, "start, rendezvous")]
    if layers.dynamic:
        spots.insert(4, (palette.SPOT_EMPTY, "found empty"))
    rec.log("legend/spots", rr.Points2D(
        [[LEGEND_COLUMN_W, float(i)] for i in range(len(spots))], colors=[c for c, _ in spots],
        radii=UI(6.0)), static=True)
    names += [(LEGEND_COLUMN_W, float(i), n) for i, (_, n) in enumerate(spots)]
    x = 2 * LEGEND_COLUMN_W
    links = [(palette.LINK_DELIVERED, f"frame, SNR {palette.LINK_SNR_STRONG_DB:.0f}+ dB"),
             (palette.LINK_WEAK, f"frame, SNR {palette.LINK_SNR_WEAK_DB:.0f} dB"),
             (palette.LINK_DROPPED, "dropped (why, SNR)")]
    rec.log("legend/links", rr.LineStrips2D(
        [[[x - 0.7, float(i)], [x + 0.7, float(i)]] for i in range(len(links))],
        colors=[c for c, _ in links], radii=UI(2.0)), static=True)
    names += [(x, float(i), n) for i, (_, n) in enumerate(links)]
    marks = [(palette.MARK_ABORTED, "aborted, dead, silent"), (palette.MARK_LOST, "declared lost")]
    rec.log("legend/marks", rr.LineStrips2D(
        [s for i in range(len(marks)) for s in _cross(x, 3.0 + i, 0.25)],
        colors=[c for c, _ in marks for _ in range(2)], radii=UI(2.0)), static=True)
    names += [(x, 3.0 + i, n) for i, (_, n) in enumerate(marks)]
    if layers.current is not None:
        rec.log("legend/current", rr.Arrows2D(
            origins=[[x - 0.7, 5.0]], vectors=[[1.4, 0.0]], colors=[palette.CURRENT],
            radii=UI(1.5)), static=True)
        names.append((x, 5.0, f"current, up to {layers.current.peak_mps:.2f} m/s"))
    # the names under their swatches (the viewer writes a label below its anchor)
    rec.log("legend/labels", text_points([[nx, ny + 0.05] for nx, ny, _ in names],
                                         [n for _, _, n in names]), static=True)


def _cross(x: float, y: float, s: float) -> list[list[tuple[float, float]]]:
    return [[(x - s, y - s), (x + s, y + s)], [(x - s, y + s), (x + s, y - s)]]


class RerunDashboard:
    """Renders drawings into one recording stream."""

    def __init__(self, rec: rr.RecordingStream,
                 color_of: Callable[[str], palette.Rgb | None] = lambda vid: None,
                 arrow_m: float = 40.0) -> None:
        self.rec = rec
        self.color_of = color_of
        self.arrow_m = arrow_m
        self._styled: set[str] = set()
        self._lines: dict[str, tuple[str, ...]] = {}  # plot entity -> its lines, as styled

    def draw(self, drawings: Iterable[Drawing]) -> None:
        for d in drawings:
            self.rec.set_time(TIMELINE, duration=d.t_s)
            self._draw(d)

    def _style(self, path: str, first: rr.AsComponents, *more: rr.AsComponents) -> None:
        """What never changes on ``path``, logged once, static."""
        if path not in self._styled:
            self.rec.log(path, first, *more, static=True)
            self._styled.add(path)

    def _draw(self, d: Drawing) -> None:
        log = self.rec.log
        match d:
            case Spots():
                log("map/spots", rr.Points2D.from_fields(colors=d.colors))
            case Vehicles():
                self._style(VEHICLES, rr.Points2D.from_fields(radii=UI(7.0), draw_order=40.0),
                            rr.Arrows2D.from_fields(radii=UI(2.0), draw_order=41.0))
                self._style(VEHICLE_LABELS, rr.Points2D.from_fields(
                    radii=UI(0.0), colors=palette.LABEL_TEXT, show_labels=True,
                    draw_order=LABEL_ORDER))
                yaw = np.radians(d.yaw_deg)
                log(VEHICLES, rr.Points2D.from_fields(positions=d.xy, colors=d.colors),
                    rr.Arrows2D.from_fields(
                        origins=d.xy, colors=d.colors,
                        vectors=self.arrow_m * np.column_stack([np.cos(yaw), np.sin(yaw)])))
                shown = [i for i, text in enumerate(d.labels) if text]
                where = d.xy if d.label_xy is None else d.label_xy
                log(VEHICLE_LABELS, rr.Points2D.from_fields(
                    positions=where[shown].reshape(-1, 2), labels=[d.labels[i] for i in shown]))
            case Finds():
                self._style(FINDS, rr.Points2D.from_fields(radii=UI(6.0), colors=palette.FIND,
                                                           show_labels=False, draw_order=32.0))
                log(FINDS, rr.Points2D.from_fields(positions=d.xy, labels=list(d.labels)))
            case Stations():
                log(STATIONS, rr.Points2D.from_fields(labels=list(d.labels)))
            case Trails():
                path = TRAILS if d.part == "recent" else f"{TRAILS}/{d.part}"
                self._style(path, rr.LineStrips2D.from_fields(radii=UI(1.5), draw_order=20.0))
                self._strips(path, d.strips, [c for c in d.colors])
            case Routes():
                self._style(ROUTES, rr.LineStrips2D.from_fields(radii=UI(0.75), draw_order=10.0))
                faded = [tuple(int(0.6 * c + 0.4 * 255) for c in color) for color in d.colors]
                self._strips(ROUTES, d.strips, faded)
            case Mark():
                self._mark(d)
            case Links():
                self._links(d)
            case Current():
                self._current(d)
            case SeriesRow():
                self._series(d)
            case LogLine():
                log("events", rr.TextLog(d.text, level=d.level))
            case _:
                raise TypeError(f"cannot draw {type(d).__name__}")

    def _strips(self, path: str, strips: tuple[np.ndarray, ...], colors: list) -> None:
        if not strips:
            self.rec.log(path, rr.Clear(recursive=False))
        else:
            self.rec.log(path, rr.LineStrips2D.from_fields(strips=list(strips), colors=colors))

    def _links(self, d: Links) -> None:
        self._style(LINKS, rr.LineStrips2D.from_fields(draw_order=5.0),
                    rr.Points2D.from_fields(radii=UI(0.0), colors=palette.LABEL_TEXT,
                                            show_labels=True, draw_order=LABEL_ORDER))
        if not d.lines:
            self.rec.log(LINKS, rr.Clear(recursive=False))
            return
        labels = [line.label() for line in d.lines]
        shown = [i for i, text in enumerate(labels) if text]
        middles = np.array([[(a + b) / 2.0 for a, b in zip(line.a, line.b)]
                            for line in d.lines], float).reshape(-1, 2)
        where = middles if d.label_xy is None else np.asarray(d.label_xy, float)
        self.rec.log(LINKS, rr.LineStrips2D.from_fields(
            strips=[[line.a, line.b] for line in d.lines],
            colors=[palette.link_color(line.delivered, line.snr_db) for line in d.lines],
            radii=UI(np.array([1.0 if line.delivered else 1.5 for line in d.lines]))),
            rr.Points2D.from_fields(positions=where[shown].reshape(-1, 2),
                                    labels=[labels[i] for i in shown]))

    def _current(self, d: Current) -> None:
        self._style(CURRENT, rr.Arrows2D.from_fields(colors=palette.CURRENT, radii=UI(1.0),
                                                     draw_order=-85.0))
        self.rec.log(CURRENT, rr.Arrows2D.from_fields(origins=d.xy, vectors=d.uv_mps * d.scale_s),
                     static=d.steady)

    def _mark(self, d: Mark) -> None:
        path = f"{vehicle_path(d.vid)}/mark"
        if not d.kind:
            self.rec.log(path, rr.Clear(recursive=False))
            return
        x, y = d.xy
        color = palette.MARK_LOST if d.kind == "lost" else palette.MARK_ABORTED
        half = self.arrow_m * 0.6
        self.rec.log(path, rr.LineStrips2D(
            _cross(x, y, half), colors=color, radii=UI(3.0), draw_order=50.0),
            text_points([[x, y - half]], [f"{d.vid} {d.kind.upper()}"]))

    def _series(self, d: SeriesRow) -> None:
        path = f"{SERIES}/{d.entity}"
        if self._lines.get(path) != d.paths:
            # name and colour the lines (again when one appears), static: the plot legends
            # match the map's colours
            self._lines[path] = d.paths
            colors = [c for c in map(self._line_color, d.paths) if c is not None]
            self.rec.log(path, rr.SeriesLines(
                names=list(d.names), widths=2.0,
                colors=colors if len(colors) == len(d.paths) else None,
                interpolation_mode=None if d.entity in LINEAR_PLOTS else STEP), static=True)
        self.rec.log(path, rr.Scalars(np.asarray(d.values, float)))

    def _line_color(self, path: str) -> palette.Rgb | None:
        head, _, rest = path.partition("/")
        if head == "fleet":
            return palette.FLEET_SERIES.get(rest)
        return self.color_of(rest) if head in ("battery_s", "t_diff_s", "spots_treated") \
            else palette.GROUND_STATION_SERIES.get(rest)

