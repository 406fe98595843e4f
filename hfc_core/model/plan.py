"""A fleet plan (one route of task indices per vehicle) and its per-vehicle figures (eq. 12)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

from hfc_core.model.feasibility import fits
from hfc_core.model.problem import Problem


@dataclass(frozen=True)
class Plan:
    """``routes[v]`` is the visiting order of task indices for ``problem.vehicles[v]``."""

    routes: tuple[tuple[int, ...], ...]

    @staticmethod
    def of(routes: Sequence[Sequence[int]]) -> "Plan":
        return Plan(tuple(tuple(int(t) for t in r) for r in routes))

    def assigned(self) -> set[int]:
        return {t for r in self.routes for t in r}


@dataclass(frozen=True)
class VehicleFigures:
    id: str
    tasks: int
    priority: float
    mission_time_s: float
    t_diff_s: float  # eq. 12: battery minus mission time (negative = overdue)
    violation_s: float  # max(0, mission time - battery)


def vehicle_figures(problem: Problem, plan: Plan) -> list[VehicleFigures]:
    out = []
    for v, route in enumerate(plan.routes):
        time_s = problem.route_time_s(v, route)
        battery = problem.vehicles[v].battery_s
        out.append(
            VehicleFigures(
                id=problem.vehicles[v].id,
                tasks=len(route),
                priority=problem.route_priority(route),
                mission_time_s=time_s,
                t_diff_s=battery - time_s,
                violation_s=max(0.0, time_s - battery),
            )
        )
    return out


def plan_to_dict(problem: Problem, plan: Plan) -> dict[str, Any]:
    """The JSON shape `cotsfleet plan --json` writes (scenario task ids, not indices)."""
    figs = vehicle_figures(problem, plan)
    return {
        "vehicles": [
            {
                "id": f.id,
                "route": [problem.tasks[t].id for t in route],
                "mission_time_s": f.mission_time_s,
                "battery_s": problem.vehicles[v].battery_s,
                "t_diff_s": f.t_diff_s,
                "violation_s": f.violation_s,
                "priority": f.priority,
            }
            for v, (f, route) in enumerate(zip(figs, plan.routes))
        ],
        "tasks_completed": sum(f.tasks for f in figs),
        "tasks_total": problem.n_tasks,
        "priority_collected": sum(f.priority for f in figs),
        "priority_total": float(problem.priority.sum()),
        "feasible": all(fits(f.mission_time_s, problem.vehicles[v].battery_s)
                        for v, f in enumerate(figs)),
    }
