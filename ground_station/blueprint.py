"""Rerun blueprints: the layout the viewer opens with (map large, series beside, log below)."""

from __future__ import annotations

import rerun.blueprint as rrb
from rerun.blueprint.encodings import TextLogColumn

from ground_station.rerun_log import REEF, SERIES, TIMELINE

Bounds = tuple[float, float, float, float]


def map_view(bounds: Bounds, name: str = "Map") -> rrb.Spatial2DView:
    """The 2D map; bounds are in world metres, the view sees them through the y-flip."""
    xmin, xmax, ymin, ymax = bounds
    return rrb.Spatial2DView(
        name=name, origin="/", contents=["+ /map/**"], background=[8, 12, 20],
        visual_bounds=rrb.VisualBounds2D(x_range=[xmin, xmax], y_range=[-ymax, -ymin]),
        # the hidden reef of a dynamic mission starts switched off (the eye in the entity
        # tree shows it): the map shows what the fleet knows
        overrides={f"/{REEF}": rrb.EntityBehavior(visible=False)})


# The whole mission so far, not the viewer's default window around the cursor. A browser
# redraws every point its plots show on every frame, so the series are thinned before they are
# logged (`state.SERIES_POLICIES`): an hour's plot holds a few hundred points, not thousands.
WHOLE_MISSION = rrb.TimeAxis(view_range=rrb.TimeRange(
    start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.cursor_relative()))


MAX_TITLE = 28  # characters of a plot's title that fit its column (see `live_blueprint`)


def _series(name: str, *contents: str) -> rrb.TimeSeriesView:
    return rrb.TimeSeriesView(
        name=name, origin="/", contents=[f"+ /{SERIES}/{c}" for c in contents],
        plot_legend=rrb.PlotLegend(corner="LeftTop"), axis_x=WHOLE_MISSION)


def legend_view(bounds: Bounds) -> rrb.Spatial2DView:
    """The swatches of `rerun_log.log_legend`: the map's colours with their names."""
    xmin, xmax, ymin, ymax = bounds
    return rrb.Spatial2DView(
        name="Legend", origin="/legend", contents=["+ /legend/**"], background=[8, 12, 20],
        visual_bounds=rrb.VisualBounds2D(x_range=[xmin, xmax], y_range=[ymin, ymax]))


DEFAULT_LEGEND: Bounds = (-2.8, 14.8, -0.8, 4.9)


def live_blueprint(bounds: Bounds, legend: Bounds = DEFAULT_LEGEND,
                   dynamic: bool = False) -> rrb.Blueprint:
    """The live layout; ``dynamic`` (a scenario with a hidden reef) names the fleet's
    figures as the real reef's and adds the plot of its share of the real priority. Titles
    are at most `MAX_TITLE` characters: a plot column is about 300 pixels wide on a 1400-pixel
    screen, and a longer title is cut."""
    vehicles = rrb.Vertical(
        _series("Battery left (s)", "battery_s"),
        _series("T_diff (s)", "t_diff_s"),
        _series("Spots treated", "spots_treated"),
        _series("Lag behind clock (s)", "lag_s"),
    )
    fleet = rrb.Vertical(
        _series("Real spots, duplicates" if dynamic else "Spots treated, duplicates",
                "fleet/spots"),
        _series("Real priority collected" if dynamic else "Priority collected",
                "fleet/priority"),
        *([_series("Share of the real reef", "fleet/reef")] if dynamic else []),
        _series("Acoustic messages", "fleet/messages", "fleet/drops/**"),
        _series("Acoustic bytes delivered", "fleet/bytes"),
    )
    below = rrb.Horizontal(
        rrb.TextLogView(name="Events", origin="/events", columns=rrb.TextLogColumns(
            text_log_columns=[TextLogColumn("LogLevel"), TextLogColumn("Body"),
                              TextLogColumn("EntityPath", visible=False)])),
        legend_view(legend),
        rrb.TextDocumentView(name="Mission", origin="/mission"),
        column_shares=[4, 4.5, 1.3],
    )
    return rrb.Blueprint(
        rrb.Vertical(
            rrb.Horizontal(map_view(bounds), vehicles, fleet, column_shares=[5, 2, 2]),
            below,
            row_shares=[3, 1.1],
        ),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(timeline=TIMELINE, state="collapsed"),
    )


def plan_blueprint(bounds: Bounds) -> rrb.Blueprint:
    """`cotsfleet plan --rrd`: routes on the map, convergence (paper Fig. 7-8) beside it."""
    conv = rrb.Vertical(
        rrb.TimeSeriesView(name="Cost (eq. 9) per vehicle and total", origin="/convergence/cost"),
        rrb.TimeSeriesView(name="Violation (s) per vehicle", origin="/convergence/violation_s"),
        rrb.TimeSeriesView(name="T_diff (s) per vehicle", origin="/convergence/t_diff_s"),
        rrb.TimeSeriesView(name="Priority collected", origin="/convergence/priority"),
    )
    return rrb.Blueprint(
        rrb.Horizontal(
            map_view(bounds, name="Plan"),
            rrb.Vertical(conv, rrb.TextDocumentView(name="Summary", origin="/summary"),
                         row_shares=[4, 1]),
            column_shares=[3, 2],
        ),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(timeline="iteration", state="collapsed"),
    )
