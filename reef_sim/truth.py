"""The hidden reef: what is really at sea, as opposed to the map the planner is given.

A scenario's optional ``truth`` section says which predicted spots (``tasks``) really hold COTS,
with what real priority and injection time, and which aggregations the map missed. It belongs
to the simulated world, like ``fleet/truth`` positions: the planner never reads it; agents
learn it only through their simulated camera (``detect_radius_m``, ``p_detect``) and by
looking at a predicted spot (``inspect_s``). JSON shape::

    "truth": {"detect_radius_m": 25.0, "p_detect": 0.9, "inspect_s": 20.0,
              "spots": [{"pos": [x, y, z], "priority": 57.0, "service_s": 74.2, "task": 12},
                        {"pos": [x, y, z], "priority": 31.0, "service_s": 66.0, "task": null}]}

A truth spot is named by its index in ``spots``. Its ``task`` is the **index in ``tasks``** of
the predicted spot it is (the contract `cotsfleet scenario --from-geojson` and the example reef
already write), or null / absent for an aggregation the map missed. A predicted task that no
truth spot names is empty. Without a ``truth`` section the map is exact (`exact_reef`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from hfc_core.model.errors import Point3, ScenarioError, point
from hfc_core.model.problem import Problem, Task

DEFAULT_DETECT_RADIUS_M = 25.0
DEFAULT_P_DETECT = 0.9
DEFAULT_INSPECT_S = 20.0


def _number(value: Any, where: str) -> float:
    """A finite float; JSON booleans are not numbers."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioError(f"{where}: expected a number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise ScenarioError(f"{where}: must be finite, got {value!r}")
    return number


def _non_negative(value: Any, where: str) -> float:
    number = _number(value, where)
    if number < 0:
        raise ScenarioError(f"{where}: must be >= 0, got {value!r}")
    return number


def _probability(value: Any, where: str) -> float:
    number = _number(value, where)
    if not 0.0 <= number <= 1.0:
        raise ScenarioError(f"{where} must be in 0..1, got {value!r}")
    return number


@dataclass(frozen=True)
class TruthSpot:
    """One real COTS aggregation: where, how much it matters, how long to inject it, and the
    index in ``problem.tasks`` of the predicted spot it is (None: the map missed it)."""

    pos: Point3
    priority: float
    service_s: float
    task: int | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "pos", point(self.pos, "truth spot: pos"))
        object.__setattr__(self, "priority", _non_negative(self.priority, "truth spot: priority"))
        object.__setattr__(self, "service_s",
                           _non_negative(self.service_s, "truth spot: service_s"))
        if self.task is not None and (isinstance(self.task, bool)
                                      or not isinstance(self.task, int) or self.task < 0):
            raise ScenarioError(f"truth spot: task must be a task index >= 0 or None, "
                                f"got {self.task!r}")


@dataclass(frozen=True)
class Reef:
    """The real reef and the camera that sees it: ``detect_radius_m`` its reach, ``p_detect``
    the chance one pass within reach sees a spot, ``inspect_s`` the time spent at a predicted
    spot to see what is there. What the sensor does with them is the agent's business."""

    detect_radius_m: float = DEFAULT_DETECT_RADIUS_M
    p_detect: float = DEFAULT_P_DETECT
    inspect_s: float = DEFAULT_INSPECT_S
    spots: tuple[TruthSpot, ...] = ()
    _by_task: dict[int, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "detect_radius_m",
                           _non_negative(self.detect_radius_m, "truth.detect_radius_m"))
        object.__setattr__(self, "p_detect", _probability(self.p_detect, "truth.p_detect"))
        object.__setattr__(self, "inspect_s", _non_negative(self.inspect_s, "truth.inspect_s"))
        object.__setattr__(self, "spots", tuple(self.spots))
        by_task: dict[int, int] = {}
        for i, spot in enumerate(self.spots):
            if spot.task is None:
                continue
            if spot.task in by_task:
                raise ScenarioError(f"truth.spots[{i}].task: task {spot.task} is already "
                                    f"named by truth.spots[{by_task[spot.task]}]")
            by_task[spot.task] = i
        object.__setattr__(self, "_by_task", by_task)

    def of_task(self, index: int) -> int | None:
        """The truth spot (its index in ``spots``) of predicted task ``index``; None: empty."""
        return self._by_task.get(index)

    def unmapped(self) -> list[int]:
        """Truth spots the map missed (no predicted task), in order."""
        return [i for i, s in enumerate(self.spots) if s.task is None]

    def empty(self, n_tasks: int) -> list[int]:
        """Predicted tasks (indices ``0..n_tasks-1``) that hold nothing."""
        return [t for t in range(n_tasks) if t not in self._by_task]

    def total_priority(self) -> float:
        """Everything there is to collect on the real reef."""
        return float(sum(s.priority for s in self.spots))

    def to_dict(self) -> dict[str, Any]:
        """The scenario's ``truth`` section (`reef_from_doc` reads it back)."""
        return {"detect_radius_m": self.detect_radius_m, "p_detect": self.p_detect,
                "inspect_s": self.inspect_s,
                "spots": [{"pos": list(s.pos), "priority": s.priority, "service_s": s.service_s,
                           "task": s.task} for s in self.spots]}


def exact_reef(problem: Problem, detect_radius_m: float = DEFAULT_DETECT_RADIUS_M,
               p_detect: float = DEFAULT_P_DETECT, inspect_s: float = 0.0) -> Reef:
    """What a scenario without ``truth`` means: every predicted task holds exactly its
    predicted COTS and nothing else is out there. ``inspect_s`` defaults to 0: with an exact
    map there is nothing to learn by looking, so a mission behaves as it always has."""
    return Reef(detect_radius_m, p_detect, inspect_s,
                tuple(TruthSpot(t.pos, t.priority, t.service_s, i)
                      for i, t in enumerate(problem.tasks)))


def _task_index(value: Any, where: str, problem: Problem) -> int | None:
    if value is None:
        return None
    if isinstance(value, float) and value.is_integer():  # JSON Schema's integers include 12.0
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int):
        raise ScenarioError(f"{where}: expected the index of a task or null, got {value!r}")
    if not 0 <= value < problem.n_tasks:
        raise ScenarioError(f"{where}: no task {value} in the scenario (task is an index in "
                            f"tasks: 0..{problem.n_tasks - 1})")
    return value


def reef_from_doc(doc: Mapping[str, Any], problem: Problem) -> Reef | None:
    """The scenario's hidden reef, or None without a ``truth`` section (the map is exact:
    see `exact_reef`). Raises `ScenarioError` with one line naming the field."""
    if not isinstance(doc, Mapping) or "truth" not in doc:
        return None
    raw = doc["truth"]
    if not isinstance(raw, Mapping):
        raise ScenarioError(f"truth: expected an object, got {type(raw).__name__}")
    knobs = {name: raw.get(name, default) for name, default in (
        ("detect_radius_m", DEFAULT_DETECT_RADIUS_M), ("p_detect", DEFAULT_P_DETECT),
        ("inspect_s", DEFAULT_INSPECT_S))}
    knobs["detect_radius_m"] = _non_negative(knobs["detect_radius_m"], "truth.detect_radius_m")
    knobs["p_detect"] = _probability(knobs["p_detect"], "truth.p_detect")
    knobs["inspect_s"] = _non_negative(knobs["inspect_s"], "truth.inspect_s")
    if "spots" not in raw:
        raise ScenarioError("truth: missing field 'spots'")
    if not isinstance(raw["spots"], list):
        raise ScenarioError(f"truth.spots: expected a list, got {type(raw['spots']).__name__}")
    spots: list[TruthSpot] = []
    named_by: dict[int, int] = {}
    for i, s in enumerate(raw["spots"]):
        where = f"truth.spots[{i}]"
        if not isinstance(s, Mapping):
            raise ScenarioError(f"{where}: expected an object, got {type(s).__name__}")
        for key in ("pos", "priority", "service_s"):
            if key not in s:
                raise ScenarioError(f"{where}: missing field {key!r}")
        task = _task_index(s.get("task"), f"{where}.task", problem)
        if task is not None and task in named_by:
            raise ScenarioError(f"{where}.task: task {task} is already named by "
                                f"truth.spots[{named_by[task]}]")
        if task is not None:
            named_by[task] = i
        spots.append(TruthSpot(point(s["pos"], f"{where}.pos"),
                               _non_negative(s["priority"], f"{where}.priority"),
                               _non_negative(s["service_s"], f"{where}.service_s"), task))
    if problem.land is not None and spots:
        # a spot on land could be seen but never injected: the world would be wrong
        wet = ~problem.land.inside(np.array([s.pos for s in spots], dtype=float))
        if not wet.all():
            i = int(np.flatnonzero(~wet)[0])
            raise ScenarioError(f"truth.spots[{i}].pos: {list(spots[i].pos)} is on land "
                                "(forbidden)")
    return Reef(spots=tuple(spots), **knobs)


def truth_problem(problem: Problem, reef: Reef) -> Problem:
    """The clairvoyant's problem: every truth spot a task with its real priority and injection
    time (task id = the truth spot's index), the same vehicles, land and current. Distances
    are recomputed from geometry, so a problem built from an explicit matrix (a TOP instance)
    has none to give."""
    tasks = [Task(i, s.pos, s.priority, s.service_s) for i, s in enumerate(reef.spots)]
    return Problem.build(f"{problem.name}-truth", problem.vehicles, tasks,
                         [poly.tolist() for poly in problem.forbidden], current=problem.current)
