"""Faults, drifting navigation and loss together, on the shipped reef and the generator's:
the mission ends (nothing raises), every vehicle is in the report, and no
aggregation is treated twice by the world's book. The first case is the fault fuzz's
(docs/search.md, "Faults under drift"): it ended in a `LandError` before replans took
positions at the nearest sea; the second mixes every kind of vehicle fault."""

from __future__ import annotations

import pytest

from benchmarks.fault_fuzz import one, reef_mission
from cotsfleet.mission.faults import Fault
from cotsfleet.mission.inprocess import simulate
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.navigation import NavigationParams
from reef_sim.score import world_tally
from reef_sim.truth import reef_from_doc

CASES = [
    # Green Island, 1 % drift, 20 % loss: auv1 killed; a survivor's takeover replan once
    # placed a peer on the island.
    ("green", 3, (Fault("kill", 790.0, "auv1"),), NavigationParams(drift_pct=1.0), 0.2),
    # The hard reef, 2 % drift with USBL fixes: a kill, a restart, an abort and a stall.
    ("hard", 7, (Fault("kill", 600.0, "auv2"), Fault("restart", 900.0, "auv2"),
                 Fault("abort", 1500.0, "auv3"), Fault("stall", 1800.0, "auv1", 200.0)),
     NavigationParams(drift_pct=2.0, fix_period_s=900.0), 0.0),
]


def _mission(which: str, seed: int):
    doc, config = reef_mission(which, seed)
    problem = problem_from_dict(doc)
    return problem, reef_from_doc(doc, problem), config


@pytest.mark.parametrize("which, seed, faults, navigation, loss", CASES)
def test_faults_under_drift_end_the_mission_and_treat_nothing_twice(which, seed, faults,
                                                                    navigation, loss):
    problem, reef, config = _mission(which, seed)
    result = simulate(problem, config, seed=seed, reef=reef, navigation=navigation,
                      loss=loss, faults=list(faults))
    books = {vid: seat.driver.vehicle.treatments for vid, seat in result.backend.seats.items()
             if seat.driver is not None}
    world = world_tally(reef, books)
    assert world["duplicates"] == 0
    assert world["priority"] > 0
    report = result.report.to_dict()
    assert report["fleet"]["duplicate_treatments"] == 0
    assert len(report["vehicles"]) == problem.n_vehicles


@pytest.mark.slow
@pytest.mark.parametrize("seed", [136, 169])
def test_the_fault_fuzz_missions_that_treated_spots_twice_no_longer_do(seed):
    """`benchmarks.fault_fuzz` seeds 136 (a restart on its whole journal acted at once, at
    49 % loss) and 169 (a sighted spot doubted only by its place on the map, at 1 % drift):
    one and two duplicates on the code before (docs/search.md, "Faults under drift")."""
    row = one(seed)
    assert row["outcome"] == "ran" and row["reef"] == "hard"
    assert row["duplicates"] == 0 and row["priority"] > 0
