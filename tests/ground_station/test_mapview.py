"""The static map: field image of eq. (1), land, forbidden zones, stations, spots."""

from __future__ import annotations

import numpy as np
import pytest

from ground_station import palette
from ground_station.mapview import FIELD_CELLS, map_layers
from hfc_core.model.errors import ScenarioError
from reef_sim.cotsmap import cots_map_of


def test_paper_scenario_draws_the_probability_field_with_land_in_black(paper_doc):
    layers = map_layers(paper_doc)
    pmap = cots_map_of(paper_doc)
    field = layers.field
    assert field is not None and field.rgb.shape == (FIELD_CELLS, FIELD_CELLS, 3)
    assert field.extent == pmap.bounds
    cx, cy = field.cell_m
    xs = field.extent[0] + (np.arange(FIELD_CELLS) + 0.5) * cx
    ys = field.extent[2] + (np.arange(FIELD_CELLS) + 0.5) * cy
    gx, gy = np.meshgrid(xs, ys)
    land = pmap.on_land(gx, gy)
    assert land.any()
    assert (field.rgb[land] == palette.LAND).all()
    # brighter where COTS are more likely: the image follows eq. (1), row 0 at ymin
    prob = pmap.density(gx, gy)
    brightness = field.rgb.astype(float).sum(axis=2)
    sea = ~land
    assert np.corrcoef(prob[sea], brightness[sea])[0, 1] > 0.95
    assert len(layers.spot_ids) == len(paper_doc["tasks"])


def test_scenario_without_map_draws_spots_stations_and_forbidden_zone(small_doc):
    layers = map_layers(small_doc)
    assert layers.field is None
    assert [s.label for s in layers.stations] == ["start", "rendezvous"]
    assert len(layers.forbidden) == 1
    xmin, xmax, ymin, ymax = layers.bounds
    assert xmin < 0 < 100 < xmax and ymin < 0 < 100 < ymax
    radii = layers.spot_radius_m()
    assert radii.argmax() == 2 and radii.argmin() == 0  # priority as size
    np.testing.assert_allclose(layers.spot_xy_of([12, 999, 10]), [[60, 30], [20, 10]])


def test_stations_name_the_vehicles_when_they_do_not_share_them(small_doc):
    small_doc["vehicles"][2]["start"] = [0.0, 50.0, 0.0]
    labels = sorted(s.label for s in map_layers(small_doc).stations)
    assert labels == ["rendezvous", "start auv1,auv2", "start auv3"]


@pytest.mark.parametrize("breakage", [
    lambda d: d["tasks"][0].pop("pos"),
    lambda d: d["tasks"][0].update(pos=["x", 1.0]),
    lambda d: d.update(forbidden=[[[0, 0], [1, 1]]]),
    lambda d: d.update(cots_map={"bounds": [0, 1]}),
])
def test_malformed_scenarios_raise_scenario_error(small_doc, breakage):
    breakage(small_doc)
    with pytest.raises(ScenarioError):
        map_layers(small_doc)


def test_a_current_is_a_grid_of_arrows_off_land_scaled_to_the_cells(paper_doc):
    paper_doc = dict(paper_doc, current={"kind": "tidal", "velocity_mps": [0.3, 0.4]})
    layers = map_layers(paper_doc)
    current = layers.current
    assert current is not None and current.peak_mps == pytest.approx(0.5)
    xy, uv = current.sample(0.0)
    assert 0 < len(xy) < current.n ** 2  # the island's cells have none
    pmap = cots_map_of(paper_doc)
    assert not pmap.on_land(xy[:, 0], xy[:, 1]).any()
    xmin, xmax, _, _ = layers.field.extent
    longest = np.hypot(*(uv * current.scale_s).T).max()
    assert longest == pytest.approx(0.8 * (xmax - xmin) / current.n, rel=0.01)
    assert map_layers(dict(paper_doc, current=None)).current is None
    with pytest.raises(ScenarioError):
        map_layers(dict(paper_doc, current={"kind": "tidal"}))
