"""Ordering operator (paper section III-2, Fig. 5, Algorithm 1).

Each route gets ``n`` random moves per call (the inner ``For i = 1 to n`` of Algorithm 1), each
a swap, an insertion or a reversion chosen with equal probability, and a move is kept when the
route is not longer afterwards (``L(ind_o) <= L(ind)``). Algorithm 4 (line 18) compares costs
instead; with the task set fixed the eq. (9) priority term is constant, and for an overdue
route both remaining terms fall with its length, so the two agree. For a route within budget
the |T^M - T^B| term would reward detours, so we follow Algorithm 1: shorter is better, and the
time saved is what cooperation fills.

Moves are evaluated in O(1) from the vehicle's travel times (symmetric in still water, as eq.
7-8 make it) and only kept moves touch the route; against a current, where a stretch flown
backwards takes a different time, a reversion also counts that change (O(length of the
stretch)). Ordering never changes which tasks a route holds; "longer" means longer in time.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from hfc_core.model.cost import RouteModel

SWAP, INSERTION, REVERSION = 0, 1, 2


def swap(route: Sequence[int], i: int, j: int) -> list[int]:
    """Exchange the tasks at positions i and j."""
    out = list(route)
    out[i], out[j] = out[j], out[i]
    return out


def insertion(route: Sequence[int], i: int, j: int) -> list[int]:
    """Take the task at position i out and put it back at position j (Fig. 5: #6 before #2)."""
    out = list(route)
    out.insert(j, out.pop(i))
    return out


def reversion(route: Sequence[int], i: int, j: int) -> list[int]:
    """Reverse the stretch between positions i and j inclusive."""
    lo, hi = min(i, j), max(i, j)
    out = list(route)
    out[lo : hi + 1] = out[lo : hi + 1][::-1]
    return out


MOVES = {SWAP: swap, INSERTION: insertion, REVERSION: reversion}


def move_delta_m(d: list[list[float]], seq: list[int], kind: int, i: int, j: int,
                 symmetric: bool = True) -> float:
    """Change of length (or time: ``d`` is a metric or travel times) of ``seq`` (terminals
    included) if move ``kind`` is applied at route positions i != j (route position p is
    ``seq[p + 1]``). ``symmetric=False``: ``d`` differs by direction."""
    if kind == INSERTION:
        if i > j:  # the later task x moves before the earlier one
            a, b = j + 1, i + 1
            x = seq[b]
            return (d[seq[a - 1]][x] + d[x][seq[a]] - d[seq[a - 1]][seq[a]]
                    + d[seq[b - 1]][seq[b + 1]] - d[seq[b - 1]][x] - d[x][seq[b + 1]])
        a, b = i + 1, j + 1  # the earlier task x moves after the later one
        x = seq[a]
        return (d[seq[a - 1]][seq[a + 1]] - d[seq[a - 1]][x] - d[x][seq[a + 1]]
                + d[seq[b]][x] + d[x][seq[b + 1]] - d[seq[b]][seq[b + 1]])
    a, b = (i + 1, j + 1) if i < j else (j + 1, i + 1)
    p, x, y, q = seq[a - 1], seq[a], seq[b], seq[b + 1]
    if kind == REVERSION or b == a + 1:  # adjacent swap == reversion of two
        delta = d[p][y] + d[x][q] - d[p][x] - d[y][q]
        if not symmetric:  # the stretch seq[a..b] is flown backwards
            for c in range(a, b):
                delta += d[seq[c + 1]][seq[c]] - d[seq[c]][seq[c + 1]]
        return delta
    xn, yp = seq[a + 1], seq[b - 1]  # x's successor, y's predecessor
    return (d[p][y] + d[y][xn] + d[yp][x] + d[x][q]) - (d[p][x] + d[x][xn] + d[yp][y] + d[y][q])


def order_route(
    route: Sequence[int], rng: np.random.Generator, *, model: RouteModel, v: int,
    moves: int | None = None,
) -> list[int]:
    """Algorithm 1 on one route of vehicle ``v``: ``moves`` (default ``len(route)``) random
    swap/insertion/reversion moves, each kept if the route does not get longer."""
    n = len(route)
    if n < 2:
        return list(route)
    count = n if moves is None else moves
    kinds = rng.integers(0, 3, size=count).tolist()
    first = rng.integers(0, n, size=count).tolist()
    second = rng.integers(0, n - 1, size=count).tolist()
    seq = [model.start[v], *route, model.end[v]]
    d, symmetric = model.time_rows[v], model.symmetric
    for kind, i, j in zip(kinds, first, second):
        j += j >= i  # a second position different from the first, uniformly
        if move_delta_m(d, seq, kind, i, j, symmetric) <= 0.0:
            seq[1:-1] = MOVES[kind](seq[1:-1], i, j)
    return seq[1:-1]


def order(
    routes: Sequence[Sequence[int]], rng: np.random.Generator, *, model: RouteModel
) -> list[list[int]]:
    """Algorithm 1 on every vehicle's route of one individual."""
    return [order_route(r, rng, model=model, v=v) for v, r in enumerate(routes)]
