"""The hidden reef (`reef_sim.truth`) and the dynamic scenario generator that draws it."""

import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from hfc_core.formats.scenario import problem_from_dict
from hfc_core.model.errors import ScenarioError
from reef_sim.cotsmap import cots_map_of, on_land
from reef_sim.scenarios.area import AreaParams
from reef_sim.scenarios.dynamic import DynamicParams, dynamic_preset_doc, generate_dynamic_doc
from reef_sim.scenarios.field import PAPER_PRESET, GeneratorParams, generate_doc, paper_preset_doc
from reef_sim.truth import Reef, TruthSpot, exact_reef, reef_from_doc, truth_problem


@pytest.fixture(scope="module")
def dynamic_doc() -> dict:
    return dynamic_preset_doc(0)


def _small_doc() -> dict:
    """Eight predicted spots (ids 1..8 at indices 0..7), a corner of land, a truth section."""
    doc = generate_doc(GeneratorParams(n_tasks=8, n_vehicles=2, size_m=400.0, battery_s=900.0),
                       np.random.default_rng(2))
    doc["forbidden"] = [[[390.0, 390.0], [399.0, 390.0], [399.0, 399.0]]]
    doc["truth"] = {"detect_radius_m": 25.0, "p_detect": 0.9, "inspect_s": 20.0,
                    "spots": [{"pos": [1.0, 2.0, -3.0], "priority": 57.0, "service_s": 74.2,
                               "task": 1},
                              {"pos": [5.0, 6.0, -3.0], "priority": 31.0, "service_s": 66.0,
                               "task": None},
                              {"pos": [8.0, 9.0], "priority": 12.0, "service_s": 60.0,
                               "task": 6},
                              {"pos": [30.0, 40.0, -5.0], "priority": 1.0, "service_s": 61.0}]}
    return doc


def test_a_scenario_without_truth_has_no_reef_and_means_the_exact_map():
    doc = paper_preset_doc(0)
    p = problem_from_dict(doc)
    assert reef_from_doc(doc, p) is None
    reef = exact_reef(p)
    assert len(reef.spots) == p.n_tasks and reef.unmapped() == [] and reef.empty(p.n_tasks) == []
    assert [reef.of_task(i) for i in range(p.n_tasks)] == list(range(p.n_tasks))
    assert reef.total_priority() == pytest.approx(float(p.priority.sum()))
    assert all(s.pos == t.pos and s.service_s == t.service_s
               for s, t in zip(reef.spots, p.tasks))
    assert reef.inspect_s == 0.0  # nothing to learn by looking: missions behave as before


def test_truth_is_read_with_task_indices():
    doc = _small_doc()
    p = problem_from_dict(doc)  # the planner ignores the truth section
    reef = reef_from_doc(doc, p)
    assert reef is not None and (reef.detect_radius_m, reef.p_detect, reef.inspect_s) == (
        25.0, 0.9, 20.0)
    assert reef.of_task(1) == 0 and reef.of_task(6) == 2 and reef.of_task(0) is None
    assert reef.unmapped() == [1, 3]  # null and absent alike
    assert reef.empty(p.n_tasks) == [0, 2, 3, 4, 5, 7]
    assert reef.total_priority() == 101.0
    assert reef.spots[2].pos == (8.0, 9.0, 0.0)  # z defaults to the surface, as for tasks


def test_truth_knobs_default_to_the_sensor_defaults():
    doc = _small_doc()
    doc["truth"] = {"spots": []}
    reef = reef_from_doc(doc, problem_from_dict(doc))
    assert reef == Reef(25.0, 0.9, 20.0, ())


def _set(path, value):
    def change(doc):
        *head, last = path
        target = doc
        for key in head:
            target = target[key]
        target[last] = value
    return change


def _drop(path):
    def change(doc):
        *head, last = path
        target = doc
        for key in head:
            target = target[key]
        del target[last]
    return change


MALFORMED = {
    "priority NaN": (_set(["truth", "spots", 0, "priority"], math.nan),
                     "truth.spots[0].priority: must be finite"),
    "priority as text": (_set(["truth", "spots", 3, "priority"], "57"),
                         "truth.spots[3].priority: expected a number, got '57'"),
    "negative priority": (_set(["truth", "spots", 3, "priority"], -1.0),
                          "truth.spots[3].priority: must be >= 0"),
    "service infinite": (_set(["truth", "spots", 1, "service_s"], math.inf),
                         "truth.spots[1].service_s: must be finite"),
    "no such task": (_set(["truth", "spots", 3, "task"], 999),
                     "truth.spots[3].task: no task 999 in the scenario"),
    "negative task": (_set(["truth", "spots", 3, "task"], -1),
                      "truth.spots[3].task: no task -1 in the scenario"),
    "task as text": (_set(["truth", "spots", 3, "task"], "6"),
                     "truth.spots[3].task: expected the index of a task or null, got '6'"),
    "task as bool": (_set(["truth", "spots", 3, "task"], True),
                     "truth.spots[3].task: expected the index of a task or null, got True"),
    "two spots, one task": (_set(["truth", "spots", 3, "task"], 1),
                            "truth.spots[3].task: task 1 is already named by truth.spots[0]"),
    "p_detect above 1": (_set(["truth", "p_detect"], 1.5), "truth.p_detect must be in 0..1"),
    "p_detect negative": (_set(["truth", "p_detect"], -0.1), "truth.p_detect must be in 0..1"),
    "p_detect NaN": (_set(["truth", "p_detect"], math.nan), "truth.p_detect: must be finite"),
    "negative radius": (_set(["truth", "detect_radius_m"], -5.0),
                        "truth.detect_radius_m: must be >= 0"),
    "negative inspect": (_set(["truth", "inspect_s"], -1.0), "truth.inspect_s: must be >= 0"),
    "pos too short": (_set(["truth", "spots", 2, "pos"], [1.0]),
                      "truth.spots[2].pos: expected [x, y, z] in metres"),
    "pos NaN": (_set(["truth", "spots", 2, "pos"], [1.0, math.nan]),
                "truth.spots[2].pos[1]: must be finite"),
    "pos on land": (_set(["truth", "spots", 2, "pos"], [397.0, 392.0, -1.0]),
                    "truth.spots[2].pos: [397.0, 392.0, -1.0] is on land (forbidden)"),
    "pos missing": (_drop(["truth", "spots", 1, "pos"]), "truth.spots[1]: missing field 'pos'"),
    "spot not an object": (_set(["truth", "spots", 1], 7),
                           "truth.spots[1]: expected an object, got int"),
    "spots missing": (_drop(["truth", "spots"]), "truth: missing field 'spots'"),
    "spots not a list": (_set(["truth", "spots"], {}), "truth.spots: expected a list, got dict"),
    "truth not an object": (_set(["truth"], None), "truth: expected an object, got NoneType"),
}


@pytest.mark.parametrize("how", list(MALFORMED))
def test_a_malformed_truth_is_refused_naming_the_field(how):
    change, message = MALFORMED[how]
    doc = _small_doc()
    change(doc)
    p = problem_from_dict(doc)  # the planner's view is unaffected
    with pytest.raises(ScenarioError) as caught:
        reef_from_doc(doc, p)
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_an_integral_float_task_is_an_index():
    doc = _small_doc()
    doc["truth"]["spots"][3]["task"] = 4.0  # JSON Schema counts 4.0 as an integer
    assert reef_from_doc(doc, problem_from_dict(doc)).of_task(4) == 3


def test_reefs_built_in_code_check_themselves():
    with pytest.raises(ScenarioError, match="already named"):
        Reef(spots=(TruthSpot((0, 0), 1, 60, 2), TruthSpot((1, 1), 1, 60, 2)))
    with pytest.raises(ScenarioError, match="p_detect must be in 0..1"):
        Reef(p_detect=2.0)
    with pytest.raises(ScenarioError, match="priority: must be finite"):
        TruthSpot((0, 0), math.nan, 60)
    with pytest.raises(ScenarioError, match="task must be a task index"):
        TruthSpot((0, 0), 1, 60, -3)


def test_truth_problem_has_one_task_per_truth_spot(dynamic_doc):
    p = problem_from_dict(dynamic_doc)
    reef = reef_from_doc(dynamic_doc, p)
    q = truth_problem(p, reef)
    assert q.n_tasks == len(reef.spots) == 90 - 23 + 12
    assert [t.id for t in q.tasks] == list(range(len(reef.spots)))
    assert_allclose(q.priority, [s.priority for s in reef.spots])
    assert_allclose(q.service_s, [s.service_s for s in reef.spots])
    assert q.vehicles == p.vehicles
    doc = _small_doc()
    small = problem_from_dict(doc)
    q = truth_problem(small, reef_from_doc(doc, small))
    assert q.n_tasks == 4 and q.land is not None and len(q.forbidden) == 1


# -- the generator --------------------------------------------------------------------------


def test_dynamic_scenario_round_trips_through_json(dynamic_doc):
    doc = json.loads(json.dumps(dynamic_doc))
    p = problem_from_dict(doc)
    reef = reef_from_doc(doc, p)
    assert reef.to_dict() == dynamic_doc["truth"]
    assert (reef.detect_radius_m, reef.p_detect, reef.inspect_s) == (25.0, 0.9, 20.0)
    assert dynamic_doc["name"] == "paper-dynamic-seed0"


def test_the_prior_is_the_static_scenario_of_the_same_seed(dynamic_doc):
    static = paper_preset_doc(0)
    assert {k: v for k, v in dynamic_doc.items() if k not in ("truth", "navigation", "name")} == {
        k: v for k, v in static.items() if k != "name"}


def test_dynamic_preset_is_seeded(dynamic_doc):
    assert json.dumps(dynamic_preset_doc(0)) == json.dumps(dynamic_doc)
    assert dynamic_preset_doc(1)["truth"] != dynamic_doc["truth"]


def test_defaults_of_the_paper_preset(dynamic_doc):
    p = problem_from_dict(dynamic_doc)
    reef = reef_from_doc(dynamic_doc, p)
    assert len(reef.empty(90)) == 23 and len(reef.unmapped()) == 12  # 0.25 x 90 rounds up
    real = np.array([s.service_s for s in reef.spots])
    assert real.min() >= 60.0 and real.max() <= 90.0  # eq. 2's times; the map plans with 90


@pytest.mark.parametrize("share", [0.0, 0.1, 0.5, 0.9, 1.0])
def test_empty_share_is_the_share_of_empty_predicted_spots(share):
    doc = generate_dynamic_doc(DynamicParams(empty_share=share), np.random.default_rng(4))
    reef = reef_from_doc(doc, problem_from_dict(doc))
    assert abs(len(reef.empty(90)) / 90 - share) <= 0.5 / 90 + 1e-12


def test_a_larger_empty_share_empties_more_of_the_same_spots():
    def empty(share):
        doc = generate_dynamic_doc(DynamicParams(empty_share=share), np.random.default_rng(5))
        return set(reef_from_doc(doc, problem_from_dict(doc)).empty(90))

    assert empty(0.1) < empty(0.3) < empty(0.6)


def _ratios(error, seeds=range(6)):
    out = []
    for seed in seeds:
        doc = generate_dynamic_doc(DynamicParams(priority_error=error, n_unmapped=0),
                                   np.random.default_rng(seed))
        predicted = {i: t["priority"] for i, t in enumerate(doc["tasks"])}
        out += [s["priority"] / predicted[s["task"]] for s in doc["truth"]["spots"]]
    return np.array(out)


def test_priority_error_is_the_relative_spread_of_the_real_priority():
    assert_allclose(_ratios(0.0), 1.0, atol=0.01)  # rounding to 0.01 only
    ratios = _ratios(0.3)  # ~400 spots
    assert 0.25 < np.std(np.log(ratios)) < 0.35
    assert 0.93 < ratios.mean() < 1.07  # right on average
    assert np.std(np.log(_ratios(0.6))) > 0.5


@pytest.mark.parametrize("n", [0, 1, 12, 40])
def test_unmapped_count_is_exact(n):
    doc = generate_dynamic_doc(DynamicParams(n_unmapped=n), np.random.default_rng(1))
    reef = reef_from_doc(doc, problem_from_dict(doc))
    assert len(reef.unmapped()) == n


def _unmapped_xy(doc):
    return np.array([s["pos"][:2] for s in doc["truth"]["spots"] if s["task"] is None])


def test_unmapped_spots_lie_in_the_water_and_the_area():
    # the paper's coast, and an island with land written as forbidden polygons
    island = ((450.0, 450.0), (600.0, 430.0), (620.0, 600.0), (470.0, 620.0))
    base = GeneratorParams(n_tasks=60, size_m=1000.0, land=(island,), land_forbidden=True,
                           centres=PAPER_PRESET.centres[:1] + (
                               PAPER_PRESET.centres[0].__class__(560.0, 360.0, 40.0, 3.0),))
    for params in (DynamicParams(n_unmapped=200, unmapped_spread_m=150.0),
                   DynamicParams(base=base, n_unmapped=200, unmapped_spread_m=150.0)):
        doc = generate_dynamic_doc(params, np.random.default_rng(2))
        xy = _unmapped_xy(doc)
        land = cots_map_of(doc).land
        assert len(xy) == 200 and not on_land(land, xy[:, 0], xy[:, 1]).any()
        assert xy.min() >= 0 and xy.max() <= 1000
        reef_from_doc(doc, problem_from_dict(doc))  # not on the forbidden land either
    assert "forbidden" in doc


def test_unmapped_spots_sit_near_the_predicted_ones_by_their_spread():
    def median_gap(spread):
        doc = generate_dynamic_doc(DynamicParams(n_unmapped=100, unmapped_spread_m=spread),
                                   np.random.default_rng(3))
        pred = np.array([t["pos"][:2] for t in doc["tasks"]])
        xy = _unmapped_xy(doc)
        return float(np.median(np.linalg.norm(xy[:, None] - pred[None], axis=2).min(axis=1)))

    near, far = median_gap(10.0), median_gap(200.0)
    assert near < 10.0 and far > 3 * near


def test_all_knobs_off_is_the_exact_reef():
    params = DynamicParams(empty_share=0.0, priority_error=0.0, n_unmapped=0,
                           service_range_s=None, inspect_s=0.0)
    doc = generate_dynamic_doc(params, np.random.default_rng(6))
    p = problem_from_dict(doc)
    assert reef_from_doc(doc, p) == exact_reef(p)


def test_a_large_area_gets_a_truth_too():
    params = DynamicParams(base=AreaParams(n_tasks=120, n_vehicles=4, area_m=2500.0))
    doc = generate_dynamic_doc(params, np.random.default_rng(0))
    reef = reef_from_doc(doc, problem_from_dict(doc))
    assert len(reef.unmapped()) == 16 and len(reef.empty(120)) == 30  # 12 per 90; 0.25
    xy = _unmapped_xy(doc)
    assert xy.min() >= 0 and xy.max() <= 2500
    assert {s["pos"][2] for s in doc["truth"]["spots"]} == {-18.0}  # open water, as the tasks


@pytest.mark.parametrize("bad", [
    {"empty_share": 1.5}, {"empty_share": -0.1}, {"empty_share": math.nan},
    {"priority_error": -0.1}, {"priority_error": math.inf}, {"n_unmapped": -1},
    {"n_unmapped": 2.5}, {"unmapped_spread_m": 0.0}, {"p_detect": 1.1},
    {"detect_radius_m": -1.0}, {"inspect_s": math.nan}, {"service_range_s": (90.0, 60.0)},
    {"base": "paper"},
])
def test_bad_dynamic_params_are_rejected(bad):
    with pytest.raises(ValueError):
        DynamicParams(**bad)
