"""The centralized online baseline (`cotsfleet.mission.central`): the same vehicles under one
planner that knows everything at once; the mission report's format; never a spot twice,
with exact or drifting navigation; searches when its belief says they pay."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cotsfleet.mission.central import CentralParams, run_central
from fleet_agent.search import BeliefParams
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.model.problem import Problem, Task
from hfc_core.model.problem import Vehicle as Spec
from reef_sim.navigation import NavigationParams
from reef_sim.scenarios.dynamic import DynamicParams, generate_dynamic_doc
from reef_sim.scenarios.field import GeneratorParams
from reef_sim.truth import Reef, TruthSpot, reef_from_doc

FAST = CentralParams(plan_iterations=80, replan_iterations=30)


def small(seed: int) -> tuple[Problem, Reef]:
    params = DynamicParams(base=GeneratorParams(n_tasks=24, n_vehicles=2, size_m=500.0,
                                                battery_s=1500.0), n_unmapped=6,
                           unmapped_spread_m=40.0)
    doc = generate_dynamic_doc(params, np.random.default_rng(seed))
    problem = problem_from_dict(doc)
    reef = reef_from_doc(doc, problem)
    assert reef is not None
    return problem, reef


@pytest.fixture(scope="module")
def exact_run():
    problem, reef = small(3)
    return problem, reef, run_central(problem, reef, seed=3, params=FAST)


def test_it_reports_in_the_mission_format_and_scores_as_the_world_does(exact_run):
    problem, reef, result = exact_run
    r = result.report
    assert r["mode"] == "central" and r["scenario"] == problem.name
    assert {v["id"] for v in r["vehicles"]} == {"auv1", "auv2"}
    assert all(v["home"] for v in r["vehicles"])
    f, d, w = r["fleet"], r["dynamic"], r["world"]
    assert f["duplicate_treatments"] == 0 == w["duplicates"] == d["duplicate_treatments"]
    # with exact navigation the report's reading of the events is the world's own book
    assert f["priority"] == pytest.approx(w["priority"]) and w["missed"] == 0
    assert {t["spot"] for t in d["treated"]} == {i for ids in w["by_vehicle"].values()
                                                 for i in ids}
    assert 0 < f["priority"] <= reef.total_priority()
    assert r["central"]["replans"] > 0 and d["empty_inspected"] > 0


def test_it_is_seeded(exact_run):
    problem, reef, result = exact_run
    assert run_central(problem, reef, seed=3, params=FAST).report == result.report


@pytest.mark.parametrize("seed", [1, 4])
def test_with_drifting_navigation_it_never_treats_a_spot_twice(seed):
    problem, reef = small(seed)
    nav = NavigationParams(drift_pct=2.0)
    r = run_central(problem, reef, seed=seed, navigation=nav, params=FAST).report
    assert r["world"]["duplicates"] == 0
    assert r["world"]["spots_treated"] > 0


def two_aggregations_on_the_way() -> tuple[Problem, Reef]:
    """auv1 flies past an aggregation the map missed; auv2 is the one free to treat it."""
    start = (0.0, 0.0, -5.0)
    tasks = [Task(0, (600.0, 0.0, -5.0), 50.0, 60.0), Task(1, (0.0, 300.0, -5.0), 5.0, 60.0)]
    vehicles = [Spec("auv1", start, start, 1500.0, 1.0), Spec("auv2", start, start, 1500.0, 1.0)]
    problem = Problem.build("on-the-way", vehicles, tasks)
    reef = Reef(20.0, 1.0, 20.0, (TruthSpot((600.0, 0.0, -5.0), 50.0, 60.0, 0),
                                  TruthSpot((0.0, 300.0, -5.0), 5.0, 60.0, 1),
                                  TruthSpot((300.0, 10.0, -5.0), 90.0, 70.0, None)))
    return problem, reef


def test_what_one_vehicle_sees_is_planned_at_once_for_the_whole_fleet():
    problem, reef = two_aggregations_on_the_way()
    r = run_central(problem, reef, seed=0, params=FAST).report
    found = [e for e in r["dynamic"]["treated"] if e["spot"] == 2]
    assert r["dynamic"]["spots_discovered"] == 1 and len(found) == 1
    assert r["world"]["priority"] == pytest.approx(145.0)


def ring_reef() -> tuple[Problem, Reef]:
    """One live spot with aggregations on a ring 40 m around it, out of the camera's reach
    (15 m) from the spot and the way there: only a search around it finds them."""
    start = (0.0, 0.0, -5.0)
    centre = (200.0, 0.0, -5.0)
    tasks = [Task(0, centre, 60.0, 60.0)]
    problem = Problem.build("ring", [Spec("auv1", start, start, 1800.0, 1.0)], tasks)
    ring = [TruthSpot((200.0 + 40.0 * math.cos(a), 40.0 * math.sin(a), -5.0), 50.0, 60.0, None)
            for a in np.linspace(0.6, 2 * math.pi - 0.6, 5)]
    return problem, Reef(15.0, 0.9, 20.0, (TruthSpot(centre, 60.0, 60.0, 0), *ring))


def test_a_search_is_flown_where_the_belief_says_it_pays():
    problem, reef = ring_reef()
    plain = run_central(problem, reef, seed=0, params=FAST).report
    belief = BeliefParams(per_spot=5.0, ring_min_m=30.0, ring_max_m=50.0, cell_m=5.0)
    searching = run_central(problem, reef, seed=0,
                            params=CentralParams(plan_iterations=80, replan_iterations=30,
                                                 belief=belief)).report
    assert plain["central"]["searches_flown"] == 0
    assert searching["central"]["searches_flown"] >= 1  # around the spot (and its finds)
    assert searching["world"]["unmapped_treated"] > plain["world"]["unmapped_treated"]
    assert searching["world"]["duplicates"] == 0


def test_a_belief_that_expects_nothing_flies_no_search():
    problem, reef = ring_reef()
    belief = BeliefParams(per_spot=0.0, ring_min_m=30.0, ring_max_m=50.0, cell_m=5.0)
    r = run_central(problem, reef, seed=0, params=CentralParams(
        plan_iterations=80, replan_iterations=30, belief=belief)).report
    assert r["central"]["searches_flown"] == 0


@pytest.mark.parametrize("bad", [dict(p_cots=1.5), dict(poll_s=0.0), dict(plan_iterations=0),
                                 dict(max_searches=-1)])
def test_bad_parameters_are_refused(bad):
    with pytest.raises(ValueError):
        CentralParams(**bad)


def test_a_drifting_vehicle_flies_to_what_its_camera_saw_and_finds_the_spot_there():
    start = (0.0, 0.0, -5.0)
    spot = (600.0, 0.0, -5.0)
    problem = Problem.build("far", [Spec("auv1", start, start, 3000.0, 1.0)],
                            [Task(0, spot, 50.0, 60.0)])
    # the camera sees 40 m around; a look sees only 5 m around where the vehicle really is
    reef = Reef(40.0, 1.0, 20.0, (TruthSpot(spot, 50.0, 60.0, 0),), look_radius_m=5.0)
    nav = NavigationParams(drift_pct=3.0, walk_m_per_sqrt_km=0.0, start_sigma_m=0.0)
    result = run_central(problem, reef, seed=2, navigation=nav, params=FAST)
    vehicle = result.central.seats[0].port
    # sent to the map's position it would have ended this far off: beyond the look's reach
    assert math.hypot(*vehicle.navigation.error(spot, 600.0)) > 5.0
    # but it saw the aggregation on the way, flew to it, looked and treated it
    assert [t.spot for t in vehicle.treatments] == [0]
    assert math.dist(vehicle.treatments[0].pos[:2], spot[:2]) <= 5.0
    assert result.report["world"]["priority"] == 50.0
