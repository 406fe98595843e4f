"""Replace a routed task by a richer unrouted one that fits (the TOP "replace" move).

For every routed task and every unrouted task the new mission time is the route's time
without the routed task plus the unrouted task's insertion, either into the gap the removed
task leaves or at its cached cheapest position when that position is not next to the removed
task (then the cost is exact). All routes are evaluated in one numpy shot.
"""

from __future__ import annotations

import numpy as np

from hfc_core.best.state import MARGIN_S, State


def best_replaces(state: State) -> list[tuple[float, int, int, int, int]]:
    """Each route's best move as (gain, vehicle, route index, task, insert index after the
    removal), richest gain first; empty if no route has one."""
    inst = state.inst
    free = np.flatnonzero(state.owner < 0)
    if not len(free) or not any(state.routes):
        return []
    state.refresh()
    dist = inst.dist_m
    lengths = [len(r) for r in state.routes]
    veh = np.repeat(np.arange(inst.k), lengths)
    idx = np.concatenate([np.arange(n) for n in lengths])
    terms = [state.nodes(v) for v in range(inst.k)]
    prev = np.concatenate([t[:-2] for t in terms])
    cur = np.concatenate([t[1:-1] for t in terms])
    nxt = np.concatenate([t[2:] for t in terms])
    speed = inst.speed_mps[veh][:, None]
    saving_s = (dist[prev, cur] + dist[cur, nxt] - dist[prev, nxt]) / speed[:, 0] + inst.service_s[cur]
    gap_m = dist[prev[:, None], free[None, :]] + dist[nxt[:, None], free[None, :]]
    gap_m -= dist[prev, nxt][:, None]
    rows, cols = veh[:, None], free[None, :]
    pos = state.ins_pos[rows, cols]
    touching = (pos == idx[:, None]) | (pos == idx[:, None] + 1)
    elsewhere_m = np.where(touching, np.inf, state.ins_len[rows, cols])
    use_gap = gap_m <= elsewhere_m
    times = np.array([state.time_s(v) for v in range(inst.k)])
    new_time = (times[veh] - saving_s)[:, None] + np.minimum(gap_m, elsewhere_m) / speed
    new_time += inst.service_s[free][None, :]
    gain = inst.value[rows, cols] - inst.value[veh, cur][:, None]
    ok = (gain > 0) & (new_time <= (inst.budget_s[veh] - MARGIN_S)[:, None])
    ok &= inst.allowed[rows, cols]
    if not ok.any():
        return []
    score = np.where(ok, gain, -np.inf)
    moves = []
    ends = np.cumsum(lengths)
    for v in range(inst.k):
        lo, hi = ends[v] - lengths[v], ends[v]
        block = score[lo:hi]
        if not lengths[v] or block.max() == -np.inf:
            continue
        # Richest gain first; among equal gains the shortest resulting mission.
        tie = np.where(block == block.max(), -new_time[lo:hi], -np.inf)
        r, c = np.unravel_index(int(tie.argmax()), block.shape)
        i = int(idx[lo + r])
        at = i if use_gap[lo + r, c] else int(pos[lo + r, c]) - (1 if pos[lo + r, c] > i else 0)
        moves.append((float(block[r, c]), v, i, int(free[c]), at))
    return sorted(moves, key=lambda m: (-m[0], m[1]))


def replace_improve(state: State, max_rounds: int = 1000) -> bool:
    """Apply replace moves until none improves; True if any was applied. Each round applies
    the best move of every route whose incoming task no richer move has taken (moves in
    different routes are independent)."""
    for rounds in range(max_rounds):
        moves = best_replaces(state)
        if not moves:
            return rounds > 0
        taken: set[int] = set()
        for _, v, i, task, at in moves:
            if task in taken:
                continue
            taken.add(task)
            route = list(state.routes[v])
            route.pop(i)
            route.insert(at, task)
            state.set_route(v, route)
    return True
