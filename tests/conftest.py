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
# Unmarked test modules that start processes on a clock or run in real time: they join the
# process-starting tests' worker (`pytest_collection_modifyitems`).
PACED_MODULES = frozenset({"test_subscriber", "test_viewer", "test_process", "test_onboard",
                           "test_sweep_processes", "test_sweep_dask"})


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Under `make test`'s two workers (pytest-xdist, ``--dist loadgroup``) every test that
    starts real processes runs in one worker, one at a time: two warp-paced missions at once
    on two cores would each measure the other's load. In-process tests spread over both."""
    for item in items:
        if item.get_closest_marker("integration") is not None or \
                item.path.stem in PACED_MODULES:
            item.add_marker(pytest.mark.xdist_group("processes"))


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
