"""Inter-route improvement: 2-opt* (exchange the tails of two routes), relocate and swap.

Routes ``a`` and ``b`` become ``a[:i] + b[j:]`` and ``b[:j] + a[i:]``, each ending at its own
vehicle's rendezvous (Potvin and Rousseau 1995). The COTSbot fleet shares its start and
rendezvous, so two routes that cross in the middle of the reef are common after a repair, and
neither 2-opt nor or-opt inside a route can undo the crossing: the ruin-and-recreate loop finds
it only by luck. Every (i, j) of a pair of routes is evaluated at once from prefix and suffix
sums of each route's times on the other vehicle's travel times, so vehicles may differ in speed,
terminals, budget, allowed tasks and values (the replanner's stability bonus).

Relocate moves one task to another route's cheapest position (from the insertion cache);
swap exchanges one task of each of two routes, each taking the other's place. Both are the
classic inter-route moves of vehicle-routing local search (e.g. Vidal et al. 2012's HGS, whose
descendant PyVRP is our reference), here for saving time rather than distance.

A move is taken when the new routes fit their batteries and the objective (value less the
tie-breaking touch of time, `State.objective`) improves: with equal values that is the fleet's
mission time, which is the room the repair then fills with more tasks.
"""

from __future__ import annotations

from enum import Enum
from typing import Final

import numpy as np

from hfc_core.engines.best.state import State, Trial
from hfc_core.model.feasibility import fits

EPS_S = 1e-6  # a saving below this many seconds is rounding (a route swapped with its twin)


class _Views:
    """Prefix and suffix arrays of each route, for tail exchanges: computed once per route
    (and kind of vehicle flying its tail) until the route changes."""

    def __init__(self, state: State) -> None:
        self.state, self.twin = state, state.inst.twins()
        self.heads: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self.tails: dict[tuple[int, int], tuple[np.ndarray, ...]] = {}

    def head(self, v: int) -> tuple[np.ndarray, np.ndarray]:
        """(time of start -> first i tasks with their service, i = 0..L; the node each head
        ends at), on vehicle ``v``'s own times."""
        if v not in self.heads:
            inst, route = self.state.inst, self.state.routes[v]
            nodes = np.array([inst.start[v], *route], dtype=np.int64)
            legs = inst.travel_s[v][nodes[:-1], nodes[1:]] + inst.service_s[route]
            self.heads[v] = (np.concatenate([[0.0], np.cumsum(legs)]), nodes)
        return self.heads[v]

    def tail(self, v: int, w: int) -> tuple[np.ndarray, ...]:
        """Route ``v``'s tails from task j on (j = 0..L) flown by vehicle ``w``: (time through
        the rest to w's rendezvous with the service, the node each starts at, w's value of
        it, may w take all of it)."""
        key = (v, int(self.twin[w]))
        if key not in self.tails:
            inst, route = self.state.inst, self.state.routes[v]
            nodes = np.array([*route, inst.end[w]], dtype=np.int64)
            legs = inst.travel_s[w][nodes[:-1], nodes[1:]] + inst.service_s[route]
            value = inst.value[w, route] if route else np.zeros(0)
            ok = inst.allowed[w, route] if route else np.zeros(0, dtype=bool)
            self.tails[key] = (
                np.concatenate([np.cumsum(legs[::-1])[::-1], [0.0]]), nodes,
                np.concatenate([np.cumsum(value[::-1])[::-1], [0.0]]),
                np.concatenate([np.cumprod(ok[::-1])[::-1].astype(bool), [True]]))
        return self.tails[key]

    def changed(self, *vehicles: int) -> None:
        for v in vehicles:
            self.heads.pop(v, None)
            for key in [key for key in self.tails if key[0] == v]:
                del self.tails[key]


def best_tail_swap(state: State, a: int, b: int, tie: float, views: _Views | None = None
                   ) -> tuple[float, int, int] | None:
    """The best improving exchange of tails between routes ``a`` and ``b``: (gain, i, j)."""
    inst = state.inst
    if not state.routes[a] and not state.routes[b]:
        return None
    views = views or _Views(state)
    head_a, end_ha = views.head(a)  # (La+1,)
    head_b, end_hb = views.head(b)
    tail_ba, start_ba, value_ba, ok_ba = views.tail(b, a)  # b's tails flown by a: (Lb+1,)
    tail_ab, start_ab, value_ab, ok_ab = views.tail(a, b)
    value_aa, value_bb = views.tail(a, a)[2], views.tail(b, b)[2]
    # [i, j]: a' = a[:i] + b[j:]  and  b' = b[:j] + a[i:]
    new_a = head_a[:, None] + inst.travel_s[a][end_ha[:, None], start_ba[None, :]] + tail_ba
    new_b = head_b + inst.travel_s[b][end_hb[None, :], start_ab[:, None]] + tail_ab[:, None]
    gain_value = value_ba[None, :] + value_ab[:, None] - value_aa[:, None] - value_bb[None, :]
    old_time = state.time_s(a) + state.time_s(b)
    gain = gain_value - tie * (new_a + new_b - old_time)
    ok = (fits(new_a, float(inst.budget_s[a])) & fits(new_b, float(inst.budget_s[b]))
          & ok_ba[None, :] & ok_ab[:, None] & (gain > tie * EPS_S))
    if not ok.any():
        return None
    masked = np.where(ok, gain, -np.inf)
    i, j = divmod(int(masked.argmax()), masked.shape[1])
    return float(masked[i, j]), i, j


def _apply(state: State, trial: Trial, tie: float) -> bool:
    """Set the ``trial``'s routes if every one fits by its own sum and the objective
    improves; otherwise leave the state as it was (the estimate gains, the routes' own sums
    often do not)."""
    if trial.fits() and trial.objective(tie) > state.objective(tie):
        trial.accept()
        return True
    return False


def best_relocate(state: State, tie: float) -> tuple[float, int, int, int, int] | None:
    """The best improving move of one task to another route: (gain, task, from, to, at)."""
    inst = state.inst
    if sum(map(bool, state.routes)) == 0 or inst.clock is not None:
        return None
    state.refresh()
    task, veh, _, prev, nxt = state.positions()
    stack, which = inst.stacked()
    c = which[veh]
    saving = (stack[c, prev, task] + stack[c, task, nxt] - stack[c, prev, nxt]
              + inst.service_s[task])  # (R,) time the route sheds
    extra = state.ins_s[:, task] + inst.service_s[task][None, :]  # (k, R) time it costs v
    room = np.array([state.slack_s(v) for v in range(inst.k)])
    gain = (inst.value[:, task] - inst.value[veh, task][None, :]
            - tie * (extra - saving[None, :]))
    ok = (extra <= room[:, None]) & inst.allowed[:, task] & (gain > tie * EPS_S)
    ok[veh, np.arange(len(task))] = False
    if not ok.any():
        return None
    masked = np.where(ok, gain, -np.inf)
    to, r = divmod(int(masked.argmax()), len(task))
    return float(masked[to, r]), int(task[r]), int(veh[r]), to, int(state.ins_pos[to, task[r]])


class _Missing(Enum):
    """What a `PairTable` answers for a pair it holds no current result for (None is a
    result: no improving move)."""

    MISSING = 0


_Move = tuple[float, int, int] | None  # (gain, index in a, index in b), or no improving move


class PairTable:
    """One result per pair of routes, kept while both routes are what they were."""

    MISSING: Final = _Missing.MISSING

    def __init__(self) -> None:
        self._table: dict[tuple[int, int], tuple[list[int], list[int], _Move]] = {}

    def get(self, state: State, a: int, b: int) -> _Move | _Missing:
        hit = self._table.get((a, b))
        if hit is None or hit[0] != state.routes[a] or hit[1] != state.routes[b]:
            return PairTable.MISSING
        return hit[2]

    def put(self, state: State, a: int, b: int, result: _Move) -> None:
        # Copies: State.insert edits a route list in place.
        self._table[(a, b)] = (list(state.routes[a]), list(state.routes[b]), result)


class PairMemo:
    """What pairs of routes gave: the moves are pure functions of the two routes, and a
    ruin-and-recreate iteration changes few routes of a large fleet, so most pairs need no new
    evaluation. Keep one per search (per instance)."""

    def __init__(self) -> None:
        self.tails = PairTable()  # each pair's best tail exchange
        self.swaps = PairTable()  # each pair's best swap


def _swap_pair(state: State, a: int, b: int, tie: float) -> tuple[float, int, int] | None:
    """The best improving swap of a task of route ``a`` with one of route ``b``: (gain, index
    in a, index in b)."""
    inst = state.inst
    ra, rb = state.routes[a], state.routes[b]
    if not ra or not rb:
        return None
    stack, which = inst.stacked()
    na, nb = state.nodes(a), state.nodes(b)
    ta, pa, xa = na[1:-1], na[:-2], na[2:]
    tb, pb, xb = nb[1:-1], nb[:-2], nb[2:]
    time_a, time_b = stack[which[a]], stack[which[b]]  # 2-D views: cheaper to index
    service = inst.service_s
    sa, sb = service[ta], service[tb]
    # put_ab[x, y]: time of route a with b's task y in a's task x's place, minus its time now
    put_ab = (time_a[pa[:, None], tb] + time_a[tb, xa[:, None]]
              - time_a[pa, ta][:, None] - time_a[ta, xa][:, None]
              + sb[None, :] - sa[:, None])
    put_ba = (time_b[pb[:, None], ta] + time_b[ta, xb[:, None]]
              - time_b[pb, tb][:, None] - time_b[tb, xb][:, None]
              + sa[None, :] - sb[:, None])  # (Lb, La)
    value_a, value_b = inst.value[a], inst.value[b]
    worth_ab = value_a[tb][None, :] - value_a[ta][:, None]  # (La, Lb)
    worth_ba = value_b[ta][None, :] - value_b[tb][:, None]  # (Lb, La)
    fit_ab = (fits(state.time_s(a) + put_ab, float(inst.budget_s[a]))
              & inst.allowed[a][tb][None, :])
    fit_ba = (fits(state.time_s(b) + put_ba, float(inst.budget_s[b]))
              & inst.allowed[b][ta][None, :])
    gain = worth_ab + worth_ba.T - tie * (put_ab + put_ba.T)
    ok = fit_ab & fit_ba.T & (gain > tie * EPS_S)
    if not ok.any():
        return None
    masked = np.where(ok, gain, -np.inf)
    i, j = divmod(int(masked.argmax()), masked.shape[1])
    return float(masked[i, j]), i, j


def best_swap(state: State, tie: float, memo: PairMemo | None = None
              ) -> tuple[float, int, int, int, int] | None:
    """The best improving exchange of one task of a route with one of another, each taking
    the other's place: (gain, vehicle a, index in a, vehicle b, index in b); of equal gains
    the first by (a, index in a, b, index in b). Each pair's best is kept in ``memo`` until
    one of its routes changes."""
    inst = state.inst
    if sum(map(bool, state.routes)) < 2 or inst.clock is not None:
        return None
    memo = memo or PairMemo()
    best: tuple[float, int, int, int, int] | None = None
    for a in range(inst.k):
        for b in range(a + 1, inst.k):
            move = memo.swaps.get(state, a, b)
            if move is PairTable.MISSING:
                move = _swap_pair(state, a, b, tie)
                memo.swaps.put(state, a, b, move)
            if move is None:
                continue
            gain, i, j = move
            if best is None or gain > best[0] or (gain == best[0] and (a, i, b, j) < best[1:]):
                best = (gain, a, i, b, j)
    return best


def improve_between(state: State, max_rounds: int = 100, memo: PairMemo | None = None
                    ) -> list[int]:
    """Tail exchanges, then the best relocation, then the best swap, round after round until
    a round changes nothing (or ``max_rounds``); returns the vehicles whose routes changed.
    ``memo``: what pairs of routes gave before (`PairMemo`), kept by the caller across calls
    on the same instance."""
    if state.inst.clock is not None:  # leg times depend on when they are flown
        return []
    tie = state.inst.tie_weight()
    changed: set[int] = set()
    memo = memo or PairMemo()
    for _ in range(max_rounds):
        moved = swap_tails(state, memo)
        relocate = best_relocate(state, tie)
        if relocate is not None:
            _, u, a, b, at = relocate
            into = list(state.routes[b])
            into.insert(at, u)
            if _apply(state, state.trial({a: [x for x in state.routes[a] if x != u],
                                          b: into}), tie):
                moved += [a, b]
        swap = best_swap(state, tie, memo)
        if swap is not None:
            _, a, i, b, j = swap
            ra, rb = list(state.routes[a]), list(state.routes[b])
            ra[i], rb[j] = rb[j], ra[i]
            if _apply(state, state.trial({a: ra, b: rb}), tie):
                moved += [a, b]
        if not moved:
            break
        changed.update(moved)
    return sorted(changed)


def swap_tails(state: State, memo: PairMemo | None = None) -> list[int]:
    """Apply the best improving tail exchange of every pair of routes, pair by pair, until
    none improves; returns the vehicles whose routes changed. A pair's best exchange is a pure
    function of its two routes, so it is not evaluated again while they stay as they were
    (``memo``): a pass over a large fleet costs the pairs that changed, and a move the fleet's
    objective rejected is only judged again (on an oversubscribed reef most moves tried are
    such rounding-sized gains, whole routes swapped between identical vehicles: 250,000 of
    268,000 in the 100-vehicle plan of benchmarks.fleet_scale, a third of whose evaluations
    were such repeats)."""
    inst = state.inst
    if inst.clock is not None:  # leg times depend on when they are flown: left to the repair
        return []
    tie = inst.tie_weight()
    views, double = _Views(state), inst.doubles()
    memo = memo or PairMemo()
    changed: set[int] = set()
    improved = True
    while improved:
        improved = False
        for a in range(inst.k):
            for b in range(a + 1, inst.k):
                move = memo.tails.get(state, a, b)
                if move is PairTable.MISSING:
                    move = best_tail_swap(state, a, b, tie, views)
                    memo.tails.put(state, a, b, move)
                if move is None:
                    continue
                # A move whose estimate gains and whose routes' own sums do not is tried again
                # on the next pass (from the memo): whether the fleet's objective rises by a
                # rounding-sized gain depends on the other routes too.
                _, i, j = move
                ra, rb = state.routes[a], state.routes[b]
                if i == j == 0 and double[a] == double[b]:  # whole routes: figures known
                    trial = state.exchanged(a, b)
                else:
                    trial = state.trial({a: ra[:i] + rb[j:], b: rb[:j] + ra[i:]})
                if _apply(state, trial, tie):
                    views.changed(a, b)
                    changed.update((a, b))
                    improved = True
    return sorted(changed)
