"""`ScenarioError`, and the two checks every part of a scenario document goes through.

Everything that reads a scenario (vehicles, tasks, the current, the hidden reef, the COTS map)
raises the one error type, naming the offending field, so the command line can print it as a
single line. The checks live here, below every model module, so that the problem, the current
and the travel model can all use them without importing each other.
"""

from __future__ import annotations

import math

Point3 = tuple[float, float, float]


class ScenarioError(ValueError):
    """A scenario that cannot be planned: the message names the offending field."""


def finite(value: float, where: str) -> float:
    """``value`` as a finite float, or `ScenarioError` naming ``where``."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ScenarioError(f"{where}: expected a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ScenarioError(f"{where}: must be finite, got {value!r}")
    return number


def point(value: object, where: str) -> Point3:
    """``[x, y]`` or ``[x, y, z]`` (metres) as a 3-D point (z = 0 if absent)."""
    if not isinstance(value, (list, tuple)) or len(value) not in (2, 3):
        raise ScenarioError(f"{where}: expected [x, y, z] in metres, got {value!r}")
    coords = [finite(c, f"{where}[{i}]") for i, c in enumerate(value)]
    if len(coords) == 2:
        coords.append(0.0)
    return (coords[0], coords[1], coords[2])
