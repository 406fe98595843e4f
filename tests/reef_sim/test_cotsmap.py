import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from hfc_core.model.errors import ScenarioError
from reef_sim.cotsmap import ProbabilityMap, VortexCentre, cots_map_of, points_in_polygon


@pytest.fixture
def one_centre() -> ProbabilityMap:
    return ProbabilityMap((0.0, 1000.0, 0.0, 1000.0), (VortexCentre(500.0, 500.0, 50.0, 2.0),))


@pytest.fixture
def coast_map() -> ProbabilityMap:
    return ProbabilityMap(
        (0.0, 1000.0, 0.0, 1000.0),
        (VortexCentre(300.0, 300.0, 40.0, 1.0), VortexCentre(700.0, 700.0, 40.0, 1.0)),
        land=(((0.0, 1000.0), (0.0, 700.0), (300.0, 1000.0)),),
    )


def test_field_is_eq1_at_a_point():
    c = VortexCentre(10.0, 20.0, 5.0, 3.0)
    x, y = np.array(13.0), np.array(24.0)
    d2 = 3.0**2 + 4.0**2
    tx = 3.0 * (24.0 - 20.0) * (math.exp(-d2 / 25.0) - 1.0) / (2 * math.pi * d2)
    ty = 3.0 * (13.0 - 10.0) * (1.0 - math.exp(-d2 / 25.0)) / (2 * math.pi * d2)
    assert_allclose(c.field(x, y), (tx, ty), rtol=1e-12)


def test_single_centre_is_a_ring_zero_at_the_centre(one_centre):
    r = 50.0
    d = np.linspace(1.0, 300.0, 3000)
    p = one_centre.density(500.0 + d, np.full_like(d, 500.0))
    assert one_centre.density(500.0, 500.0) == 0.0
    # the magnitude T (1 - e^{-d^2/r^2}) / (2 pi d) peaks at d ~ 1.1209 r
    assert d[np.argmax(p)] == pytest.approx(1.1209 * r, rel=0.01)
    closed_form = -np.expm1(-(d**2) / r**2) / d
    assert_allclose(p / p.max(), closed_form / closed_form.max(), rtol=1e-3)


def test_grid_is_normalised_with_row_zero_at_ymin():
    m = ProbabilityMap((0.0, 400.0, 0.0, 200.0), (VortexCentre(200.0, 20.0, 10.0, 1.0),))
    prob, extent = m.grid(10.0)
    assert prob.shape == (20, 40)
    assert extent == (0.0, 400.0, 0.0, 200.0)
    assert prob.min() >= 0.0 and prob.max() <= 1.0 and prob.max() > 0.9
    row_of_peak = np.unravel_index(np.argmax(prob), prob.shape)[0]
    assert row_of_peak <= 3  # the centre lies near ymin, so near row 0


def test_land_has_zero_probability(coast_map):
    prob, _ = coast_map.grid(10.0)
    xs = np.arange(5.0, 1000.0, 10.0)
    gx, gy = np.meshgrid(xs, xs)
    land = gy > gx + 700.0
    assert land.any()
    assert np.all(prob[land] == 0.0)
    assert np.all(prob[~land & (np.hypot(gx - 300, gy - 300) < 100)] > 0)


def test_points_in_polygon_even_odd_rule():
    square = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    x = np.array([5.0, -1.0, 11.0, 5.0, 9.99])
    y = np.array([5.0, 5.0, 5.0, 10.5, 0.01])
    assert points_in_polygon(x, y, square).tolist() == [True, False, False, False, True]


def test_vector_combination_cancels_where_the_sum_does_not():
    centres = (VortexCentre(400.0, 500.0, 50.0, 1.0), VortexCentre(600.0, 500.0, 50.0, 1.0))
    summed = ProbabilityMap((0.0, 1000.0, 0.0, 1000.0), centres, combine="sum")
    vector = ProbabilityMap((0.0, 1000.0, 0.0, 1000.0), centres, combine="vector")
    # midway between two equal vortices their fields are opposite
    assert vector.density(500.0, 500.0) == pytest.approx(0.0, abs=1e-12)
    assert summed.density(500.0, 500.0) > 0.1


def test_dict_round_trip_is_json_and_exact(coast_map):
    doc = json.loads(json.dumps(coast_map.to_dict()))
    again = ProbabilityMap.from_dict(doc)
    x = np.linspace(0, 1000, 57)
    gx, gy = np.meshgrid(x, x)
    assert_allclose(again.density(gx, gy), coast_map.density(gx, gy))
    assert again.land_polygons() == coast_map.land_polygons()


def test_cots_map_of_reads_the_scenario_field(coast_map):
    assert cots_map_of({"name": "x"}) is None
    found = cots_map_of({"cots_map": coast_map.to_dict()})
    assert found is not None and found.combine == "sum"


@pytest.mark.parametrize(
    "doc",
    [
        {"centres": []},
        {"bounds": [0, 1, 0, 1], "centres": []},
        {"bounds": [1, 0, 0, 1], "centres": [{"x_m": 0, "y_m": 0, "radius_m": 1, "density": 1}]},
        {"bounds": [0, 1, 0, 1], "centres": [{"x_m": 0, "y_m": 0, "radius_m": 0, "density": 1}]},
        {"bounds": [0, 1, 0, 1],
         "centres": [{"x_m": "nan", "y_m": 0, "radius_m": 1, "density": 1}]},
        {"bounds": [0, 1, 0, 1], "centres": [{"x_m": 0, "y_m": 0, "radius_m": 1}]},
        {"bounds": [0, 1, 0, 1], "centres": [{"x_m": 0, "y_m": 0, "radius_m": 1, "density": 1}],
         "land": [[[0, 0], [1, 1]]]},
    ],
)
def test_malformed_maps_are_scenario_errors(doc):
    with pytest.raises(ScenarioError):
        ProbabilityMap.from_dict(doc)
