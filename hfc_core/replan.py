"""`replan`: new routes for the live vehicles, from where they are, with what battery they have.

The agents call this mid-mission: after a vehicle is lost (survivors share its spots), or for
the online cooperation operator (one vehicle with spare battery inserts free spots into its own
route: call it with that vehicle alone and mark the others' spots ``cleared`` or ``held``).

Two doors onto one core: `replan_indexed` takes and returns indices of the `Problem` (vehicle
index, task indices), as the fleet agent holds them; `replan` takes and returns scenario ids
(vehicle names, task ids) for users, and turns them into indices at its edge only.

How the inputs become a `best` search (`hfc_core.engines.best.live`):
- each vehicle starts at its position (or, with ``locked`` spots, at the last of them: the
  locked chain is prepended unchanged and its time taken off the battery);
- spots ``cleared``, locked by a vehicle, or held by another live vehicle are off limits;
- travel from a position uses `Problem.land` when the scenario has land;
- stability: the current routes (minus what is now off limits, cut to fit the battery, topped
  up with free spots that fit) are the starting point, and they are returned unless the search
  beats them by more than ``stability`` times the mean priority. Within the search, treating a
  spot from another live vehicle's current route is worth that much less, so spots change
  vehicle only for a real gain. Reordering happens only when it shortens a route, which leaves
  a plan from `best` (already 2-opt/or-opt optimal) as it is.

With ``max_iterations`` and no time limit the result is a pure function of the inputs (the
order of ``cleared`` and ``held`` does not matter): agents on different machines agree.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Collection, Mapping, Sequence

import numpy as np

from hfc_core.engines.best.construct import construct
from hfc_core.engines.best.engine import SearchParams, search
from hfc_core.engines.best.live import LiveSetup
from hfc_core.model.errors import ScenarioError
from hfc_core.model.live import IndexedVehicle
from hfc_core.model.problem import Problem
from hfc_core.stop import Stop

DEFAULT_ITERATIONS = 60
DEFAULT_STABILITY = 0.1


@dataclass(frozen=True)
class LiveVehicle:
    id: str  # scenario vehicle id
    pos: tuple[float, float, float]  # where it is now
    battery_s: float  # battery time left
    speed_mps: float | None = None  # None = the scenario vehicle's speed
    route: tuple[int, ...] = ()  # its current planned route (scenario task ids), for stability
    locked: tuple[int, ...] = ()  # tasks it must keep at the head of its route, in order


def replan_indexed(
    problem: Problem,
    vehicles: Sequence[IndexedVehicle],
    *,
    cleared: Collection[int] = (),
    held: Mapping[int, int] = {},  # read only
    max_iterations: int | None = None,
    time_limit_s: float | None = None,
    seed: int = 0,
    stability: float = DEFAULT_STABILITY,
    now_s: float | None = None,
) -> dict[int, list[int]]:
    """Vehicle index -> new route (task indices; the rendezvous follows) for ``vehicles``, in
    their order. ``cleared``: task indices; ``held``: task index -> index of the vehicle
    holding it. The rules are `replan`'s."""
    if not stability >= 0:
        raise ValueError(f"stability must be >= 0, got {stability}")
    if max_iterations is None and time_limit_s is None:
        max_iterations = DEFAULT_ITERATIONS
    setup = LiveSetup(problem, vehicles, cleared, held, stability, now_s)
    inst = setup.instance()
    rng = np.random.default_rng(seed)
    stop = Stop(time_limit_s=time_limit_s, max_iterations=max_iterations)
    warm = setup.warm_start(inst, rng)
    tie = inst.tie_weight()
    start = warm
    if not any(v.route for v in vehicles):  # nothing to keep: build from scratch too
        scratch = construct(inst, rng)
        start = scratch if scratch.objective(tie) > warm.objective(tie) + 1e-12 else warm
    best, _ = search(start, rng, stop, SearchParams(restart=100))
    if best.objective(tie) <= warm.objective(tie) + setup.penalty:
        best = warm
    out = {}
    for v, live in enumerate(setup.vehicles):
        tail = best.routes[v] if setup.budget_s[v] > 0 else []
        out[live.index] = [*setup.locked[v], *tail]
    return out


def replan(
    problem: Problem,
    vehicles: Sequence[LiveVehicle],
    *,
    cleared: Collection[int] = (),
    held: Mapping[int, str] = {},  # read only
    max_iterations: int | None = None,
    time_limit_s: float | None = None,
    seed: int = 0,
    stability: float = DEFAULT_STABILITY,
    now_s: float | None = None,
) -> dict[str, list[int]]:
    """Vehicle id -> new route (scenario task ids; the rendezvous follows) for ``vehicles``.

    Vehicles not passed are gone: their spots are free unless cleared. A spot held by one of
    ``vehicles`` goes to that vehicle or to none; a spot held by a gone vehicle is free. No
    route exceeds its vehicle's ``battery_s`` from ``pos``. Locked spots that are cleared or
    held by another live vehicle are dropped. If even the locked spots and the way to the
    rendezvous do not fit the battery, that vehicle gets its locked spots only (it cannot do
    better). Without a budget, ``DEFAULT_ITERATIONS`` iterations are run.

    ``now_s``: the mission time the vehicles are at; it matters only in a tidal current, where
    routes are then timed as flown from now (`hfc_core.model.tide_clock`). Without it a tide is
    planned with the longest leg times over the whole mission: safe, but it leaves battery
    unused.
    """
    indexed = [IndexedVehicle(_vehicle_index(problem, v.id), v.pos, v.battery_s, v.speed_mps,
                              _task_indices(problem, v.route), _task_indices(problem, v.locked))
               for v in vehicles]
    live = {v.id for v in vehicles}  # a spot held by a gone vehicle is free: no need to look
    routes = replan_indexed(
        problem, indexed, cleared=_task_indices(problem, cleared),
        held={_task_index(problem, t): problem.vehicle_index[vid]
              for t, vid in held.items() if vid in live},
        max_iterations=max_iterations, time_limit_s=time_limit_s, seed=seed,
        stability=stability, now_s=now_s)
    return {problem.vehicles[v].id: [problem.tasks[u].id for u in route]
            for v, route in routes.items()}


def _vehicle_index(problem: Problem, vehicle_id: str) -> int:
    try:
        return problem.vehicle_index[vehicle_id]
    except (KeyError, TypeError):
        raise ScenarioError(f"unknown vehicle {vehicle_id!r}") from None


def _task_index(problem: Problem, task_id: int) -> int:
    try:
        return problem.task_index[task_id]
    except (KeyError, TypeError):
        raise ScenarioError(f"unknown task {task_id!r}") from None


def _task_indices(problem: Problem, task_ids: Collection[int]) -> tuple[int, ...]:
    return tuple(_task_index(problem, t) for t in task_ids)
