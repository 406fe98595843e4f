"""Intra-route improvement: 2-opt and or-opt, each neighbourhood evaluated in one numpy shot.

A route is shortened (in travel time), never changed in content, so its value is untouched and
the time it frees is room for more tasks. ``nodes`` includes the route's terminals, which never
move. In still water times are symmetric and a reversed stretch costs what it cost forwards;
against a current (``symmetric=False``) the moves also count what reversing a stretch changes
inside it, from prefix sums of the route's forward and backward leg times.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

EPS_S = 1e-9  # an improvement smaller than this is rounding, not progress


@lru_cache(maxsize=256)
def _lower(size: int) -> np.ndarray:
    """Mask of the pairs (i, j) with j <= i + 1: not a 2-opt move."""
    return np.tri(size, size, 1, dtype=bool)


def _reversal(dist: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """``r[x] - r[y]``: what reversing nodes[y..x] adds inside the stretch (backward minus
    forward leg times), from prefix sums; all zeros for symmetric times."""
    forward = dist[nodes[:-1], nodes[1:]]
    backward = dist[nodes[1:], nodes[:-1]]
    return np.concatenate([[0.0], np.cumsum(backward - forward)])


def two_opt_step(dist: np.ndarray, nodes: np.ndarray, symmetric: bool = True
                 ) -> np.ndarray | None:
    """The best improving segment reversal, or None at a local optimum."""
    if len(nodes) < 4:
        return None
    a, b = nodes[:-1], nodes[1:]
    edge = dist[a, b]
    # Reversing nodes[i+1..j] swaps edges (a_i, b_i), (a_j, b_j) for (a_i, a_j), (b_i, b_j).
    gain = dist[a[:, None], a[None, :]] + dist[b[:, None], b[None, :]]
    gain -= edge[:, None] + edge[None, :]
    if not symmetric:  # and the stretch nodes[i+1..j] is flown backwards
        r = _reversal(dist, nodes)
        gain += r[None, : len(a)] - r[1:, None]
    gain[_lower(len(a))] = np.inf
    flat = int(gain.argmin())
    i, j = divmod(flat, len(a))
    if gain[i, j] >= -EPS_S:
        return None
    out = nodes.copy()
    out[i + 1 : j + 1] = nodes[i + 1 : j + 1][::-1]
    return out


def or_opt_step(dist: np.ndarray, nodes: np.ndarray, max_len: int = 3, symmetric: bool = True
                ) -> np.ndarray | None:
    """The best improving move of a segment of 1..max_len tasks elsewhere (either direction)."""
    inner = len(nodes) - 2
    if inner < 2:
        return None
    # Every segment nodes[i : i + s] at once: one row per (i, s).
    lens = range(1, min(max_len, inner - 1) + 1)
    i = np.concatenate([np.arange(1, inner - s + 2) for s in lens])
    s = np.concatenate([np.full(inner - s + 1, s) for s in lens])
    first, last = nodes[i], nodes[i + s - 1]
    prev, nxt = nodes[i - 1], nodes[i + s]
    removal = dist[prev, first] + dist[last, nxt] - dist[prev, nxt]
    tail, head = nodes[:-1], nodes[1:]
    edge = dist[tail, head]
    if symmetric:
        fwd = dist[first[:, None], tail[None, :]] + dist[last[:, None], head[None, :]]
        rev = dist[last[:, None], tail[None, :]] + dist[first[:, None], head[None, :]]
    else:  # tail -> first .. last -> head, or tail -> last .. first -> head (flown backwards)
        fwd = dist[tail[None, :], first[:, None]] + dist[last[:, None], head[None, :]]
        rev = dist[tail[None, :], last[:, None]] + dist[first[:, None], head[None, :]]
        r = _reversal(dist, nodes)
        rev = rev + (r[i + s - 1] - r[i])[:, None]
    delta = np.minimum(fwd, rev) - edge[None, :] - removal[:, None]
    # Edges touching the segment (j from i-1 to i+s-1) are not insertion points.
    j = np.arange(len(edge))[None, :]
    delta[(j >= i[:, None] - 1) & (j <= (i + s)[:, None] - 1)] = np.inf
    r, c = divmod(int(delta.argmin()), delta.shape[1])
    if delta[r, c] >= -EPS_S:
        return None
    start, length = int(i[r]), int(s[r])
    seg = nodes[start : start + length]
    if rev[r, c] < fwd[r, c]:
        seg = seg[::-1]
    rest = np.concatenate([nodes[:start], nodes[start + length :]])
    at = c + 1 if c < start else c + 1 - length  # edge c's head, in the route without the segment
    return np.concatenate([rest[:at], seg, rest[at:]])


def improve_route(dist: np.ndarray, nodes: np.ndarray, symmetric: bool = True,
                  max_rounds: int = 1000) -> np.ndarray:
    """2-opt to a local optimum, then or-opt; repeat until neither improves. ``dist``: the
    vehicle's travel times (``symmetric=False`` when they differ by direction)."""
    for _ in range(max_rounds):
        while (step := two_opt_step(dist, nodes, symmetric)) is not None:
            nodes = step
        step = or_opt_step(dist, nodes, symmetric=symmetric)
        if step is None:
            return nodes
        nodes = step
    return nodes
