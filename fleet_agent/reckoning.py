"""Dead reckoning of a peer: where it is by now, from its last pose and its known route.

A peer heard at ``pos`` at mission time ``t0_s`` is moved along its route (straight legs from
spot to spot, then home; a spot being injected first), each leg flown piece by piece through
the water as `hfc_core.travel.segment_pieces` cuts it (still water is one piece), so the
estimate is the one the planner's travel model gives. Used to place peers in a takeover.
"""

from __future__ import annotations

import math
from typing import Sequence

from hfc_core.model.paths import as_point3
from hfc_core.model.problem import Problem
from hfc_core.model.travel import LegError, segment_pieces

Point3 = tuple[float, float, float]


def position_along(problem: Problem, v: int, pos: Sequence[float], route: Sequence[int],
                   dt_s: float, first_service_left_s: float = 0.0, t0_s: float = 0.0) -> Point3:
    """Where vehicle ``v`` is ``dt_s`` after being at ``pos`` (at mission time ``t0_s``, which
    matters only in a tidal current) with ``route`` ahead (a spot being injected first if
    ``first_service_left_s`` > 0)."""
    speed = problem.vehicles[v].speed_mps
    now, until = t0_s + first_service_left_s, t0_s + dt_s
    here = as_point3(pos)
    last = len(route)
    for i in range(last + 1):  # the spots, then home; each read only once reached (a
        if now >= until:       # reckoning over a turn seldom passes the first two)
            break
        if i < last:
            target, service = as_point3(problem.xyz[route[i]]), float(problem.service_s[route[i]])
        else:
            target, service = problem.vehicles[v].rendezvous, math.inf
        try:
            pieces = segment_pieces(problem.current, here, target, speed, now)
        except LegError:
            break  # no headway against the current: it stays where it is
        run, leg = 0.0, math.dist(here, target)
        for duration, length in pieces:
            if now + duration >= until:
                run += length * ((until - now) / duration)
                f = run / leg
                return as_point3(a + (b - a) * f for a, b in zip(here, target))
            now, run = now + duration, run + length
        here = target
        now += service
    return here
