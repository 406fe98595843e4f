import numpy as np
import pytest
from numpy.testing import assert_allclose

from hfc_core.formats.scenario import problem_from_dict
from hfc_core.formats.top import parse_top
from hfc_core.model.cost import CostWeights, RouteModel, eq9_cost
from hfc_core.model.errors import ScenarioError
from hfc_core.model.problem import Problem, Task, Vehicle
from reef_sim.scenarios.field import paper_preset_doc


@pytest.fixture
def small_problem() -> Problem:
    vehicles = [Vehicle("a", (0, 0, 0), (100, 0, 0), 400.0, 1.0),
                Vehicle("b", (0, 0, 0), (0, 100, 0), 300.0, 2.0)]
    tasks = [Task(i + 1, (10.0 * i, 5.0, -3.0), 10.0 + i, 20.0) for i in range(6)]
    return Problem.build("small", vehicles, tasks)


def test_eq9_by_hand():
    w = CostWeights(lambda1_per_s=2.0, lambda2=1000.0, lambda3=3.0, epsilon_per_s=4.0)
    # within budget: 2 * |90 - 100| + 1000 / 50; no violation term
    assert eq9_cost(90.0, 100.0, 50.0, w) == pytest.approx(20.0 + 20.0)
    # overdue by 10 s: 2 * 10 + 1000 / 50 + 3 * 4 * 10
    assert eq9_cost(110.0, 100.0, 50.0, w) == pytest.approx(20.0 + 20.0 + 120.0)
    # an empty route's priority is floored, not divided by zero
    assert eq9_cost(100.0, 100.0, 0.0, w) == pytest.approx(1000.0)


def test_eq9_is_vectorised():
    w = CostWeights()
    times = np.array([3000.0, 3600.0, 4000.0])
    got = eq9_cost(times, 3600.0, np.array([100.0, 100.0, 100.0]), w)
    want = [eq9_cost(t, 3600.0, 100.0, w) for t in times]
    assert_allclose(got, want)


def test_route_model_agrees_with_problem(small_problem):
    model = RouteModel(small_problem)
    for v, route in ((0, [2, 0, 5]), (1, [1, 3]), (1, [])):
        assert model.time_s(v, route) == pytest.approx(small_problem.route_time_s(v, route))
    routes = [[0, 1], [2]]
    assert_allclose(model.violation_s(routes),
                    np.maximum(0, model.times_s(routes) - model.battery_s))
    assert model.cost(1, [2], CostWeights()) == pytest.approx(model.costs(routes, CostWeights())[1])


def test_scaling_keeps_the_paper_setting_and_rescales_top(top_dir):
    paper = problem_from_dict(paper_preset_doc(0))
    scaled = CostWeights().scaled_to(paper)
    assert scaled.lambda2 == pytest.approx(2e7, rel=0.15)
    top = parse_top((top_dir / "p4.3.f.txt").read_text(), "p4.3.f")
    # l2 scales with time (33.3 s vs 3600 s) and total priority (1306 vs 90 * 50.5)
    assert CostWeights().scaled_to(top).lambda2 == pytest.approx(
        2e7 * (33.3 / 3600.0) * (1306.0 / 4545.0), rel=1e-3
    )


def test_unreachable_rendezvous_is_a_scenario_error():
    far = Problem.build("far", [Vehicle("a", (0, 0, 0), (500, 0, 0), 100.0, 1.0)], [])
    with pytest.raises(ScenarioError, match="vehicle a"):
        RouteModel(far).require_reachable()


@pytest.mark.parametrize("bad", [dict(lambda1_per_s=-1.0), dict(lambda2=float("inf")),
                                 dict(epsilon_per_s=0.0), dict(priority_floor=0.0)])
def test_bad_weights_are_rejected(bad):
    with pytest.raises(ValueError):
        CostWeights(**bad)
