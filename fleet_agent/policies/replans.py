"""What the takeover and the cooperation policies ask the replanner, and how.

Pure functions over what an agent knows. Both end in `hfc_core.replan` (through `Planner`,
iteration budgets only, a seed shared where the fleet should agree):

- takeover: the survivors nearest the freed spots (this vehicle at its true state, the others
  dead-reckoned), spots they hold locked to them, the freed spots open; returns this
  vehicle's share;
- cooperation (the paper's operator, online): this vehicle alone, every spot held by another
  live vehicle off limits; returns its route with free spots inserted.

Both are local: the replanner sees the spots in play and the vehicles near them only
(`Planner.replan`'s ``scope``), so a replan costs the same in a fleet of 3 and of 100.
"""

from __future__ import annotations

from typing import Collection, Mapping, Sequence

import numpy as np

from fleet_agent.knowledge import PeerPose
from fleet_agent.motion import OwnVehicle
from fleet_agent.plans import Live, Planner
from fleet_agent.reckoning import position_along
from fleet_bus.states import VehicleState
from hfc_core.model.paths import as_point3
from hfc_core.model.problem import Problem


def live_self(own: OwnVehicle) -> Live:
    """This vehicle as the replanner sees it (rounded: equal inputs memoise)."""
    locked = (own.injecting,) if own.injecting is not None else ()
    return Live(own.index, as_point3(round(c, 3) for c in own.pos),
                round(own.battery_left_s(), 3), tuple(own.route), locked)


def live_peer(problem: Problem, v: int, pose: PeerPose | None, route: Sequence[int],
              now_s: float) -> Live:
    """Dead reckoning: peer ``v``'s last pose (position, time, state) moved along its known
    route since then; without a pose, from its start at time 0. Battery: capacity minus
    mission time (constant power, Assumption 1)."""
    if pose is not None:
        pos, t = pose.pos, pose.t_s
        service_left = 0.5 * float(problem.service_s[route[0]]) \
            if pose.state == VehicleState.INJECTING and route else 0.0
    else:
        pos, t, service_left = problem.vehicles[v].start, 0.0, 0.0
    est = position_along(problem, v, pos, route, max(0.0, now_s - t), service_left)
    battery = max(0.0, problem.vehicles[v].battery_s - now_s)
    return Live(v, as_point3(round(c, 3) for c in est), round(battery, 3), tuple(route))


def takeover_share(planner: Planner, me: Live, peers: Sequence[Live], cleared: Collection[int],
                   held: Mapping[int, int], seed: int,
                   scope: Collection[int] | None = None) -> list[int]:
    """This vehicle's new route after replanning ``me`` and ``peers`` over the free spots
    (those in ``scope`` if given, with the spots ``me`` and ``peers`` hold)."""
    live = [me, *peers]
    present = {lv.index for lv in live}
    unavailable = frozenset(cleared) | frozenset(t for t, h in held.items() if h not in present)
    if scope is not None:
        scope = set(scope) | {t for t, h in held.items() if h in present}
    routes = planner.replan(live, unavailable, held, seed, scope)
    return [t for t in routes.get(me.index, []) if t not in cleared]


def nearest(points: Mapping[int, Sequence[float]], target: Sequence[float], count: int
            ) -> list[int]:
    """The ``count`` vehicles of ``points`` (index -> position) nearest ``target`` (x, y),
    ties by index: who is "near" is decided the same way on every vehicle."""
    def key(v: int) -> tuple[float, int]:
        p = points[v]
        return (round(float(np.hypot(p[0] - target[0], p[1] - target[1])), 3), v)
    return sorted(sorted(points), key=key)[:count]


def cheapest_detours(own: OwnVehicle, free: Collection[int], slack_s: float,
                     count: int) -> list[int]:
    """Up to ``count`` free spots that fit into the current route as detours within
    ``slack_s`` (cheapest insertion, service included), cheapest first, ties by index: the
    spots in this vehicle's reach (`detour_fits`)."""
    if not free:
        return []
    cand = np.array(sorted(free), dtype=int)
    cost = _detour_costs(own, cand)
    ok = np.flatnonzero(cost <= slack_s)
    order = ok[np.lexsort((cand[ok], cost[ok]))]
    return [int(t) for t in cand[order[:count]]]


def peer_etas(problem: Problem, v: int, pose: PeerPose | None, route: Sequence[int]
              ) -> dict[int, float]:
    """When peer ``v``, if alive and on its known route, reaches each spot of it: straight
    legs at cruise speed from its last pose (from its start at time 0 without one). Only an
    ordering is needed, so currents and land are left out."""
    speed = problem.vehicles[v].speed_mps
    here = np.asarray(pose.pos if pose is not None else problem.vehicles[v].start, dtype=float)
    t = pose.t_s if pose is not None else 0.0
    etas = {}
    for task in route:
        t += float(np.linalg.norm(problem.xyz[task] - here)) / speed
        etas[task] = t
        t += float(problem.service_s[task])
        here = problem.xyz[task]
    return etas


def after_own(route: Sequence[int], soon: Collection[int]) -> list[int]:
    """The route after a takeover: the replanner's route with the spots in ``soon`` moved to
    its end (in their order).

    ``soon`` are the taken spots the presumed-lost peer, were it alive, would reach before
    long (`peer_etas`). A peer presumed lost may only be out of earshot; whatever it is going
    to treat, it treats on its own schedule. A duplicate on one of its next spots needs this
    vehicle to get there before hearing anything from the peer again (any frame revives it
    and hands its spots back), so those go last, leaving that window as long as the route
    allows. Spots far down the peer's route are safe to take early: the peer would reach
    them long after this vehicle's clear has spread. Spots this vehicle held before are
    protected by the caller: a false alarm never costs it its own plan.
    """
    late = set(soon)
    return [t for t in route if t not in late] + [t for t in route if t in late]


def cooperation_route(planner: Planner, me: Live, cleared: Collection[int],
                      held: Mapping[int, int], seed: int,
                      offered: Collection[int] | None = None) -> list[int]:
    """This vehicle's route with free spots inserted (single-vehicle replan): any free spot,
    or only those ``offered`` (with its own)."""
    mine = {t: h for t, h in held.items() if h == me.index}
    others = frozenset(t for t, h in held.items() if h != me.index)
    scope = None if offered is None else set(offered) | set(mine) | set(me.route)
    routes = planner.replan([me], frozenset(cleared) | others, mine, seed, scope)
    return [t for t in routes.get(me.index, []) if t not in cleared]


def detour_fits(own: OwnVehicle, free: Collection[int], slack_s: float) -> bool:
    """Cheap pre-check before the replanner: does any free spot fit as a detour (cheapest
    insertion into the current route, service included) within ``slack_s``?"""
    cost = _detour_costs(own, np.fromiter(free, dtype=int))
    return bool((cost <= slack_s).any())


def _detour_costs(own: OwnVehicle, cand: np.ndarray) -> np.ndarray:
    """Seconds each spot of ``cand`` adds inserted where it costs least in the route."""
    p = own.problem
    nodes = list(own.route) + [p.end_node(own.index)]
    pos = np.asarray(own.pos)
    first = nodes[0]
    detour = (np.linalg.norm(p.xyz[cand] - pos, axis=1) + p.dist_m[cand, first]
              - float(np.linalg.norm(p.xyz[first] - pos)))
    for a, b in zip(nodes[:-1], nodes[1:]):
        detour = np.minimum(detour, p.dist_m[a, cand] + p.dist_m[cand, b] - p.dist_m[a, b])
    return detour / own.speed_mps + p.service_s[cand]
