"""Replace a routed task by a richer unrouted one that fits (the TOP "replace" move).

For every routed task and every unrouted task the new mission time is the route's time
without the routed task plus the unrouted task's insertion, either into the gap the removed
task leaves or at its cached cheapest position when that position is not next to the removed
task (then the cost is exact). All routes are evaluated in one numpy shot.
"""

from __future__ import annotations

import numpy as np

from hfc_core.best.state import MARGIN_S, State


def best_replace(state: State) -> tuple[int, int, int, int] | None:
    """(vehicle, route index, task, insert index after removal) of the best move, or None."""
    inst = state.inst
    free = np.flatnonzero(state.owner < 0)
    if not len(free) or not any(state.routes):
        return None
    state.refresh()
    dist = inst.dist_m
    veh = np.concatenate([np.full(len(r), v) for v, r in enumerate(state.routes)])
    idx = np.concatenate([np.arange(len(r)) for r in state.routes])
    cur = np.concatenate([np.asarray(r, dtype=np.int64) for r in state.routes])
    terms = [state.nodes(v) for v in range(inst.k)]
    prev = np.concatenate([t[:-2] for t in terms])
    nxt = np.concatenate([t[2:] for t in terms])
    speed = inst.speed_mps[veh][:, None]
    saving_s = (dist[prev, cur] + dist[cur, nxt] - dist[prev, nxt]) / speed[:, 0] + inst.service_s[cur]
    gap_m = dist[prev[:, None], free[None, :]] + dist[nxt[:, None], free[None, :]]
    gap_m -= dist[prev, nxt][:, None]
    pos = state.ins_pos[veh][:, free]
    touching = (pos == idx[:, None]) | (pos == idx[:, None] + 1)
    elsewhere_m = np.where(touching, np.inf, state.ins_len[veh][:, free])
    use_gap = gap_m <= elsewhere_m
    times = np.array([state.time_s(v) for v in range(inst.k)])
    new_time = (times[veh] - saving_s)[:, None] + np.minimum(gap_m, elsewhere_m) / speed
    new_time += inst.service_s[free][None, :]
    gain = inst.value[veh][:, free] - inst.value[veh, cur][:, None]
    ok = (gain > 0) & (new_time <= (inst.budget_s[veh] - MARGIN_S)[:, None])
    ok &= inst.allowed[veh][:, free]
    if not ok.any():
        return None
    # Richest gain first; among equal gains the shortest resulting mission.
    score = np.where(ok, gain, -np.inf)
    r, c = np.unravel_index(np.where(score == score.max(), -new_time, -np.inf).argmax(), score.shape)
    v, i = int(veh[r]), int(idx[r])
    at = i if use_gap[r, c] else int(pos[r, c]) - (1 if pos[r, c] > i else 0)
    return v, i, int(free[c]), at


def replace_improve(state: State, max_moves: int = 1000) -> bool:
    """Apply best replace moves until none improves; True if any was applied."""
    for moves in range(max_moves):
        move = best_replace(state)
        if move is None:
            return moves > 0
        v, i, task, at = move
        route = list(state.routes[v])
        route.pop(i)
        route.insert(at, task)
        state.set_route(v, route)
    return True
