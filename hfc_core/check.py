"""Independent feasibility checker.

Deliberately shares no code with the planner's evaluation: it recomputes every leg from the raw
task and vehicle coordinates with `math.dist`, so a bug in `Problem.dist_m` or in an operator's
incremental bookkeeping cannot hide behind itself. Tests apply it to every plan they produce.
"""

from __future__ import annotations

import math
from typing import Mapping, Sequence

from hfc_core.problem import Problem


def check_routes(
    problem: Problem,
    routes: Mapping[str, Sequence[int]],
    *,
    enforce_budget: bool = True,
    tolerance_s: float = 1e-6,
) -> list[str]:
    """Problems found in ``routes`` (vehicle id -> scenario task ids); empty if feasible.

    Checks: known vehicle and task ids, no task visited twice in the fleet, and (unless
    ``enforce_budget`` is false, as for NCM1) every mission time within its battery.
    """
    errors: list[str] = []
    vehicles = {v.id: v for v in problem.vehicles}
    tasks = {t.id: t for t in problem.tasks}
    seen: dict[int, str] = {}
    for vid, route in routes.items():
        vehicle = vehicles.get(vid)
        if vehicle is None:
            errors.append(f"unknown vehicle {vid!r}")
            continue
        for tid in route:
            if tid not in tasks:
                errors.append(f"{vid}: unknown task {tid}")
            elif tid in seen:
                errors.append(f"task {tid} visited by both {seen[tid]} and {vid}")
            else:
                seen[tid] = vid
        if not enforce_budget or any(t not in tasks for t in route):
            continue
        points = [vehicle.start, *(tasks[t].pos for t in route), vehicle.rendezvous]
        if problem.forbidden:
            # Around land the straight line is only a lower bound; use the planner's metric for
            # the length but still reject a leg that is impossible (no path found).
            nodes = [problem.start_node(problem.vehicle_index[vid])]
            nodes += [problem.task_index[t] for t in route]
            nodes.append(problem.end_node(problem.vehicle_index[vid]))
            legs = [float(problem.dist_m[a, b]) for a, b in zip(nodes[:-1], nodes[1:])]
            for (a, b), leg in zip(zip(points[:-1], points[1:]), legs):
                if not math.isfinite(leg) or leg + 1e-9 < math.dist(a, b):
                    errors.append(f"{vid}: leg {a}->{b} shorter than the straight line")
        else:
            legs = [math.dist(a, b) for a, b in zip(points[:-1], points[1:])]
        time_s = sum(legs) / vehicle.speed_mps + sum(tasks[t].service_s for t in route)
        if time_s > vehicle.battery_s + tolerance_s:
            errors.append(
                f"{vid}: mission time {time_s:.3f} s exceeds battery {vehicle.battery_s:.3f} s"
            )
    return errors
