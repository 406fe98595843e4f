import numpy as np
import pytest

from hfc_core.engines.hfc import HFCParams
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.model.errors import ScenarioError
from hfc_core.model.plan import vehicle_figures
from hfc_core.model.problem import Problem, Task, Vehicle
from hfc_core.solve import solve
from reef_sim.scenarios.field import GeneratorParams, generate_doc, paper_preset_doc

FAST = dict(population=20, max_iterations=40)


@pytest.fixture(scope="module")
def tight() -> Problem:
    """30 spots, 3 AUVs, batteries far too small for all of them."""
    params = GeneratorParams(n_tasks=30, n_vehicles=3, size_m=600.0, battery_s=1500.0,
                             service_s=60.0)
    return problem_from_dict(generate_doc(params, np.random.default_rng(4)))


def test_ncm1_keeps_every_spot_and_overruns(tight):
    result = solve(tight, "hfc-ncm1", seed=1, **FAST)
    assert sorted(t for r in result.plan.routes for t in r) == list(range(tight.n_tasks))
    assert max(f.violation_s for f in vehicle_figures(tight, result.plan)) > 0


@pytest.mark.parametrize("mode", ["hfc-ncm2", "hfc-cm"])
def test_budgeted_modes_are_feasible_and_record_history(tight, mode):
    # feasibility is asserted by the autouse checker of tests/conftest.py
    result = solve(tight, mode, seed=1, **FAST)
    assert result.iterations == 40 and len(result.history) == 40
    last = result.history[-1]
    assert len(last.cost) == len(last.violation_s) == len(last.t_diff_s) == 3
    figs = vehicle_figures(tight, result.plan)
    assert 0 < sum(f.tasks for f in figs) < tight.n_tasks
    assert [h.iteration for h in result.history] == list(range(1, 41))


def test_same_seed_same_plan(tight):
    a = solve(tight, "hfc-cm", seed=9, **FAST)
    b = solve(tight, "hfc-cm", seed=9, **FAST)
    assert a.plan == b.plan
    assert [h.cost for h in a.history] == [h.cost for h in b.history]


def test_zero_iterations_still_returns_a_feasible_plan(tight):
    result = solve(tight, "hfc-ncm2", seed=0, population=5, max_iterations=0)
    assert result.extra["repaired"] is True


@pytest.mark.parametrize("clustering", ["fcm-max", "fcm-roulette"])
def test_fuzzy_clusterings_plan_too(tight, clustering):
    solve(tight, "hfc-cm", seed=2, clustering=clustering, population=10, max_iterations=10)


def test_unreachable_rendezvous_is_reported():
    p = Problem.build("far", [Vehicle("a", (0, 0, 0), (5000, 0, 0), 100.0, 1.0)],
                      [Task(1, (10, 0, 0), 5.0, 1.0)])
    with pytest.raises(ScenarioError, match="rendezvous"):
        solve(p, "hfc-cm", max_iterations=5, population=3)


@pytest.mark.parametrize("bad", [dict(population=0), dict(population=10, screened=11),
                                 dict(clustering="dbscan"), dict(fuzzifier=1.0)])
def test_bad_params_are_rejected(bad):
    with pytest.raises(ValueError):
        HFCParams(**bad)


def test_unknown_params_are_named(tight):
    with pytest.raises(ValueError, match="populaton"):
        solve(tight, "hfc-cm", max_iterations=1, populaton=5)


def test_paper_pattern_on_the_preset():
    """Table I's pattern (seed 0, the paper's 150 iterations): NCM1 treats every spot and
    overruns; NCM2 fits the battery with fewer; cooperation (CM) treats more than NCM2."""
    p = problem_from_dict(paper_preset_doc(0))
    tasks = {}
    for mode in ("hfc-ncm1", "hfc-ncm2", "hfc-cm"):
        figs = vehicle_figures(p, solve(p, mode, seed=0, max_iterations=150).plan)
        tasks[mode] = sum(f.tasks for f in figs)
        if mode == "hfc-ncm1":
            assert sum(f.violation_s > 0 for f in figs) >= 2
    assert tasks["hfc-ncm1"] == 90
    assert tasks["hfc-ncm2"] < tasks["hfc-cm"] < 90
