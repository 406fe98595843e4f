import numpy as np
import pytest

from hfc_core.engines.operators.cooperation import cooperate, take_nearest
from hfc_core.model.cost import RouteModel
from hfc_core.model.problem import Problem, Task, Vehicle


@pytest.fixture
def line() -> Problem:
    """Spots every 10 m along y = 0; both vehicles shuttle from x = 0 to x = 100."""
    tasks = [Task(i, (10.0 * i, 0.0, 0.0), 10.0, 5.0) for i in range(1, 10)]
    vehicles = [Vehicle("idle", (0, 0, 0), (100, 0, 0), 140.0, 1.0),
                Vehicle("busy", (0, 0, 0), (100, 0, 0), 105.0, 1.0)]
    return Problem.build("line", vehicles, tasks)


def test_idle_vehicle_takes_nearest_abandoned_spots_while_they_fit(line):
    model = RouteModel(line)
    # idle: 100 s of travel and 40 s for injections; a spot on the way costs its 5 s only
    abandoned = np.ones(model.n, dtype=bool)
    abandoned[[0, 8]] = False
    taken = take_nearest([0], abandoned, model=model, v=0)
    # nearest to the last spot first, until the battery is used exactly: 100 s + 8 x 5 s
    assert taken == [0, 1, 2, 3, 4, 5, 6, 7]
    assert model.time_s(0, taken) <= model.battery_s[0]
    assert not abandoned[taken].any()


def test_cooperation_only_adds_abandoned_spots_that_fit(line):
    model = RouteModel(line)
    routes = [[0], [8]]
    out = cooperate(routes, np.random.default_rng(0), model=model)
    assert 0 in out[0] and out[1] == [8]  # busy has T_diff == 0: it takes nothing
    assert set(out[0]).isdisjoint(out[1])
    assert all(model.time_s(v, r) <= model.battery_s[v] for v, r in enumerate(out))
    assert sorted(out[0]) == list(range(8))  # 100 s + 8 x 5 s = 140 s: the battery, exactly


def test_no_abandoned_spots_no_change(line):
    model = RouteModel(line)
    routes = [[0, 1, 2], [3, 4, 5, 6, 7, 8]]
    assert cooperate(routes, np.random.default_rng(0), model=model) == routes
