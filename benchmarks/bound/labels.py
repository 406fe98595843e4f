"""One-directional labelling of ng-paths: every path that could be part of a fitting route is
represented by a kept label at least as good (the dominance argument below).

A label is a path ending at a node: its time ``t``, its reduced profit ``p`` and its ng-memory
``mask`` (`benchmarks.bound.ng`). Extending it by one arc adds the arc's time and the gains of
the nodes. A label is dropped only when

(a) no completion can fit the budget (``t + rest`` exceeds it, ``rest`` a lower bound on the
    time still needed), or
(b) another kept label at the same node has ``t' <= t``, ``p' >= p`` and ``mask' ⊆ mask``:
    every extension of the dropped label is an extension of the other (its memory forbids
    less) with no more time and no less profit, because float addition is monotone, or
(c) the caller's completion bound says that no completion can lift it above the threshold.

So for every ng-path the kept labels hold one at the same node that is at least as good.

Labels are extended in rounds, in order of time: a round takes the pending labels within
``step`` (the shortest arc) of the earliest one, so every label extended in an earlier round
is no later than any label still pending. Then (b) against extended labels needs no time
test: ``sub[j, m]`` is the highest profit of an extended label at ``j`` whose memory lies in
``m`` (a subset-maximum table over the ``2**k`` memories), and a label is dominated when
``sub[j, mask] >= p``. Within a round, labels with equal memories are filtered exactly in time
order, and the round is extended in a few slices of time, each checked against the table
holding the slices before it. Missing a dominance only costs time, never exactness.

``exact=False`` ignores memories in (b) and keeps at most ``max_per_node`` labels per node and
round (a heuristic that may lose routes: it finds columns, it never certifies a bound).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from benchmarks.bound.ng import NgSets

PENDING, EXTENDED, DEAD = 0, 1, 2
SLICES = 4  # time slices of a round, for dominance within the round

# Completion bound: (nodes, times) -> upper bound on the profit any completion can still add.
Completion = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True, eq=False)
class Direction:
    """The arcs one labelling walks (``m`` nodes, all tasks)."""

    arc: np.ndarray  # (m, m) time added by moving from a to b (inf: no arc)
    gain_from: np.ndarray  # (m,) profit added when leaving a node
    gain_to: np.ndarray  # (m,) profit added when entering a node
    init_t: np.ndarray  # (m,) time of the one-node label (inf: none)
    init_p: np.ndarray  # (m,) its profit
    rest: np.ndarray  # (m,) lower bound on the time any completion still needs
    budget: float
    ng: NgSets


@dataclass(eq=False)
class Labels:
    """Every label made (flat arrays), with its parent (-1: a one-node label), and the kept
    ones of each node."""

    node: np.ndarray
    t: np.ndarray
    p: np.ndarray
    mask: np.ndarray
    parent: np.ndarray
    by_node: list[np.ndarray]

    def path(self, i: int) -> list[int]:
        """The nodes of label ``i``, first to last."""
        out = []
        while i >= 0:
            out.append(int(self.node[i]))
            i = int(self.parent[i])
        return out[::-1]

    @property
    def kept(self) -> int:
        return sum(len(ids) for ids in self.by_node)


class _Pool:
    """Every label made, in growable flat arrays (capacity doubles), and the pending ones."""

    def __init__(self) -> None:
        self.size = 0
        self.node = np.empty(1024, dtype=np.int64)
        self.t = np.empty(1024)
        self.p = np.empty(1024)
        self.mask = np.empty(1024, dtype=np.int64)
        self.parent = np.empty(1024, dtype=np.int64)
        self.state = np.empty(1024, dtype=np.int8)
        self.pending = np.empty(0, dtype=np.int64)

    def add(self, node, t, p, mask, parent) -> None:
        n = len(t)
        if self.size + n > len(self.t):
            cap = max(2 * len(self.t), self.size + n)
            for name in ("node", "t", "p", "mask", "parent", "state"):
                old = getattr(self, name)
                grown = np.empty(cap, dtype=old.dtype)
                grown[: self.size] = old[: self.size]
                setattr(self, name, grown)
        sl = slice(self.size, self.size + n)
        self.node[sl], self.t[sl], self.p[sl] = node, t, p
        self.mask[sl], self.parent[sl], self.state[sl] = mask, parent, PENDING
        self.pending = np.concatenate([self.pending, np.arange(self.size, self.size + n)])
        self.size += n


def subset_max(best: np.ndarray, k: int) -> np.ndarray:
    """``out[j, m] = max(best[j, m'] for m' ⊆ m)`` (the zeta transform over subsets)."""
    out = best.copy()
    rows = out.shape[0]
    for b in range(k):
        view = out.reshape(rows, -1, 2, 1 << b)
        np.maximum(view[:, :, 1, :], view[:, :, 0, :], out=view[:, :, 1, :])
    return out


def _running_max(values: np.ndarray, segment: np.ndarray) -> np.ndarray:
    """Prefix maximum of ``values`` within runs of equal ``segment`` (exact: max only)."""
    out = values.copy()
    shift = 1
    while shift < len(out):
        same = segment[shift:] == segment[:-shift]
        if not same.any():
            break
        prev = np.where(same, out[:-shift], -np.inf)
        np.maximum(out[shift:], prev, out=out[shift:])
        shift *= 2
    return out


def _pareto(group: np.ndarray, t: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Keep mask: the labels that no label of the same ``group`` (node and memory: equal
    memories need no subset test) dominates; of equal ones, one stays. The labels must come
    in order of time (ties in any order: then both stay, which is still exact)."""
    keep = np.ones(len(t), dtype=bool)
    if len(t) <= 1:
        return keep
    order = np.argsort(group, kind="stable")  # by group, in time within each
    g, ps = group[order], p[order]
    best = _running_max(ps, g)
    first = np.r_[True, g[1:] != g[:-1]]
    kept = first.copy()
    kept[1:] |= ps[1:] > best[:-1]
    keep[order] = kept
    return keep


def _top_per_node(node: np.ndarray, p: np.ndarray, cap: int) -> np.ndarray:
    """Keep mask: the ``cap`` most profitable labels of each node."""
    order = np.lexsort((-p, node))
    g = node[order]
    starts = np.r_[0, np.flatnonzero(np.diff(g)) + 1]
    rank = np.arange(len(g)) - np.repeat(starts, np.diff(np.r_[starts, len(g)]))
    keep = np.empty(len(g), dtype=bool)
    keep[order] = rank < cap
    return keep


def label(direction: Direction, horizon: float, exact: bool = True, *,
          max_per_node: int | None = None, completion: Completion | None = None,
          threshold: float = -np.inf, finish: np.ndarray | None = None) -> Labels:
    """The non-dominated ng-paths of ``direction``: labels with ``t <= horizon`` are extended;
    every fitting extension is kept (also past the horizon) unless dominated, or unless
    ``p + completion(node, t) <= threshold``. With ``finish`` (the time to end the path at
    each node), ``threshold`` rises to the best path ended so far: then only what can beat
    that is kept, which still finds the best ended path."""
    d = direction
    m, k = len(d.init_t), d.ng.k
    width = 1 << k if exact else 1
    best = np.full((m, width), -np.inf)  # per memory: best profit of an extended label
    sub = best.copy()
    pool = _Pool()
    records: list[int] = []  # labels that raised the threshold when they ended
    first = np.flatnonzero(np.isfinite(d.init_t) & (d.init_t + d.rest <= d.budget))
    pool.add(first, d.init_t[first], d.init_p[first], np.zeros(len(first), dtype=np.int64),
             np.full(len(first), -1, dtype=np.int64))
    finite = d.arc[np.isfinite(d.arc)]
    step = max(float(finite.min()), 0.0) if finite.size else d.budget
    while True:
        open_ = pool.pending[pool.t[pool.pending] <= horizon]
        if open_.size == 0:
            break
        t_open = pool.t[open_]
        t0 = t_open.min()
        now = t_open <= t0 + step
        batch = open_[now]
        pool.pending = np.setdiff1d(pool.pending, batch, assume_unique=True)
        node, bt, bp, bm = pool.node[batch], pool.t[batch], pool.p[batch], pool.mask[batch]
        if finish is not None:
            ends = np.flatnonzero(bt + finish[node] <= d.budget)
            if ends.size and bp[ends].max() > threshold:
                record = int(batch[ends[np.argmax(bp[ends])]])
                threshold = float(pool.p[record])
                records.append(record)
        key = bm if exact else np.zeros_like(bm)
        alive = sub[node, key] < bp
        if completion is not None:
            alive &= bp + completion(node, bt) > threshold
        idx = np.flatnonzero(alive)
        idx = idx[np.argsort(bt[idx], kind="stable")]  # in order of time
        if exact:
            idx = idx[_pareto(node[idx] * width + bm[idx], bt[idx], bp[idx])]
            # in slices of time, each checked against the table holding the earlier ones
            parts = []
            for part in np.array_split(idx, SLICES):
                part = part[sub[node[part], bm[part]] < bp[part]]
                if part.size:
                    np.maximum.at(best, (node[part], bm[part]), bp[part])
                    rows = np.unique(node[part])
                    sub[rows] = subset_max(best[rows], k)
                    parts.append(part)
            idx = np.sort(np.concatenate(parts)) if parts else idx[:0]
        else:
            idx = idx[_pareto(node[idx], bt[idx], bp[idx])]
            if max_per_node is not None:
                idx = idx[_top_per_node(node[idx], bp[idx], max_per_node)]
        pool.state[batch] = DEAD
        pool.state[batch[idx]] = EXTENDED
        batch, node, bt, bp, bm = batch[idx], node[idx], bt[idx], bp[idx], bm[idx]
        if not exact:
            np.maximum.at(best, (node, 0), bp)
            sub = best
        nt = bt[:, None] + d.arc[node]
        ok = (nt + d.rest[None, :] <= d.budget) & ~d.ng.forbidden(node, bm)
        r, c = np.nonzero(ok)
        if r.size == 0:
            continue
        new_t = nt[r, c]
        new_p = bp[r] + d.gain_from[node[r]] + d.gain_to[c]
        if completion is not None:
            sel = np.flatnonzero(new_p + completion(c, new_t) > threshold)
            r, c, new_t, new_p = r[sel], c[sel], new_t[sel], new_p[sel]
        new_m = d.ng.moved(node[r], bm[r], c)
        sel = np.flatnonzero(sub[c, new_m if exact else 0] < new_p)
        pool.add(c[sel], new_t[sel], new_p[sel], new_m[sel], batch[r[sel]])
    final = pool.pending  # past the horizon: never extended
    dominated = sub[pool.node[final], pool.mask[final] if exact else 0] >= pool.p[final]
    pool.state[final[dominated]] = DEAD
    if records:  # a record may be dominated or cut by its own value: keep it all the same
        pool.state[records] = EXTENDED
    n = pool.size
    kept = np.flatnonzero(pool.state[:n] != DEAD)
    order = kept[np.argsort(pool.node[kept], kind="stable")]
    counts = np.bincount(pool.node[order], minlength=m)
    by_node = np.split(order, np.cumsum(counts)[:-1])
    return Labels(pool.node[:n], pool.t[:n], pool.p[:n], pool.mask[:n], pool.parent[:n],
                  by_node)
