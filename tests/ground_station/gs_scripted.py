"""A scripted mini mission as real bus payloads (the real encoders), for in-process tests.

Vehicles fly straight legs at 1 m/s through their routes and inject each spot for its service
time; one vehicle aborts, a peer declares it lost and takes its remaining spots over; every
30 s each vehicle broadcasts and the link outcome is published like the relay does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from fleet_bus import keys as bus
from fleet_bus.link import LinkRecord
from fleet_bus.mission import Mission
from fleet_bus.telemetry import Event, Status, Truth


@dataclass
class _Auv:
    vid: str
    xy: tuple[float, float]
    rendezvous: tuple[float, float]
    route: list[int]
    battery_s: float
    treated: list[int] = field(default_factory=list)
    claims: list[int] = field(default_factory=list)
    state: str = "transit"
    yaw_deg: float = 0.0
    busy_until: float = 0.0
    priority: float = 0.0
    distance_m: float = 0.0


def scripted_mission(doc: dict, routes: dict[str, list[int]], end_s: float,
                     abort: tuple[str, float] | None = None, taker: str | None = None,
                     drop_every: int = 3, dt_s: float = 2.0) -> list[tuple[str, bytes]]:
    """``(key, payload)`` in publication order. Every ``drop_every``-th message is dropped
    ("collision"); with ``abort=(vid, t)``, ``taker`` declares it lost and takes over."""
    tasks = {t["id"]: t for t in doc["tasks"]}
    auvs = {v["id"]: _Auv(v["id"], tuple(v["start"][:2]), tuple(v["rendezvous"][:2]),
                          list(routes.get(v["id"], [])), float(v["battery_s"]))
            for v in doc["vehicles"]}
    out: list[tuple[str, bytes]] = []
    n_msgs = 0
    t = 0.0
    while t <= end_s:
        for a in auvs.values():
            if a.state in ("aborted", "home"):
                continue
            if abort and a.vid == abort[0] and t >= abort[1]:
                a.state = "aborted"
                abort_event = Event(t, a.vid, "abort", detail="fault")
                out.append((bus.event_key(a.vid), abort_event.encode()))
                if taker:
                    lost = Event(t + 1, taker, "lost", peer=a.vid)
                    out.append((bus.event_key(taker), lost.encode()))
                    auvs[taker].route += a.route
                    auvs[taker].claims += a.route
                    out.append((bus.event_key(taker), Event(t + 1, taker, "takeover", list(a.route),
                                                            peer=a.vid).encode()))
                continue
            _step(a, tasks, t, dt_s, out)
        for a in auvs.values():
            out.append((bus.truth_key(a.vid), Truth(t, (*a.xy, -2.0), a.yaw_deg, 0.0,
                                                        a.state).encode()))
        if int(t) % 10 == 0:
            for a in auvs.values():
                left = a.battery_s - t
                out.append((bus.status_key(a.vid), Status(
                    t, a.vid, a.state, (*a.xy, -2.0), left, left - _route_time(a, tasks),
                    list(a.route), list(a.treated),
                    len({x for b in auvs.values() for x in b.treated}),
                    a.priority, a.distance_m, claims=list(a.claims)).encode()))
        if int(t) % 30 == 0:
            for a in auvs.values():
                if a.state == "aborted":
                    continue
                for b in auvs.values():
                    if b is a:
                        continue
                    n_msgs += 1
                    ok = n_msgs % drop_every != 0
                    out.append((bus.link_event_key(a.vid, b.vid), LinkRecord(
                        a.vid, b.vid, t, t + 0.5, 24, ok, None if ok else "collision",
                        snr_db=25.0 + 10.0 * (n_msgs % 3)).encode()))
        t += dt_s
    return out


def _route_time(a: _Auv, tasks: dict) -> float:
    pts = [a.xy] + [tuple(tasks[i]["pos"][:2]) for i in a.route] + [a.rendezvous]
    return sum(math.dist(p, q) for p, q in zip(pts, pts[1:])) + sum(
        tasks[i]["service_s"] for i in a.route)


def _step(a: _Auv, tasks: dict, t: float, dt: float, out: list) -> None:
    if t < a.busy_until:
        return
    if a.state == "injecting":
        done = a.route.pop(0)
        a.treated.append(done)
        a.priority += tasks[done]["priority"]
        if done in a.claims:
            a.claims.remove(done)
        out.append((bus.event_key(a.vid), Event(t, a.vid, "cleared", [done]).encode()))
        a.state = "transit"
    goal = tuple(tasks[a.route[0]]["pos"][:2]) if a.route else a.rendezvous
    d = math.dist(a.xy, goal)
    if d <= dt:
        a.distance_m += d
        a.xy = goal
        if a.route:
            a.state = "injecting"
            a.busy_until = t + tasks[a.route[0]]["service_s"]
        else:  # an agent announces its arrival (fleet_agent.agent: replan, home)
            a.state = "home"
            out.append((bus.event_key(a.vid), Event(t, a.vid, "replan", detail="home").encode()))
        return
    a.yaw_deg = math.degrees(math.atan2(goal[1] - a.xy[1], goal[0] - a.xy[0]))
    a.xy = (a.xy[0] + dt * (goal[0] - a.xy[0]) / d, a.xy[1] + dt * (goal[1] - a.xy[1]) / d)
    a.distance_m += dt
    a.state = "returning" if not a.route else "transit"


def small_scenario() -> dict[str, Any]:
    """Three vehicles, six spots on a 100 m square, no COTS map, one forbidden square."""
    return {
        "name": "small",
        "speed_mps": 1.0,
        "vehicles": [
            {"id": v, "start": [0.0, 0.0, 0.0], "rendezvous": [100.0, 100.0, 0.0],
             "battery_s": 3600.0} for v in ("auv1", "auv2", "auv3")
        ],
        "tasks": [
            {"id": 10 + i, "pos": [x, y, -5.0], "priority": p, "service_s": 20.0}
            for i, (x, y, p) in enumerate([(20, 10, 10), (40, 20, 50), (60, 30, 100),
                                           (20, 60, 30), (40, 80, 70), (80, 60, 90)])
        ],
        "forbidden": [[[45.0, 45.0], [55.0, 45.0], [55.0, 55.0], [45.0, 55.0]]],
    }


def mission_of(doc: dict[str, Any], run_id: str = "test-run") -> Mission:
    return Mission(doc, 3, run_id)
