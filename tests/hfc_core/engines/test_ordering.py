import numpy as np
import pytest

from hfc_core.engines.operators.ordering import (
    INSERTION,
    MOVES,
    REVERSION,
    SWAP,
    insertion,
    move_delta_m,
    order,
    order_route,
    reversion,
    swap,
)
from hfc_core.model.cost import RouteModel
from hfc_core.model.problem import Problem, Task, Vehicle


@pytest.fixture
def scattered() -> Problem:
    rng = np.random.default_rng(11)
    xyz = rng.uniform(0, 500, size=(25, 3)) * [1, 1, -0.02]
    tasks = [Task(i, tuple(p), 1.0, 30.0) for i, p in enumerate(xyz)]
    vehicles = [Vehicle("a", (0, 0, 0), (500, 500, 0), 1e5, 1.5),
                Vehicle("b", (0, 500, 0), (500, 0, 0), 1e5, 1.0)]
    return Problem.build("scattered", vehicles, tasks)


def test_moves_as_in_fig5():
    route = [1, 2, 3, 4, 5, 6, 7]
    assert swap(route, 1, 5) == [1, 6, 3, 4, 5, 2, 7]
    assert insertion(route, 5, 1) == [1, 6, 2, 3, 4, 5, 7]  # task 6 moves before task 2
    assert insertion(route, 1, 5) == [1, 3, 4, 5, 6, 2, 7]
    assert reversion(route, 1, 5) == [1, 6, 5, 4, 3, 2, 7]
    assert route == [1, 2, 3, 4, 5, 6, 7]  # moves never modify their input


def test_move_deltas_are_exact(scattered):
    model = RouteModel(scattered)
    rng = np.random.default_rng(0)
    route = rng.permutation(scattered.n_tasks).tolist()
    seq = [model.start[0], *route, model.end[0]]
    before = model.length_m(0, route)
    for kind in (SWAP, INSERTION, REVERSION):
        for i in range(len(route)):
            for j in range(len(route)):
                if i == j:
                    continue
                after = model.length_m(0, MOVES[kind](route, i, j))
                assert move_delta_m(model.dist_rows, seq, kind, i, j) == pytest.approx(
                    after - before, abs=1e-9
                )


def test_ordering_keeps_every_task_and_never_lengthens(scattered):
    model = RouteModel(scattered)
    rng = np.random.default_rng(5)
    routes = [list(range(0, 12)), list(range(12, 25))]
    for _ in range(30):
        ordered = order(routes, rng, model=model)
        for v in range(2):
            assert sorted(ordered[v]) == sorted(routes[v])
            assert model.length_m(v, ordered[v]) <= model.length_m(v, routes[v]) + 1e-9
        routes = ordered
    # 30 passes of Algorithm 1 untangle a random order substantially
    start = model.length_m(0, list(range(0, 12)))
    assert model.length_m(0, routes[0]) < 0.8 * start


def test_ordering_is_seeded(scattered):
    model = RouteModel(scattered)
    route = list(range(25))
    a = order_route(route, np.random.default_rng(3), model=model, v=1, moves=200)
    b = order_route(route, np.random.default_rng(3), model=model, v=1, moves=200)
    assert a == b


def test_short_routes_are_left_alone(scattered):
    model = RouteModel(scattered)
    assert order_route([], np.random.default_rng(0), model=model, v=0) == []
    assert order_route([4], np.random.default_rng(0), model=model, v=0) == [4]
