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


# -- the hidden reef's knobs (reef_sim.scenarios.dynamic) -------------------------------------

# sha256 (first 16 hex) of six seeds' documents, drawn by the generator as it was before
# unmapped_share, the ring and empty_anchor_weight existed (commit 819a5fc), look_radius_m
# left out of the truth section (a field, not a draw): the old knobs draw what they drew.
OLD_DRAWS = {"preset": "fa291908ed43a8ea", "knobs": "362880219dbaa27c",
             "area": "1d18c826a91f1921", "small": "79d131f1e5c8f8c2"}


def _old_knob_cases():
    from reef_sim.scenarios.area import AreaParams
    from reef_sim.scenarios.dynamic import DynamicParams

    return {"preset": DynamicParams(),
            "knobs": DynamicParams(empty_share=0.4, n_unmapped=30, unmapped_spread_m=20.0,
                                   priority_error=0.5),
            "area": DynamicParams(base=AreaParams(n_tasks=60, n_vehicles=4)),
            "small": DynamicParams(base=GeneratorParams(n_tasks=30, size_m=400.0),
                                   service_range_s=None)}


@pytest.mark.parametrize("case", sorted(OLD_DRAWS))
def test_the_old_knobs_draw_what_they_always_drew(case):
    import hashlib

    from reef_sim.scenarios.dynamic import generate_dynamic_doc

    h = hashlib.sha256()
    for seed in range(6):
        doc = generate_dynamic_doc(_old_knob_cases()[case], np.random.default_rng(seed))
        assert doc["truth"].pop("look_radius_m") == 15.0
        h.update(json.dumps(doc, sort_keys=True).encode())
    assert h.hexdigest()[:16] == OLD_DRAWS[case]


def _hard(seed: int, **kw):
    from reef_sim.scenarios.dynamic import DynamicParams, generate_dynamic_doc

    params = DynamicParams(empty_share=0.28, unmapped_share=0.45, unmapped_min_m=10.0,
                           unmapped_max_m=70.0, **kw)
    return generate_dynamic_doc(params, np.random.default_rng(seed))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_unmapped_aggregations_can_be_a_share_of_the_map_in_a_ring_around_it(seed):
    doc = _hard(seed)
    spots = doc["truth"]["spots"]
    pred = np.array([t["pos"][:2] for t in doc["tasks"]])
    unmapped = np.array([s["pos"][:2] for s in spots if s["task"] is None])
    assert len(unmapped) == 41 == round(0.45 * 90 + 0.5 - 1e-9)  # 40.5 rounds up
    assert sum(s["task"] is not None for s in spots) == 90 - 25  # 28 % of 90 empty: 25
    d = np.linalg.norm(unmapped[:, None, :] - pred[None, :, :], axis=2)
    assert d.min() >= 10.0 - 0.01  # never nearer than the ring's inner radius (rounded)
    assert (d.min(axis=1) <= 70.0 + 0.01).all()  # within the outer one of its own spot
    assert problem_from_dict(doc).n_tasks == 90


def test_empty_spots_anchor_fewer_aggregations_when_told():
    near_empty = {}
    for weight in (1.0, 0.0):
        count = 0
        for seed in range(4):
            doc = _hard(seed, empty_anchor_weight=weight)
            named = {s["task"] for s in doc["truth"]["spots"] if s["task"] is not None}
            pred = np.array([t["pos"][:2] for t in doc["tasks"]])
            live = pred[sorted(named)]
            for s in doc["truth"]["spots"]:
                if s["task"] is None:  # only an empty spot within 70 m: it was the anchor
                    d_live = np.linalg.norm(live - s["pos"][:2], axis=1).min()
                    count += d_live > 70.0 + 0.01
        near_empty[weight] = count
    assert near_empty[0.0] == 0 < near_empty[1.0]


@pytest.mark.parametrize("bad", [dict(unmapped_share=-0.1), dict(unmapped_share=0.4, n_unmapped=3),
                                 dict(unmapped_min_m=10.0), dict(unmapped_min_m=70.0,
                                                                 unmapped_max_m=10.0),
                                 dict(empty_anchor_weight=-1.0), dict(look_radius_m=-2.0)])
def test_bad_dynamic_knobs_are_rejected(bad):
    from reef_sim.scenarios.dynamic import DynamicParams

    with pytest.raises(ValueError):
        DynamicParams(**bad)
