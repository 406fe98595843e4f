"""A map a person can read: where it is and how big (a grid or lines of longitude and
latitude, a scale bar), labels that stand out and do not pile up, titles that fit, and the
report's figures on the dashboard."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import rerun.blueprint as rrb

from cotsfleet.mission.inprocess import simulate
from fleet_agent.config import AgentConfig
from fleet_bus.ledger import SpotValues
from ground_station import palette
from ground_station.blueprint import MAX_TITLE, live_blueprint
from ground_station.graticule import graticule, metre_grid, nice_step
from ground_station.labels import stack
from ground_station.mapview import map_layers
from ground_station.state import FleetPicture
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.dynamic import DynamicParams, generate_dynamic_doc
from reef_sim.scenarios.field import GeneratorParams
from reef_sim.truth import reef_from_doc

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("span,step", [(1060.0, 200.0), (3000.0, 500.0), (90.0, 20.0),
                                       (0.012, 0.002)])
def test_grid_steps_are_round_numbers(span: float, step: float) -> None:
    assert nice_step(span) == pytest.approx(step)


def test_a_metre_grid_and_a_scale_bar_of_round_length() -> None:
    g = metre_grid((-30.0, 1030.0, -30.0, 1030.0))
    xs = sorted({float(line[0, 0]) for line in g.lines if line[0, 0] == line[1, 0]})
    assert xs == [0.0, 200.0, 400.0, 600.0, 800.0, 1000.0] and not g.lonlat
    assert "x 400 m" in g.labels and "y 1 km" in g.labels
    # nothing in the bottom-left corner, where the two edges' labels would meet
    assert all(not (x < -30 + 0.12 * 1060 and y < -30 + 0.06 * 1060) for x, y in g.label_xy)
    bar = g.scale[0]
    assert g.scale_label == "200 m" and bar[1, 0] - bar[0, 0] == pytest.approx(200.0)
    assert bar[1, 0] < 1030.0 and bar[0, 1] > -30.0  # inside the map


def test_a_reef_on_the_globe_gets_longitude_and_latitude() -> None:
    """Green Island (examples/): lines of longitude and latitude, labelled in degrees, that
    cross the map where pyproj puts them."""
    from pyproj import Transformer

    doc = json.loads((REPO / "examples" / "green_island.json").read_text())
    layers = map_layers(doc)
    assert layers.geo is not None
    g = graticule(layers.bounds, layers.geo)
    assert g.lonlat and g.lines
    assert any(label.endswith("° E") for label in g.labels)
    assert any(label.endswith("° S") for label in g.labels)
    crs, (e0, n0) = layers.geo
    back = Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
    east = [label for label in g.labels if label.endswith("E")][0]
    anchor = g.label_xy[list(g.labels).index(east)]
    line = min(g.lines, key=lambda ln: float(np.abs(ln[:, 0] - anchor[0]).min()))
    lons, _ = back.transform(line[:, 0] + e0, line[:, 1] + n0)
    assert np.allclose(lons, float(east.split("°")[0]), atol=1e-6)  # a line of longitude
    assert graticule(layers.bounds, ("EPSG:99999", (0.0, 0.0))).lonlat is False  # metres


def test_stacked_labels_never_overlap() -> None:
    anchors = np.array([[0.0, 0.0], [1.0, 0.5], [2.0, -0.5], [50.0, 50.0], [0.0, 0.0]])
    box = (10.0, 3.0)
    out = stack(anchors, box)
    assert out[0].tolist() == [0.0, 0.0] and out[3].tolist() == [50.0, 50.0]  # free: stay
    for i in range(len(out)):
        for j in range(i):
            assert not (abs(out[i, 0] - out[j, 0]) < box[0]
                        and abs(out[i, 1] - out[j, 1]) < box[1]), (i, j, out)
    assert (out[:, 0] == anchors[:, 0]).all() and (out[:, 1] <= anchors[:, 1]).all()  # down


def test_labels_are_white_because_no_colour_reads_on_the_viewers_grey() -> None:
    for background in palette.LABEL_BACKGROUNDS:
        assert palette.contrast(palette.LABEL_TEXT, background) >= palette.MIN_CONTRAST
    web = palette.LABEL_BACKGROUNDS[0]
    assert palette.contrast(palette.SPOT_ABANDONED, web) < 1.5  # why the legend was unreadable
    assert palette.contrast((0, 0, 0), (255, 255, 255)) == pytest.approx(21.0)


def _titles(view) -> list[str]:
    out = [view.name] if getattr(view, "name", None) else []
    for child in getattr(view, "contents", None) or []:
        if isinstance(child, (rrb.Container, rrb.View)):
            out += _titles(child)
    return out


@pytest.mark.parametrize("dynamic", [False, True])
def test_no_plot_title_is_cut(dynamic: bool) -> None:
    bp = live_blueprint((0.0, 1.0, 0.0, 1.0), dynamic=dynamic)
    titles = _titles(bp.root_container)
    assert "Acoustic messages" in titles and len(titles) >= 10
    assert max(len(t) for t in titles) <= MAX_TITLE, max(titles, key=len)
    assert ("Real priority collected" in titles) == dynamic


def test_the_dashboard_shows_the_reports_figures_on_a_real_reef() -> None:
    """The dashboard folded the fleet's telemetry to the map's priority while the report
    counted the real reef (issue 32: 2938 on the plots, 3372 in the summary)."""
    params = DynamicParams(base=GeneratorParams(name="gs-real", n_tasks=24, n_vehicles=2,
                                                size_m=500.0, battery_s=1500.0), n_unmapped=4)
    doc = generate_dynamic_doc(params, np.random.default_rng(5))
    problem = problem_from_dict(doc)
    result = simulate(problem, AgentConfig(), seed=5, reef=reef_from_doc(doc, problem))
    pic = FleetPicture(map_layers(doc))
    records = [*result.events, *result.statuses.values()]
    for r in sorted(records, key=lambda r: r.t_s):
        pic.apply(r.id, r)
    c = result.report.collected
    figures = pic.fleet_figures()
    assert c.on_reef and c.priority > 0
    assert figures["spots_cleared"] == c.spots
    assert figures["priority_collected"] == pytest.approx(c.priority, abs=0.01)
    assert figures["duplicates"] == c.duplicates
    assert figures["reef_share"] == pytest.approx(c.priority / c.priority_of)
    on_the_map = pic.ledger.collected(SpotValues(pic.values.predicted))
    assert not math.isclose(on_the_map.priority, c.priority)  # what it showed before
