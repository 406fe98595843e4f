"""Independent feasibility checker.

Deliberately shares no code with the planner's evaluation: it recomputes every leg from the raw
task and vehicle coordinates with `math.dist`, so a bug in `Problem.dist_m` or in an operator's
incremental bookkeeping cannot hide behind itself. What it shares is the rule itself
(`hfc_core.model.feasibility.fits`), so that checker and planner cannot disagree on what fits.
Tests apply it to every plan they produce.

With a current the checker flies each route as the vehicle would, from mission time 0, with
its own code for the water model of `hfc_core.model.travel` (ground speed along the track, the
gridded field's pieces and bilinear interpolation, the tide's 60 s steps, ``math.cos``): only
the scenario's field parameters are shared. A leg the current makes impossible is an error
with the reason.
"""

from __future__ import annotations

import math
from typing import Mapping, Sequence

from hfc_core.model.feasibility import fits
from hfc_core.model.problem import Problem


def check_routes(
    problem: Problem,
    routes: Mapping[str, Sequence[int]],
    *,
    enforce_budget: bool = True,
) -> list[str]:
    """Problems found in ``routes`` (vehicle id -> scenario task ids); empty if feasible.

    Checks: known vehicle and task ids, no task visited twice in the fleet, and (unless
    ``enforce_budget`` is false, as for NCM1) every mission time within its battery, by the
    planner's one rule (`hfc_core.model.feasibility.fits`: a time equal to the battery fits).
    With land, each leg is the waypoint path the vehicle would follow
    (`Problem.land.shortest_path`): it must join the leg's ends and enter no forbidden polygon,
    and its length is what counts.
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
        paths = []
        if problem.forbidden:
            legs = []
            for a, b in zip(points[:-1], points[1:]):
                leg, leg_errors, path = _land_leg(problem, a, b)
                legs.append(leg)
                paths.append(path)
                errors += [f"{vid}: {e}" for e in leg_errors]
        else:
            legs = [math.dist(a, b) for a, b in zip(points[:-1], points[1:])]
            paths = [[a, b] for a, b in zip(points[:-1], points[1:])]
        if problem.current is None:
            time_s = sum(legs) / vehicle.speed_mps + sum(tasks[t].service_s for t in route)
        else:
            services = [tasks[t].service_s for t in route] + [0.0]
            time_s, why = _flown(problem.current, paths, services, vehicle.speed_mps)
            if why:
                errors.append(f"{vid}: {why}")
                continue
        if not fits(time_s, vehicle.battery_s):
            errors.append(
                f"{vid}: mission time {time_s:.3f} s exceeds battery {vehicle.battery_s:.3f} s"
            )
    return errors


# --- land: the path of a leg must stay in the water ------------------------------------------
LAND_DEPTH_TOL_M = 1e-6  # grazing the coast is allowed; entering land deeper than this is not
Point = tuple[float, ...]


def _land_leg(problem: Problem, a: Point, b: Point) -> tuple[float, list[str], list[Point]]:
    """(length of the waypoint path from a to b, problems with it, the path)."""
    assert problem.land is not None
    try:
        _, waypoints = problem.land.shortest_path(a, b)
        path: list[Point] = list(waypoints)
    except ValueError as err:
        return math.inf, [f"leg {a}->{b}: {err}"], [a, b]
    errors = []
    if math.dist(path[0], a) > 1e-9 or math.dist(path[-1], b) > 1e-9:
        errors.append(f"leg {a}->{b}: its path runs from {path[0]} to {path[-1]}")
    for p, q in zip(path[:-1], path[1:]):
        for i, poly in enumerate(problem.forbidden):
            ring = [(float(x), float(y)) for x, y in poly]
            if _segment_enters(p[:2], q[:2], ring):
                errors.append(f"leg {a}->{b}: segment {p}->{q} crosses forbidden[{i}]")
    return sum((math.dist(p, q) for p, q in zip(path[:-1], path[1:])), 0.0), errors, path


# --- currents: each route flown through the water, from mission time 0 ---------------------
TIDE_STEP_S = 60.0  # the tide is constant over steps of this much mission time (the model)


class _Impossible(Exception):
    pass


def _flown(current: object, paths: list[list[Point]], services: list[float], speed: float
           ) -> tuple[float, str]:
    """(mission time, "" or why a leg cannot be flown): leg k along ``paths[k]``, then the
    ``services[k]`` of the spot it reaches."""
    t = 0.0
    for path, service in zip(paths, services):
        for p, q in zip(path[:-1], path[1:]):
            try:
                t += _segment(current, p, q, speed, t)
            except _Impossible as err:
                return math.inf, f"leg {tuple(p)}->{tuple(q)} at t={t:.0f} s: {err}"
        t += service
    return t, ""


def _segment(current: object, p: Point, q: Point, speed: float, t0: float) -> float:
    length = math.dist(p, q)
    if length == 0.0:
        return 0.0
    ux, uy = (q[0] - p[0]) / length, (q[1] - p[1]) / length
    kind = getattr(current, "kind")
    if kind == "uniform":
        cu, cv = getattr(current, "velocity_mps")
        return length / _ground(speed, cu, cv, ux, uy)
    if kind == "grid":
        cell = float(getattr(current, "cell_m"))
        n = max(1, math.ceil(max(abs(q[0] - p[0]), abs(q[1] - p[1])) / (0.125 * cell)))
        total = 0.0
        for k in range(n):
            f = (k + 0.5) / n
            cu, cv = _bilinear(current, p[0] + (q[0] - p[0]) * f, p[1] + (q[1] - p[1]) * f)
            total += (length / n) / _ground(speed, cu, cv, ux, uy)
        return total
    # tidal: walk the steps, the stream constant in each at its mid-step value
    vu, vv = getattr(current, "velocity_mps")
    period, phase = float(getattr(current, "period_s")), float(getattr(current, "phase_s"))
    step, t, left = math.floor(t0 / TIDE_STEP_S), t0, length
    while True:
        a = math.cos(2.0 * math.pi * ((step + 0.5) * TIDE_STEP_S - phase) / period)
        g = _ground(speed, vu * a, vv * a, ux, uy)
        end = (step + 1) * TIDE_STEP_S
        if g * (end - t) >= left:
            return t + left / g - t0
        left -= g * (end - t)
        t, step = end, step + 1


def _ground(speed: float, cu: float, cv: float, ux: float, uy: float) -> float:
    """Ground speed along the track, crabbing into the current; `_Impossible` if none."""
    along = cu * ux + cv * uy
    across2 = cu * cu + cv * cv - along * along
    if across2 > speed * speed:
        raise _Impossible(f"current ({cu:.2f}, {cv:.2f}) m/s, {math.sqrt(across2):.2f} m/s "
                          f"across the track, exceeds the vehicle's {speed:.2f} m/s")
    g = along + math.sqrt(speed * speed - across2)
    if g <= 0.0:
        raise _Impossible(f"current ({cu:.2f}, {cv:.2f}) m/s against the track: no headway "
                          f"at {speed:.2f} m/s")
    return g


def _bilinear(current: object, x: float, y: float) -> tuple[float, float]:
    u, v = getattr(current, "u"), getattr(current, "v")
    ny, nx = len(u), len(u[0])
    x0, y0 = getattr(current, "origin")
    cell = float(getattr(current, "cell_m"))
    fx = min(max((x - x0) / cell, 0.0), nx - 1.0)
    fy = min(max((y - y0) / cell, 0.0), ny - 1.0)
    i, j = min(int(fx), nx - 2), min(int(fy), ny - 2)
    ax, ay = fx - i, fy - j
    out = []
    for grid in (u, v):
        g00, g10 = float(grid[j][i]), float(grid[j][i + 1])
        g01, g11 = float(grid[j + 1][i]), float(grid[j + 1][i + 1])
        south, north = g00 + (g10 - g00) * ax, g01 + (g11 - g01) * ax
        out.append(south + (north - south) * ay)
    return out[0], out[1]


def _segment_enters(p: Point, q: Point, ring: list[tuple[float, float]]) -> bool:
    """Does segment p-q pass through the polygon's interior? Cut it wherever it meets the
    boundary; each piece is then wholly inside or outside, so test each piece's middle."""
    dx, dy = q[0] - p[0], q[1] - p[1]
    cuts = {0.0, 1.0}
    for (ax, ay), (bx, by) in zip(ring, ring[1:] + ring[:1]):
        ex, ey = bx - ax, by - ay
        denom = dx * ey - dy * ex
        wx, wy = ax - p[0], ay - p[1]
        if abs(denom) > 1e-15:
            t = (wx * ey - wy * ex) / denom
            s = (wx * dy - wy * dx) / denom
            if 0.0 <= t <= 1.0 and -1e-12 <= s <= 1.0 + 1e-12:
                cuts.add(t)
        else:  # parallel: the edge's ends may lie on the segment
            length2 = dx * dx + dy * dy
            for cx, cy in ((ax, ay), (bx, by)):
                if length2 > 0:
                    t = ((cx - p[0]) * dx + (cy - p[1]) * dy) / length2
                    if 0.0 < t < 1.0:
                        cuts.add(t)
    ordered = sorted(cuts)
    for t0, t1 in zip(ordered[:-1], ordered[1:]):
        mid = (p[0] + dx * (t0 + t1) / 2, p[1] + dy * (t0 + t1) / 2)
        if _inside(mid, ring) and _boundary_distance(mid, ring) > LAND_DEPTH_TOL_M:
            return True
    return False


def _inside(pt: tuple[float, float], ring: list[tuple[float, float]]) -> bool:
    x, y = pt
    inside = False
    for (ax, ay), (bx, by) in zip(ring, ring[1:] + ring[:1]):
        if (ay > y) != (by > y) and x < ax + (y - ay) * (bx - ax) / (by - ay):
            inside = not inside
    return inside


def _boundary_distance(pt: tuple[float, float], ring: list[tuple[float, float]]) -> float:
    best = math.inf
    for (ax, ay), (bx, by) in zip(ring, ring[1:] + ring[:1]):
        ex, ey = bx - ax, by - ay
        length2 = ex * ex + ey * ey
        along = ((pt[0] - ax) * ex + (pt[1] - ay) * ey) / length2 if length2 else 0.0
        t = max(0.0, min(1.0, along))
        best = min(best, math.dist(pt, (ax + t * ex, ay + t * ey)))
    return best
