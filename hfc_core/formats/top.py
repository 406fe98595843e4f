"""Reader for Team Orienteering Problem instances in Chao's format (Chao, Golden, Wasil 1996).

Mapping to our model: speed 1, service 0, every vehicle's budget ``tmax``; the first point is
the start, the last the rendezvous; a task's id is the point's index in the file.
"""

from __future__ import annotations

from hfc_core.model.errors import ScenarioError
from hfc_core.model.problem import Problem, Task, Vehicle


def parse_top(text: str, name: str = "top") -> Problem:
    """Parse the text of a TOP instance file (raises `ScenarioError` on malformed input)."""
    lines = [ln.split() for ln in text.splitlines() if ln.strip()]
    header: dict[str, float] = {}
    for key in ("n", "m", "tmax"):
        if not lines or lines[0][0] != key or len(lines[0]) != 2:
            raise ScenarioError(f"{name}: expected a '{key} <value>' header line")
        try:
            header[key] = float(lines.pop(0)[1])
        except ValueError:
            raise ScenarioError(f"{name}: header {key!r} is not a number") from None
    n, m, tmax = int(header["n"]), int(header["m"]), header["tmax"]
    if n < 2 or m < 1 or n != header["n"] or m != header["m"]:
        raise ScenarioError(f"{name}: need n >= 2 points and m >= 1 paths")
    if len(lines) != n:
        raise ScenarioError(f"{name}: header says {n} points, file has {len(lines)}")
    points = []
    for i, row in enumerate(lines):
        if len(row) != 3:
            raise ScenarioError(f"{name}: point {i} needs 'x y score', got {' '.join(row)!r}")
        try:
            points.append(tuple(float(c) for c in row))
        except ValueError:
            raise ScenarioError(f"{name}: point {i} has a non-numeric field") from None
    start, end = points[0], points[-1]
    vehicles = [
        Vehicle(
            id=f"v{j + 1}",
            start=(start[0], start[1], 0.0),
            rendezvous=(end[0], end[1], 0.0),
            battery_s=tmax,
            speed_mps=1.0,
        )
        for j in range(m)
    ]
    tasks = [
        Task(id=i, pos=(x, y, 0.0), priority=score, service_s=0.0)
        for i, (x, y, score) in enumerate(points)
        if 0 < i < n - 1
    ]
    return Problem.build(name, vehicles, tasks)
