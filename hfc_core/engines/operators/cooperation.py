"""Cooperation operator (paper section III-4, Algorithm 3, eq. 13; Algorithm 4 lines 40-46).

A vehicle with time to spare (T_diff > 0, eq. 12) takes over abandoned spots, i.e. spots on no
route of the individual, whoever's cluster they came from: the one nearest (eq. 13, 3-D) to the
last spot of its route is appended before the rendezvous, and this repeats while the next
nearest spot still fits the battery ("repeated until the remaining time is consumed"; we stop
at the first nearest spot that would overrun it, so cooperation never creates a violation).
The extended route is then re-ordered (line 44: ``order(R'(j))``).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from hfc_core.engines.operators.ordering import order_route
from hfc_core.model.cost import RouteModel
from hfc_core.model.feasibility import fits


def take_nearest(
    route: Sequence[int], abandoned: np.ndarray, *, model: RouteModel, v: int
) -> list[int]:
    """Algorithm 3 for vehicle ``v``: append nearest abandoned spots while they fit.
    ``abandoned`` is a boolean mask over tasks; taken spots are cleared in it."""
    out = list(route)
    while abandoned.any():
        last = out[-1] if out else model.start[v]
        candidates = np.flatnonzero(abandoned)
        nearest = int(candidates[np.argmin(model.dist_m[last, candidates])])  # eq. (13)
        # the mission time is recomputed, not accumulated, so "fits" means what the
        # screening and the final feasibility test mean by it
        if not fits(model.time_s(v, [*out, nearest]), model.battery_s[v]):
            break
        out.append(nearest)
        abandoned[nearest] = False
    return out


def cooperate(
    routes: Sequence[Sequence[int]], rng: np.random.Generator, *, model: RouteModel
) -> list[list[int]]:
    """Algorithm 4 lines 40-46 for one individual: every vehicle with T_diff > 0, in turn,
    takes abandoned spots (Algorithm 3) and re-orders its route (Algorithm 1)."""
    out = [list(r) for r in routes]
    abandoned = np.ones(model.n, dtype=bool)
    for r in out:
        abandoned[r] = False
    for v in range(model.k):
        if not abandoned.any():
            break
        if model.battery_s[v] - model.time_s(v, out[v]) <= 0:
            continue
        extended = take_nearest(out[v], abandoned, model=model, v=v)
        if len(extended) > len(out[v]):
            out[v] = order_route(extended, rng, model=model, v=v)
    return out
