"""The Rerun entity layout and the logging calls (the only module that knows Rerun archetypes).

Entity layout (timeline ``sim_time``, seconds of simulation time)::

    map                          static y-flip so north is up on screen; data stays in metres
    map/field                    static Image of eq. (1) + its placement transform
    map/land, map/forbidden      static LineStrips2D
    map/stations                 static Points2D: start and rendezvous
    map/spots                    static positions, radii (priority) and labels; colours by state
    map/vehicles/<id>            Points2D pose (label: id and state)
    map/vehicles/<id>/heading    Arrows2D
    map/vehicles/<id>/trail      LineStrips2D where it has been
    map/vehicles/<id>/route      LineStrips2D remaining planned route to the rendezvous
    map/vehicles/<id>/mark       red/orange cross when aborted, lost, silent or dead
    map/links/<src>/<dst>        LineStrips2D: green delivered, red dropped (label: reason)
    series/<metric>/<id>         Scalars per vehicle: battery_s, t_diff_s, spots_treated
    series/fleet/...             Scalars: spots_cleared, priority_collected, duplicates,
                                 messages/{delivered,dropped}, bytes/delivered, drops/<reason>
    events                       TextLog: claims, aborts, detections, takeovers, state changes
    mission                      static TextDocument: run, scenario, legend
"""

from __future__ import annotations

import math
from typing import Callable, Iterable

import numpy as np
import rerun as rr

from ground_station import palette
from ground_station.drawing import (
    Drawing, LinkClear, LinkLine, LogLine, Mark, Pose, Route, Scalar, Spots, Trail,
)
from ground_station.mapview import MapLayers

TIMELINE = "sim_time"
SERIES = "series"
PER_VEHICLE_SERIES = ("battery_s", "t_diff_s", "spots_treated")
COUNT_SERIES = ("spots_treated",)  # counts are logged when they change: draw them as steps
STEP = rr.components.InterpolationMode.StepAfter
UI = rr.components.Radius.ui_points  # radii that stay readable at any zoom


def vehicle_path(vid: str) -> str:
    return f"map/vehicles/{rr.escape_entity_path_part(vid)}"


def link_path(src: str, dst: str) -> str:
    esc = rr.escape_entity_path_part
    return f"map/links/{esc(src)}/{esc(dst)}"


def _closed(poly: np.ndarray) -> np.ndarray:
    return np.vstack([poly, poly[:1]])


def log_map(rec: rr.RecordingStream, layers: MapLayers) -> None:
    """Everything that never changes during a mission, logged static."""
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
            labels=["forbidden"] * len(layers.forbidden), draw_order=-80.0), static=True)
    if layers.stations:
        rec.log("map/stations", rr.Points2D(
            [s.xy for s in layers.stations], colors=palette.STATION, radii=UI(6.0),
            labels=[s.label for s in layers.stations], show_labels=True, draw_order=35.0),
            static=True)
    labels = [f"spot {t} (priority {p:.0f})"
              for t, p in zip(layers.spot_ids.tolist(), layers.spot_priority.tolist())]
    rec.log("map/spots", rr.Points2D(layers.spot_xy, radii=layers.spot_radius_m(), labels=labels,
                                     show_labels=False, draw_order=30.0), static=True)


def log_text(rec: rr.RecordingStream, markdown: str) -> None:
    rec.log("mission", rr.TextDocument(markdown, media_type="text/markdown"), static=True)


class RerunDashboard:
    """Renders drawings into one recording stream."""

    def __init__(self, rec: rr.RecordingStream,
                 color_of: Callable[[str], palette.Rgb | None] = lambda vid: None,
                 arrow_m: float = 40.0) -> None:
        self.rec = rec
        self.color_of = color_of
        self.arrow_m = arrow_m
        self._styled: set[str] = set()

    def draw(self, drawings: Iterable[Drawing]) -> None:
        for d in drawings:
            self.rec.set_time(TIMELINE, duration=d.t_s)
            self._draw(d)

    def _draw(self, d: Drawing) -> None:
        log = self.rec.log
        match d:
            case Spots():
                log("map/spots", rr.Points2D.from_fields(colors=d.colors))
            case Pose():
                path = vehicle_path(d.vid)
                log(path, rr.Points2D([d.xy], colors=d.color, radii=UI(7.0),
                                      labels=[f"{d.vid} {d.state}"], show_labels=True,
                                      draw_order=40.0))
                yaw = math.radians(d.yaw_deg)
                log(f"{path}/heading", rr.Arrows2D(
                    origins=[d.xy], vectors=[[self.arrow_m * math.cos(yaw),
                                              self.arrow_m * math.sin(yaw)]],
                    colors=d.color, radii=UI(2.0), draw_order=41.0))
            case Trail():
                log(f"{vehicle_path(d.vid)}/trail",
                    rr.LineStrips2D([d.points], colors=d.color, radii=UI(1.5), draw_order=20.0))
            case Route():
                path = f"{vehicle_path(d.vid)}/route"
                if len(d.points) < 2:
                    log(path, rr.Clear(recursive=False))
                else:
                    faded = tuple(int(0.6 * c + 0.4 * 255) for c in d.color)
                    log(path, rr.LineStrips2D([d.points], colors=faded, radii=UI(0.75),
                                              draw_order=10.0))
            case Mark():
                self._mark(d)
            case LinkLine():
                color = palette.LINK_DELIVERED if d.delivered else palette.LINK_DROPPED
                log(link_path(d.src, d.dst), rr.LineStrips2D(
                    [[d.a, d.b]], colors=color, radii=UI(1.0 if d.delivered else 1.5),
                    labels=[d.reason] if d.reason else None, show_labels=bool(d.reason),
                    draw_order=5.0))
            case LinkClear():
                log(link_path(d.src, d.dst), rr.Clear(recursive=False))
            case Scalar():
                self._scalar(d)
            case LogLine():
                log("events", rr.TextLog(d.text, level=d.level))
            case _:
                raise TypeError(f"cannot draw {type(d).__name__}")

    def _mark(self, d: Mark) -> None:
        path = f"{vehicle_path(d.vid)}/mark"
        if not d.kind:
            self.rec.log(path, rr.Clear(recursive=False))
            return
        x, y = d.xy
        s = self.arrow_m * 0.6
        color = palette.MARK_LOST if d.kind == "lost" else palette.MARK_ABORTED
        self.rec.log(path, rr.LineStrips2D(
            [[(x - s, y - s), (x + s, y + s)], [(x - s, y + s), (x + s, y - s)]],
            colors=color, radii=UI(3.0), labels=[f"{d.vid} {d.kind.upper()}", ""],
            show_labels=True, draw_order=50.0))

    def _scalar(self, d: Scalar) -> None:
        path = f"{SERIES}/{d.path}"
        if path not in self._styled:
            # name and colour each line once, static: legends match the map's colours
            metric, _, rest = d.path.partition("/")
            if metric in PER_VEHICLE_SERIES:
                self.rec.log(path, rr.SeriesLines(
                    names=rest, widths=2.0, colors=self.color_of(rest),
                    interpolation_mode=STEP if metric in COUNT_SERIES else None), static=True)
            elif metric == "fleet":
                self.rec.log(path, rr.SeriesLines(
                    names=rest, widths=2.0, colors=palette.FLEET_SERIES.get(rest),
                    interpolation_mode=STEP), static=True)
            self._styled.add(path)
        self.rec.log(path, rr.Scalars(d.value))
