import numpy as np
import pytest
from numpy.testing import assert_allclose

from hfc_core.engines.operators.screening import removal_costs, screen, screen_route
from hfc_core.model.cost import CostWeights, RouteModel
from hfc_core.model.problem import Problem, Task, Vehicle


@pytest.fixture
def crowded() -> Problem:
    """20 spots on a 200 m square; 1000 s of battery cannot serve them all."""
    rng = np.random.default_rng(2)
    xy = rng.uniform(0, 200, size=(20, 2))
    tasks = [Task(i + 100, (x, y, -5.0), float(rng.uniform(1, 100)), 60.0)
             for i, (x, y) in enumerate(xy)]
    vehicles = [Vehicle("a", (0, 0, 0), (200, 200, 0), 1000.0, 1.0),
                Vehicle("b", (0, 0, 0), (200, 200, 0), 5000.0, 1.0)]
    return Problem.build("crowded", vehicles, tasks)


@pytest.fixture
def weights() -> CostWeights:
    return CostWeights()


def test_removal_costs_match_recomputation(crowded, weights):
    model = RouteModel(crowded)
    route = list(range(12))
    costs, times = removal_costs(route, model=model, v=0, weights=weights)
    for i in range(len(route)):
        rest = route[:i] + route[i + 1:]
        assert times[i] == pytest.approx(model.time_s(0, rest))
        assert costs[i] == pytest.approx(model.cost(0, rest, weights))


def test_screening_ends_feasible_and_only_removes(crowded, weights):
    model = RouteModel(crowded)
    route = list(range(20))
    screened = screen_route(route, model=model, v=0, weights=weights)
    assert model.time_s(0, screened) <= model.battery_s[0]
    assert set(screened) < set(route)
    assert screened == [t for t in route if t in set(screened)]  # order kept


def test_screening_drops_the_far_cheap_spot_first(weights):
    # three spots on the way, one low-priority spot far off the route
    tasks = [Task(1, (100, 0, 0), 50.0, 10.0), Task(2, (200, 0, 0), 50.0, 10.0),
             Task(3, (300, 0, 0), 50.0, 10.0), Task(4, (200, 300, 0), 5.0, 10.0)]
    p = Problem.build("detour", [Vehicle("a", (0, 0, 0), (400, 0, 0), 500.0, 1.0)], tasks)
    model = RouteModel(p)
    assert model.time_s(0, [0, 1, 3, 2]) > 500.0
    assert screen_route([0, 1, 3, 2], model=model, v=0, weights=weights) == [0, 1, 2]


def test_screen_leaves_feasible_routes_alone(crowded, weights):
    model = RouteModel(crowded)
    routes = [list(range(10)), list(range(10, 20))]
    out = screen(routes, np.random.default_rng(0), model=model, weights=weights)
    assert out[1] == routes[1]  # vehicle b has 5000 s: nothing to screen
    assert model.time_s(0, out[0]) <= model.battery_s[0]
    assert_allclose(model.violation_s(out), 0.0)
