"""Shared fixtures.

Every plan a test produces through `hfc_core.solve.solve` is checked by the independent
feasibility checker (`hfc_core.model.check`): the autouse fixture wraps the engine lookup, so no
test can forget to check, whatever it imports. Plans from other entry points (the replanner) use the
`assert_feasible` fixture explicitly.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Mapping, Sequence

import pytest

from hfc_core.model.check import check_routes
from hfc_core.model.problem import Problem

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
TOP_DIR = REPO / "benchmarks" / "top" / "instances"


@pytest.fixture
def top_dir() -> Path:
    if not TOP_DIR.is_dir():
        pytest.skip(f"shared TOP instances not found at {TOP_DIR}")
    return TOP_DIR


def _assert_feasible(
    problem: Problem, routes: Mapping[str, Sequence[int]], enforce_budget: bool = True
) -> None:
    errors = check_routes(problem, routes, enforce_budget=enforce_budget)
    assert not errors, f"infeasible plan: {errors}"


@pytest.fixture
def assert_feasible() -> Callable[..., None]:
    """``assert_feasible(problem, {vehicle_id: [task ids]}, enforce_budget=True)``."""
    return _assert_feasible


@pytest.fixture(autouse=True)
def _check_every_solved_plan(monkeypatch: pytest.MonkeyPatch) -> None:
    import hfc_core.solve as solve_mod

    original = solve_mod.engine

    def checked_engine(mode: str):
        run = original(mode)

        def checked(problem, stop, rng, **params):
            result = run(problem, stop, rng, **params)
            assert len(result.plan.routes) == problem.n_vehicles, "one route per vehicle"
            routes = {
                problem.vehicles[v].id: [problem.tasks[t].id for t in route]
                for v, route in enumerate(result.plan.routes)
            }
            _assert_feasible(problem, routes, mode not in solve_mod.BUDGET_FREE_MODES)
            return result

        return checked

    monkeypatch.setattr(solve_mod, "engine", checked_engine)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The longest files first: a file with a ``slow`` test, then one with an ``integration``
    test, then the rest, each group in its own order (a stable sort on a per-file key keeps a
    file's tests together and in order). `make test` runs two workers a file at a time with
    ``--no-loadscope-reorder``, so they take files in this order; xdist's own order is by
    test count, which sent the 6-test, 7-minute crash file out among the last."""
    rank: dict[Path, int] = {}
    for item in items:
        weight = 0 if item.get_closest_marker("slow") else \
            1 if item.get_closest_marker("integration") else 2
        rank[item.path] = min(rank.get(item.path, 2), weight)
    items.sort(key=lambda item: rank[item.path])
