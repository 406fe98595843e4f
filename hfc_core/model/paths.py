"""How a leg runs on the ground: straight in open water, the waypoint path around land.

The planner's land metric (`hfc_core.geometry.LandMap`) gives every leg's length; a vehicle
needs the waypoints too. `path_function(problem)` returns the one function the agent (to
command its vehicle and time its route) and the simulated world (to replay a plan) both use,
so that what a vehicle flies is what its planner measured.
"""

from __future__ import annotations

import math
from typing import Callable, Iterable

from hfc_core.model.problem import Problem

Point3 = tuple[float, float, float]
# (from, to) -> (length_m, waypoints after ``from`` ending at ``to``)
PathFn = Callable[[Point3, Point3], tuple[float, list[Point3]]]


def as_point3(p: Iterable[float]) -> Point3:
    """Three plain floats (from a numpy row, a list, a generator)."""
    x, y, z = (float(c) for c in p)
    return (x, y, z)


def straight_path(p: Point3, q: Point3) -> tuple[float, list[Point3]]:
    return math.dist(p, q), [q]


def path_function(problem: Problem) -> PathFn:
    """Straight legs in open water; shortest waypoint paths around land otherwise."""
    land = problem.land
    if land is None:
        return straight_path

    def around_land(p: Point3, q: Point3) -> tuple[float, list[Point3]]:
        length, waypoints = land.shortest_path(p, q)
        points: list[Point3] = []
        for w in waypoints:  # 2-D corners keep the leg's depth
            x, y, *z = (float(c) for c in w)
            points.append((x, y, z[0] if z else q[2]))
        if not points or math.dist(points[-1], q) > 1e-6:
            points.append(q)
        if math.dist(points[0], p) <= 1e-6 and len(points) > 1:
            points = points[1:]
        return float(length), points

    return around_land
