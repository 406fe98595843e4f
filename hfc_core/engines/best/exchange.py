"""Replace a routed task by a richer unrouted one that fits (the TOP "replace" move).

For every routed task and every unrouted task the new mission time is the route's time
without the routed task plus the unrouted task's insertion, either into the gap the removed
task leaves or at its cached cheapest position when that position is not next to the removed
task (then the cost is exact). All routes are evaluated in one numpy shot.

With ``relocate``, the task taken out need not be lost: if it fits (at its cached cheapest
position) into another route with time to spare, it moves there, and the move gains the
unrouted task's whole value (an ejection chain of length two: room is made in a full route by
moving one of its tasks to a route with slack).
"""

from __future__ import annotations

import numpy as np

from hfc_core.engines.best.state import State
from hfc_core.model.feasibility import fits

# Up to this many (routed, unrouted) pairs every pair is evaluated; beyond, each routed task
# is paired with its NEIGHBOURS nearest unrouted tasks only (granular neighbourhood).
DENSE_PAIRS = 20_000
NEIGHBOURS = 40


def _pairs(state: State, cur: np.ndarray, free: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(row into ``cur``, unrouted task) candidate pairs."""
    if len(cur) * len(free) <= DENSE_PAIRS:
        return np.repeat(np.arange(len(cur)), len(free)), np.tile(free, len(cur))
    near = state.inst.nearest_tasks(NEIGHBOURS)[cur]  # (R, M)
    rows, cols = np.nonzero(state.owner[near] < 0)
    return rows, near[rows, cols]


Move = tuple[float, int, int, int, int, int, int]


def best_replaces(state: State, relocate: bool = False) -> list[Move]:
    """Each route's best move as (gain, vehicle, route index, task, insert index after the
    removal, route the removed task moves to or -1, its position there), richest gain first;
    empty if no route has one.

    The moves are a function of the instance and the routes alone, and the local search asks
    again of routes it has not changed (17 % of the calls planning 100 vehicles over 2,500
    spots), so the last answer is kept on the instance with its routes."""
    inst = state.inst
    free = np.flatnonzero(state.owner < 0)
    # every task routed (the usual case on an easy reef), or nothing routed: no move, and no
    # key to build for it
    if not len(free) or not any(state.routes):
        return []
    key = (relocate, tuple(map(tuple, state.routes)))
    last = inst.__dict__.get("_replaces")
    if last is not None and last[0] == key:
        return list(last[1])
    moves = _best_replaces(state, relocate, free)
    inst.__dict__["_replaces"] = (key, tuple(moves))
    return moves


def _best_replaces(state: State, relocate: bool, free: np.ndarray) -> list[Move]:
    """`best_replaces` computed afresh; ``free``: the unrouted tasks, at least one."""
    inst = state.inst
    state.refresh()
    stack, which = inst.stacked()
    cur, owner, index, before, after = state.positions()
    row, w = _pairs(state, cur, free)
    # Only a pair that gains value can be a move: the rest are dropped before any time is
    # computed (on an oversubscribed reef the unrouted tasks are mostly the poorer ones).
    # Each figure below is elementwise, and the survivors keep their order: the same moves.
    veh = owner[row]
    gain = inst.value[veh, w] - inst.value[owner, cur][row]
    dest = np.full(len(row), -1, dtype=np.int64)
    if relocate and inst.k > 1:
        room = np.array([state.slack_s(v) for v in range(inst.k)])
        extra = state.ins_s[:, cur] + inst.service_s[cur]
        fit_into = (extra <= room[:, None]) & inst.allowed[:, cur]
        fit_into[owner, np.arange(len(cur))] = False  # elsewhere, not its own route
        kept = np.where(fit_into, inst.value[:, cur], -np.inf)
        worth = kept.max(axis=0)
        # the richest route it fits, and of those the one it lengthens least
        where = np.where(kept == worth[None, :], extra, np.inf).argmin(axis=0)
        moves_on = (worth > 0)[row]
        gain = np.where(moves_on, gain + worth[row], gain)
        dest = np.where(moves_on, where[row], -1)
    live = np.flatnonzero((gain > 0) & inst.allowed[veh, w])
    if not len(live):
        return []
    row, w, veh, gain, dest = row[live], w[live], veh[live], gain[live], dest[live]
    # What depends on the routed task alone is computed once per task, then spread over its
    # pairs (same operations in the same order: the same floats as per pair).
    times = np.array([state.time_s(v) for v in range(inst.k)])
    idx, prev, nxt = index[row], before[row], after[row]
    if len(stack) == 1:  # every vehicle the same travel times (the usual case): plain lookups
        time = stack[0]
        shortcut_s = time[before, after]
        saving_s = time[before, cur] + time[cur, after] - shortcut_s + inst.service_s[cur]
        gap_s = time[prev, w] + time[w, nxt] - shortcut_s[row]
    else:
        c = which[owner]
        shortcut_s = stack[c, before, after]
        saving_s = stack[c, before, cur] + stack[c, cur, after] - shortcut_s \
            + inst.service_s[cur]
        c_pair = c[row]
        gap_s = stack[c_pair, prev, w] + stack[c_pair, w, nxt] - shortcut_s[row]
    pos = state.ins_pos[veh, w]
    elsewhere_s = np.where((pos == idx) | (pos == idx + 1), np.inf, state.ins_s[veh, w])
    use_gap = gap_s <= elsewhere_s
    new_time = (times[owner] - saving_s)[row] + np.minimum(gap_s, elsewhere_s) \
        + inst.service_s[w]
    ok = fits(new_time, inst.budget_s[veh])
    if not ok.any():
        return []
    # Per vehicle: richest gain first, then the shortest resulting mission.
    ok = np.flatnonzero(ok)
    order = ok[np.lexsort((new_time[ok], -gain[ok], veh[ok]))]
    firsts = order[np.flatnonzero(np.diff(veh[order], prepend=-1))]
    moves = []
    for p in firsts:
        i = int(idx[p])
        at = i if use_gap[p] else int(pos[p]) - (1 if pos[p] > i else 0)
        d = int(dest[p])
        removed = int(cur[row[p]])
        moves.append((float(gain[p]), int(veh[p]), i, int(w[p]), at, d,
                      int(state.ins_pos[d, removed]) if d >= 0 else -1))
    return sorted(moves, key=lambda m: (-m[0], m[1]))


def replace_improve(state: State, max_rounds: int = 1000, relocate: bool = False) -> bool:
    """Apply replace moves until none improves; True if any was applied. Each round applies
    the best move of every route whose incoming task no richer move has taken and whose
    routes no earlier move of the round has changed (moves in different routes are
    independent)."""
    applied_any = False
    for _ in range(max_rounds):
        applied = False
        taken: set[int] = set()
        touched: set[int] = set()
        for _, v, i, task, at, dest, dest_at in best_replaces(state, relocate):
            if task in taken or v in touched or dest in touched:
                continue
            taken.add(task)
            before = state.routes[v]
            out = before[i]
            route = list(before)
            route.pop(i)
            route.insert(at, task)
            state.set_route(v, route)
            if not state.fits(v):  # the estimate fitted, the route's own sum does not: undo
                state.set_route(v, before)
                continue
            touched.add(v)
            if dest >= 0:
                state.insert(dest, out, dest_at)
                touched.add(dest)
                if not state.fits(dest):
                    state.remove([out])
                    state.set_route(v, before)
                    continue
            applied = True
        if not applied:
            break
        applied_any = True
    return applied_any
