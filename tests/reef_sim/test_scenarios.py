import json

import numpy as np
import pytest
from numpy.testing import assert_array_less

from hfc_core.engines.operators.clustering import kmeans
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.cotsmap import cots_map_of
from reef_sim.scenarios.field import GeneratorParams, generate_doc, paper_preset_doc


@pytest.fixture(scope="module")
def paper_doc() -> dict:
    return paper_preset_doc(0)


def test_paper_preset_is_the_papers_setting(paper_doc):
    p = problem_from_dict(paper_doc)
    assert p.n_tasks == 90
    assert [v.id for v in p.vehicles] == ["auv1", "auv2", "auv3"]
    assert {v.start for v in p.vehicles} == {p.vehicles[0].start}
    assert {v.rendezvous for v in p.vehicles} == {p.vehicles[0].rendezvous}
    assert all(v.battery_s == 3600.0 and v.speed_mps == 1.0 for v in p.vehicles)
    assert np.all(p.service_s == 90.0)
    assert p.priority.min() >= 1.0 and p.priority.max() <= 100.0
    xyz = p.xyz[: p.n_tasks]
    assert np.all((xyz[:, :2] >= 0) & (xyz[:, :2] <= 1000))
    assert_array_less(xyz[:, 2], 0.0)  # spots lie on the seabed, z negative down
    assert "forbidden" not in paper_doc  # land is a map mask only (see generate.py)


def test_spots_are_never_on_land(paper_doc):
    cmap = cots_map_of(paper_doc)
    assert cmap is not None and cmap.land
    xy = np.array([t["pos"][:2] for t in paper_doc["tasks"]])
    assert not cmap.on_land(xy[:, 0], xy[:, 1]).any()
    assert np.all(cmap.density(xy[:, 0], xy[:, 1]) > 0)


def test_paper_preset_has_one_small_cluster(paper_doc):
    p = problem_from_dict(paper_doc)
    labels, _ = kmeans(p.xyz[: p.n_tasks], 3, np.random.default_rng(0))
    sizes = sorted(np.bincount(labels, minlength=3))
    assert sizes[0] <= 0.5 * sizes[1]  # like cluster (2) of the paper's Fig. 6


def test_preset_is_seeded(paper_doc):
    assert json.dumps(paper_preset_doc(0)) == json.dumps(paper_doc)
    other = paper_preset_doc(1)
    assert other["tasks"] != paper_doc["tasks"]
    assert other["cots_map"]["centres"] != paper_doc["cots_map"]["centres"]  # Gaussian jitter


def test_generic_scenario_draws_eq2_service_times():
    params = GeneratorParams(n_tasks=40, n_vehicles=2, size_m=500.0)
    doc = generate_doc(params, np.random.default_rng(3))
    p = problem_from_dict(doc)
    assert p.n_tasks == 40 and p.n_vehicles == 2
    assert p.service_s.min() >= 60.0 and p.service_s.max() <= 90.0
    assert len(doc["cots_map"]["centres"]) == 2


def test_land_becomes_forbidden_only_when_asked():
    land = (((0.0, 500.0), (0.0, 400.0), (100.0, 500.0)),)
    quiet = generate_doc(GeneratorParams(n_tasks=5, size_m=500.0, land=land),
                         np.random.default_rng(0))
    loud = generate_doc(GeneratorParams(n_tasks=5, size_m=500.0, land=land, land_forbidden=True),
                        np.random.default_rng(0))
    assert "forbidden" not in quiet
    assert loud["forbidden"] == [[list(p) for p in land[0]]]


def test_depth_is_shallow_near_the_coast(paper_doc):
    pos = np.array([t["pos"] for t in paper_doc["tasks"]])
    coast_side = pos[:, 1] - pos[:, 0]  # the coast is the line y = x + 760
    near, far = pos[np.argmax(coast_side)], pos[np.argmin(coast_side)]
    assert -near[2] < -far[2]


@pytest.mark.parametrize(
    "bad",
    [dict(n_tasks=-1), dict(n_vehicles=0), dict(size_m=0.0), dict(battery_s=float("nan")),
     dict(speed_mps=-1.0), dict(service_s=-5.0), dict(service_range_s=(90.0, 60.0)),
     dict(concentration=0.0), dict(centre_jitter_m=-1.0)],
)
def test_bad_params_are_rejected(bad):
    with pytest.raises(ValueError):
        GeneratorParams(**bad)
