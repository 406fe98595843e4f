"""A whole in-process mission with the scenario's navigation error (`reef_sim.navigation`):
no section is exact navigation, report for report; a zero-error section changes nothing; a
drifting one reports where the vehicles believe they are."""

from __future__ import annotations

import numpy as np
import pytest

from cotsfleet.mission.inprocess import simulate
from fleet_agent.config import AgentConfig
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.navigation import NavigationParams, navigation_from_doc
from reef_sim.scenarios.dynamic import DynamicParams, generate_dynamic_doc
from reef_sim.scenarios.field import GeneratorParams
from reef_sim.truth import reef_from_doc

CONFIG = AgentConfig(plan_iterations=60, replan_iterations=30)


@pytest.fixture(scope="module")
def small():
    params = DynamicParams(base=GeneratorParams(n_tasks=24, n_vehicles=2, size_m=500.0,
                                                battery_s=1500.0))
    doc = generate_dynamic_doc(params, np.random.default_rng(5))
    problem = problem_from_dict(doc)
    return problem, reef_from_doc(doc, problem)


def test_a_zero_error_section_flies_the_mission_exact_navigation_flies(small):
    problem, reef = small
    exact = simulate(problem, CONFIG, seed=3, reef=reef).report
    zero = NavigationParams(drift_pct=0.0, walk_m_per_sqrt_km=0.0, start_sigma_m=0.0,
                            camera_sigma_m=0.0)
    assert simulate(problem, CONFIG, seed=3, reef=reef, navigation=zero).report == exact
    assert exact.dynamic is not None and exact.dynamic.treated


def test_with_drift_the_vehicles_report_their_estimate_and_the_world_books_the_truth(small):
    problem, reef = small
    nav = navigation_from_doc({"navigation": {"drift_pct": 2.0}})
    result = simulate(problem, CONFIG, seed=3, reef=reef, navigation=nav)
    vehicles = [seat.driver.vehicle for seat in result.backend.seats.values()]
    for v in vehicles:
        fix = v.fix()
        assert fix.sigma_m > 0.5  # it ran hundreds of metres on dead reckoning
        err = np.hypot(fix.pos[0] - v.pos[0], fix.pos[1] - v.pos[1])
        assert 0 < err < 6 * fix.sigma_m
    # every injection is in the world's book, with the truth spot it really treated (if any)
    injected = sum(len(v.treatments) for v in vehicles)
    assert injected >= result.report.fleet.treatments > 0
    assert any(t.spot is not None for v in vehicles for t in v.treatments)
