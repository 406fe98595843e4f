"""Scenario documents <-> `Problem` (pure: parses already-loaded data, never touches files).

JSON shape (extra fields allowed and ignored)::

    {"name": str, "speed_mps": float,
     "vehicles": [{"id": str, "start": [x,y,z], "rendezvous": [x,y,z],
                   "battery_s": float, "speed_mps"?: float}],
     "tasks": [{"id": int, "pos": [x,y,z], "priority": float, "service_s": float}],
     "forbidden"?: [[[x,y], ...], ...],
     "current"?: {"kind": "uniform" | "tidal" | "grid", ...}}

Metres and seconds; z is negative down. ``current``: see `hfc_core.model.current` (absent or null:
still water, the paper's Assumption 1).
"""

from __future__ import annotations

from typing import Any, Mapping

from hfc_core.model.current import current_from_dict
from hfc_core.model.errors import ScenarioError, finite
from hfc_core.model.problem import Problem, Task, Vehicle


def _field(doc: Mapping[str, Any], key: str, where: str) -> Any:
    if not isinstance(doc, Mapping):
        raise ScenarioError(f"{where}: expected an object, got {type(doc).__name__}")
    if key not in doc:
        raise ScenarioError(f"{where}: missing field {key!r}")
    return doc[key]


def _list(value: Any, where: str) -> list:
    if not isinstance(value, list):
        raise ScenarioError(f"{where}: expected a list, got {type(value).__name__}")
    return value


def problem_from_dict(doc: Mapping[str, Any]) -> Problem:
    """Validate a scenario document and build the `Problem` (raises `ScenarioError`)."""
    name = _field(doc, "name", "scenario")
    if not isinstance(name, str):
        raise ScenarioError(f"scenario: name must be a string, got {name!r}")
    fleet_speed = finite(_field(doc, "speed_mps", "scenario"), "scenario: speed_mps")
    if fleet_speed <= 0:
        raise ScenarioError(f"scenario: speed_mps must be positive, got {fleet_speed}")
    vehicles = []
    for i, v in enumerate(_list(_field(doc, "vehicles", "scenario"), "scenario: vehicles")):
        where = f"vehicles[{i}]"
        vehicles.append(
            Vehicle(
                id=_field(v, "id", where),
                start=_field(v, "start", where),
                rendezvous=_field(v, "rendezvous", where),
                battery_s=_field(v, "battery_s", where),
                speed_mps=v.get("speed_mps", fleet_speed),
            )
        )
    tasks = []
    for i, t in enumerate(_list(_field(doc, "tasks", "scenario"), "scenario: tasks")):
        where = f"tasks[{i}]"
        tasks.append(
            Task(
                id=_field(t, "id", where),
                pos=_field(t, "pos", where),
                priority=_field(t, "priority", where),
                service_s=_field(t, "service_s", where),
            )
        )
    forbidden = _list(doc.get("forbidden", []), "scenario: forbidden")
    current = doc.get("current")
    return Problem.build(name, vehicles, tasks, forbidden,
                         current=None if current is None else current_from_dict(current))


def problem_to_dict(problem: Problem) -> dict[str, Any]:
    """The scenario document of ``problem`` (round-trips through `problem_from_dict`)."""
    speeds = {v.speed_mps for v in problem.vehicles}
    doc: dict[str, Any] = {
        "name": problem.name,
        "speed_mps": problem.vehicles[0].speed_mps if len(speeds) == 1 else min(speeds),
        "vehicles": [
            {
                "id": v.id,
                "start": list(v.start),
                "rendezvous": list(v.rendezvous),
                "battery_s": v.battery_s,
                "speed_mps": v.speed_mps,
            }
            for v in problem.vehicles
        ],
        "tasks": [
            {"id": t.id, "pos": list(t.pos), "priority": t.priority, "service_s": t.service_s}
            for t in problem.tasks
        ],
    }
    if problem.forbidden:
        doc["forbidden"] = [poly.tolist() for poly in problem.forbidden]
    if problem.current is not None:
        doc["current"] = problem.current.to_dict()
    return doc
