import math

import numpy as np
import pytest

from hfc_core.formats.scenario import problem_from_dict, problem_to_dict
from hfc_core.formats.top import parse_top
from hfc_core.model.check import check_routes
from hfc_core.model.errors import ScenarioError


def small_doc() -> dict:
    return {
        "name": "tiny",
        "speed_mps": 2.0,
        "vehicles": [
            {"id": "a", "start": [0, 0, 0], "rendezvous": [10, 0, 0], "battery_s": 100},
            {"id": "b", "start": [0, 0, 0], "rendezvous": [0, 10, 0], "battery_s": 50,
             "speed_mps": 1.0},
        ],
        "tasks": [
            {"id": 7, "pos": [3, 4, 0], "priority": 10, "service_s": 5},
            {"id": 9, "pos": [0, 0, -12], "priority": 1, "service_s": 0},
        ],
    }


def test_route_time_counts_3d_travel_and_service_once():
    p = problem_from_dict(small_doc())
    # a: (0,0,0)->(3,4,0) 5 m, ->(10,0,0) sqrt(49+16) m, at 2 m/s, + 5 s service
    expected = (5 + math.sqrt(65)) / 2 + 5
    assert p.route_time_s(0, [0]) == pytest.approx(expected)
    # b is slower (its own speed overrides the fleet's): 12 m down, then sqrt(100+144) m
    assert p.route_time_s(1, [1]) == pytest.approx(12 + math.sqrt(244))
    assert p.route_time_s(0, []) == pytest.approx(5.0)


def test_round_trip_through_dict():
    p = problem_from_dict(small_doc())
    q = problem_from_dict(problem_to_dict(p))
    np.testing.assert_allclose(p.dist_m, q.dist_m)
    assert [v.speed_mps for v in q.vehicles] == [2.0, 1.0]


@pytest.mark.parametrize(
    "mutate, message",
    [
        (lambda d: d.pop("vehicles"), "missing field 'vehicles'"),
        (lambda d: d["tasks"][0].pop("priority"), "missing field 'priority'"),
        (lambda d: d["tasks"].append(dict(d["tasks"][0])), "duplicate task id 7"),
        (lambda d: d["vehicles"].append(dict(d["vehicles"][0])), "duplicate vehicle id 'a'"),
        (lambda d: d["tasks"][0].update(pos=[1, float("nan"), 0]), "must be finite"),
        (lambda d: d["tasks"][0].update(priority=float("inf")), "must be finite"),
        (lambda d: d["vehicles"][0].update(battery_s=0), "battery_s must be positive"),
        (lambda d: d.update(speed_mps=-1), "speed_mps must be positive"),
        (lambda d: d["vehicles"][1].update(speed_mps=0), "speed_mps must be positive"),
        (lambda d: d["tasks"][0].update(pos="here"), "expected [x, y, z]"),
        (lambda d: d["tasks"][0].update(id="x"), "task id must be an integer"),
        (lambda d: d.update(forbidden=[[[0, 0], [1, 1]]]), "at least 3"),
    ],
)
def test_bad_scenarios_are_refused_with_a_clear_message(mutate, message):
    doc = small_doc()
    mutate(doc)
    with pytest.raises(ScenarioError, match=message.replace("[", r"\[").replace("]", r"\]")):
        problem_from_dict(doc)


def test_checker_finds_duplicates_unknowns_and_overruns():
    p = problem_from_dict(small_doc())
    assert check_routes(p, {"a": [7], "b": [9]}) == []  # b: 12 + 15.6 s fits its 50 s
    assert check_routes(p, {"a": [7], "b": []}) == []
    errors = check_routes(p, {"a": [7, 7], "zz": [1], "b": [42]})
    assert any("visited by both" in e for e in errors)
    assert any("unknown vehicle" in e for e in errors)
    assert any("unknown task 42" in e for e in errors)
    tight = small_doc()
    tight["vehicles"][0]["battery_s"] = 8
    assert any("exceeds battery" in e for e in check_routes(problem_from_dict(tight), {"a": [7]}))
    assert check_routes(problem_from_dict(tight), {"a": [7]}, enforce_budget=False) == []


def test_top_reader_maps_start_end_and_ids(top_dir):
    p = parse_top((top_dir / "p2.2.g.txt").read_text(), "p2.2.g")
    assert p.n_vehicles == 2 and p.n_tasks == 19
    assert [t.id for t in p.tasks] == list(range(1, 20))
    assert all(v.battery_s == 16.0 and v.speed_mps == 1.0 for v in p.vehicles)
    assert all(t.service_s == 0 for t in p.tasks)


@pytest.mark.parametrize(
    "text, message",
    [
        ("m 2\nn 3\ntmax 1\n", "'n <value>' header"),
        ("n 3\nm 1\ntmax 5\n0 0 0\n1 1 1\n", "header says 3 points"),
        ("n 3\nm 1\ntmax 5\n0 0 0\n1 x 1\n2 2 0\n", "non-numeric"),
    ],
)
def test_top_reader_rejects_malformed_files(text, message):
    with pytest.raises(ScenarioError, match=message):
        parse_top(text)


def test_with_reserve_keeps_the_margin_back_from_every_battery():
    p = problem_from_dict(small_doc())
    q = p.with_reserve(2.5)
    assert [v.battery_s for v in q.vehicles] == [97.5, 47.5]
    assert q.dist_m is p.dist_m and q.travel_s[0] is p.travel_s[0]  # matrices shared
    assert p.vehicles[0].battery_s == 100  # the original is untouched
    assert p.with_reserve(0.0) is p
    with pytest.raises(ScenarioError, match="leaves no battery to b"):
        p.with_reserve(50.0)
    with pytest.raises(ScenarioError, match="reserve_s must be >= 0"):
        p.with_reserve(-1.0)
