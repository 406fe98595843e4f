"""A plan back on the globe: GeoJSON in longitude/latitude for QGIS, geojson.io, a chart plotter.

Routes are LineStrings through every waypoint the vehicle really follows (legs bend around
land and no-go polygons as `hfc_core.model.geometry.LandMap` routes them), with the depth as the
third coordinate (metres, negative down). Spots, stations and forbidden polygons come along
with the same ``role`` properties a reef file uses.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from cotsfleet.geo.frame import LocalFrame
from hfc_core.model.problem import Problem

DECIMALS = 7  # 1e-7 degree is about 1 cm


def _lonlat(frame: LocalFrame, xyz: ArrayLike) -> list[list[float]]:
    xyz = np.atleast_2d(np.asarray(xyz, dtype=float))
    lon, lat = frame.to_lonlat(xyz[:, 0], xyz[:, 1])
    return [[round(float(a), DECIMALS), round(float(b), DECIMALS), round(float(z), 2)]
            for a, b, z in zip(np.atleast_1d(lon), np.atleast_1d(lat), xyz[:, 2])]


def route_path(problem: Problem, v: int, route: Sequence[int]) -> np.ndarray:
    """``(m, 3)`` local waypoints of vehicle ``v`` on ``route`` (task indices), start to
    rendezvous, around land where the scenario has any."""
    nodes = [problem.start_node(v), *route, problem.end_node(v)]
    points = [problem.xyz[nodes[0]]]
    for a, b in zip(nodes[:-1], nodes[1:]):
        if problem.land is not None:
            _, hops = problem.land.shortest_path(problem.xyz[a], problem.xyz[b])
            points.extend(np.asarray(hops)[1:])
        else:
            points.append(problem.xyz[b])
    return np.array(points)


def _feature(geometry: dict[str, Any], **props: Any) -> dict[str, Any]:
    return {"type": "Feature", "properties": props, "geometry": geometry}


def plan_geojson(problem: Problem, routes: Sequence[Sequence[int]], frame: LocalFrame,
                 scenario: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """A FeatureCollection of the plan: one ``route`` LineString per vehicle, every ``cots``
    spot (with the vehicle that treats it and its place in the route, or null), the
    ``start``/``rendezvous`` stations and the ``land``/``no_go`` polygons."""
    features = []
    served: dict[int, tuple[str, int]] = {}
    for v, route in enumerate(routes):
        vid = problem.vehicles[v].id
        served.update({t: (vid, k + 1) for k, t in enumerate(route)})
        features.append(_feature(
            {"type": "LineString", "coordinates": _lonlat(frame, route_path(problem, v, route))},
            role="route", vehicle=vid, tasks=[problem.tasks[t].id for t in route],
            priority=round(problem.route_priority(route), 2),
            mission_time_s=round(problem.route_time_s(v, route), 1),
            battery_s=problem.vehicles[v].battery_s))
    for i, task in enumerate(problem.tasks):
        by, order = served.get(i, (None, None))
        features.append(_feature(
            {"type": "Point", "coordinates": _lonlat(frame, task.pos)[0]},
            role="cots", id=task.id, priority=task.priority, service_s=task.service_s,
            vehicle=by, order=order))
    for vehicle in problem.vehicles:
        for role in ("start", "rendezvous"):
            features.append(_feature(
                {"type": "Point", "coordinates": _lonlat(frame, getattr(vehicle, role))[0]},
                role=role, vehicle=vehicle.id))
    roles = list((scenario or {}).get("geo", {}).get("forbidden_roles", []))
    for k, poly in enumerate(problem.forbidden):
        ring = _lonlat(frame, np.column_stack([poly, np.zeros(len(poly))]))
        ring = [p[:2] for p in ring]
        features.append(_feature({"type": "Polygon", "coordinates": [ring + ring[:1]]},
                                 role=roles[k] if k < len(roles) else "no_go"))
    return {"type": "FeatureCollection", "name": problem.name, "features": features}
