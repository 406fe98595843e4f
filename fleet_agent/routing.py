"""Route edits the agent's policies share: fit a route to the battery, insert a spot.

Both time the route with the agent's model of its vehicle (`fleet_agent.motion.OwnVehicle`),
from where the vehicle is now, so a route they return is one the vehicle can fly home from.
"""

from __future__ import annotations

import math
from typing import Collection, Sequence

from fleet_agent.motion import OwnVehicle
from hfc_core.model.feasibility import fits


def fit_route(own: OwnVehicle, route: Sequence[int], reserve_s: float,
              protect: Collection[int] = ()) -> list[int]:
    """``route`` with spots dropped until it ends at the rendezvous within the battery.

    Drops the spot whose removal saves the most time per unit of priority (the paper's
    screening idea), never the one being injected, and spots in ``protect`` only once no
    other spot is left to drop.
    """
    route = list(route)
    priority = own.problem.priority
    budget_s = own.battery_left_s() - reserve_s
    while route and not fits(own.time_to_finish_s(route), budget_s):
        base = own.time_to_finish_s(route)
        best, best_score = None, -math.inf
        spare = any(t not in protect and not (i == 0 and own.injecting == t)
                    for i, t in enumerate(route))
        for i, task in enumerate(route):
            if (i == 0 and own.injecting == task) or (spare and task in protect):
                continue
            saved = base - own.time_to_finish_s(route[:i] + route[i + 1:])
            score = saved / max(float(priority[task]), 1e-9)
            if score > best_score:
                best, best_score = i, score
        if best is None:
            break
        route.pop(best)
    return route


def cheapest_insertion(own: OwnVehicle, route: list[int], task: int) -> list[int]:
    """``route`` with ``task`` where it lengthens the remaining mission least (never before
    the spot being injected)."""
    start = 1 if route and route[0] == own.injecting else 0
    best, best_time = route, math.inf
    for i in range(start, len(route) + 1):
        cand = route[:i] + [task] + route[i:]
        t = own.time_to_finish_s(cand)
        if t < best_time:
            best, best_time = cand, t
    return best
