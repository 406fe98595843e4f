"""The camera a live helm adapter consults, and the text form of a detection on board.

In emulation the camera is the simulated reef's (what the vehicle sees at its *true*
position): the adapter is given an object with two calls,

- ``sweep(pos) -> [(pos, priority, service_s), ...]``: the aggregations seen along the track
  since the last call, the vehicle now at true position ``pos`` (scenario frame);
- ``inspect(task, pos) -> (present, priority, service_s)``: what hovering at spot ``task``
  shows: a predicted spot's aggregation as the truth has it, a find's (a task the map does
  not name) what lies under the camera at true position ``pos`` (nothing without one).

`reef_sim.camera.ReefCamera` has that shape. On board there is no
camera object: the vehicle's detector posts detections as text (a MOOS variable, a ROS 2
``std_msgs/String``), one per post, as comma-separated ``key=value`` pairs
(`parse_detection`, `format_detection`):

- a sighting: ``kind=sighting,x=12.5,y=-3,z=-8.2,priority=55,service_s=70`` (the helm's local
  frame, the position the vehicle's navigation gives the aggregation);
- a look's result: ``kind=look,task=17,present=true,priority=55,service_s=70``
  (``present=false`` with nothing else: nothing there).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Protocol

from fleet_bus.vehicle_port import NavFix, Sighted
from reef_sim.camera import SeenSpot

Point3 = tuple[float, float, float]
MAX_DETECTION_CHARS = 512  # one detection is a short line; longer text is not one


class Camera(Protocol):
    def sweep(self, pos: Point3) -> Iterable[SeenSpot]: ...

    def inspect(self, task: int, pos: Point3 | None = None) -> tuple[bool, float, float]: ...


class DetectionError(ValueError):
    """Text that is not a detection."""


@dataclass(frozen=True)
class Sighting:
    """An aggregation the detector saw along the track, at ``pos`` (the helm's local frame)."""

    pos: Point3
    priority: float
    service_s: float


@dataclass(frozen=True)
class LookResult:
    """What a look at predicted spot ``task`` showed."""

    task: int
    present: bool
    priority: float
    service_s: float


Detection = Sighting | LookResult


def _number(fields: dict[str, str], key: str, default: float | None = None) -> float:
    raw = fields.get(key)
    if raw is None:
        if default is None:
            raise DetectionError(f"missing {key}")
        return default
    try:
        value = float(raw)
    except ValueError:
        raise DetectionError(f"{key}={raw!r} is not a number") from None
    if not math.isfinite(value):
        raise DetectionError(f"{key} must be finite")
    return value


def parse_detection(text: str) -> Detection:
    """A detection, checked: a `Sighting` (``kind=sighting``) or a `LookResult`
    (``kind=look``)."""
    if len(text) > MAX_DETECTION_CHARS:
        raise DetectionError(f"detection longer than {MAX_DETECTION_CHARS} characters")
    fields: dict[str, str] = {}
    for part in text.split(","):
        key, sep, value = part.partition("=")
        if not sep or not key.strip():
            raise DetectionError(f"{part!r} is not key=value")
        fields[key.strip().lower()] = value.strip()
    kind = fields.get("kind", "")
    if kind == "sighting":
        priority, service = _number(fields, "priority"), _number(fields, "service_s")
        if priority < 0 or service < 0:
            raise DetectionError("priority and service_s must be >= 0")
        pos = (_number(fields, "x"), _number(fields, "y"), _number(fields, "z", 0.0))
        return Sighting(pos, priority, service)
    if kind == "look":
        task = _number(fields, "task")
        if task != int(task) or task < 0:
            raise DetectionError(f"task must be a non-negative integer, got {task}")
        present = fields.get("present", "").lower()
        if present not in ("true", "false"):
            raise DetectionError("present must be true or false")
        priority = _number(fields, "priority", 0.0)
        service = _number(fields, "service_s", 0.0)
        if priority < 0 or service < 0:
            raise DetectionError("priority and service_s must be >= 0")
        return LookResult(int(task), present == "true", priority, service)
    raise DetectionError(f"unknown kind {kind!r} (sighting | look)")


def format_detection(kind: str, **fields: object) -> str:
    """The text of a detection (`parse_detection` reads it back)."""
    parts = [f"kind={kind}"]
    for key, value in fields.items():
        if isinstance(value, bool):
            value = "true" if value else "false"
        elif isinstance(value, float):
            value = repr(round(value, 3))
        parts.append(f"{key}={value}")
    return ",".join(parts)


def sightings(camera: Camera, fix: NavFix, true: Point3) -> list[Sighted]:
    """What ``camera`` sees from the vehicle's true pose ``true``, each placed where the
    vehicle believes it is (``fix``) plus what the camera measured from it: in the vehicle's
    own navigation frame, as a real vehicle would report it."""
    out = []
    for spot in camera.sweep(true):
        p = spot.pos
        seen = (fix.pos[0] + (p[0] - true[0]), fix.pos[1] + (p[1] - true[1]),
                fix.pos[2] + (p[2] - true[2]))
        out.append(Sighted(fix.t_s, seen, float(spot.priority), float(spot.service_s)))
    return out
