"""ng-neighbourhoods and their bit tables: the memory that makes ng-routes nearly elementary.

An ng-route (Baldacci, Mingozzi, Roberti 2011) may revisit a task ``v`` only after passing a
task whose neighbourhood ``N(u)`` does not hold ``v``: a label at node ``j`` remembers the
set ``M`` of tasks it may not enter next, and moving on to ``l`` keeps ``(M | {j}) & N(l)``.
Every elementary route is an ng-route whatever the neighbourhoods, so the best ng-route is
at least the best elementary one: the relaxation the bound needs.

A label's memory lives in ``N(j)`` (the node itself is implicit), so it is stored as a small
integer of ``k`` bits local to its node; the tables here translate those bits between nodes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_NG = 30  # bits of a local memory (int64 arithmetic, with room to spare)


@dataclass(frozen=True, eq=False)
class NgSets:
    """Neighbourhoods of ``m`` nodes, ``k`` each: ``members[j]`` are the tasks of ``N(j)``."""

    members: np.ndarray  # (m, k) node indices, never j itself
    pos: np.ndarray  # (m, m) pos[l, x]: bit of x in N(l), or -1
    carry: np.ndarray  # (m, k, m) int64: carry[j, b, l] = 1 << pos[l, members[j, b]] or 0
    self_bit: np.ndarray  # (m, m) int64: self_bit[j, l] = 1 << pos[l, j] or 0

    @property
    def k(self) -> int:
        return self.members.shape[1]

    def forbidden(self, node: np.ndarray, mask: np.ndarray) -> np.ndarray:
        """(L, m) bool: may not move from ``node[i]`` with memory ``mask[i]`` to each node."""
        p = self.pos[node]  # (L, m)
        bit = (mask[:, None] >> np.maximum(p, 0)) & 1
        return (p >= 0) & (bit == 1)

    def moved(self, src: np.ndarray, mask: np.ndarray, dst: np.ndarray) -> np.ndarray:
        """Memory at ``dst`` after moving there from ``src`` with memory ``mask`` (all (L,))."""
        out = self.self_bit[src, dst].copy()
        for b in range(self.k):
            out |= ((mask >> b) & 1) * self.carry[src, b, dst]
        return out


def ng_sets(closeness: np.ndarray, k: int) -> NgSets:
    """Each node's ``k`` closest other nodes by ``closeness`` (m, m), smaller is closer."""
    m = closeness.shape[0]
    k = max(0, min(k, m - 1, MAX_NG))
    score = np.array(closeness, dtype=float)
    np.fill_diagonal(score, np.inf)
    members = np.argsort(score, axis=1, kind="stable")[:, :k].astype(np.int64)
    pos = np.full((m, m), -1, dtype=np.int64)
    rows = np.repeat(np.arange(m), k)
    pos[rows, members.ravel()] = np.tile(np.arange(k), m)
    one = np.int64(1)
    bit_of = np.where(pos >= 0, one << np.maximum(pos, 0), 0)  # bit_of[l, x]
    carry = bit_of[:, members].transpose(1, 2, 0).copy()  # [j, b, l] = bit_of[l, members[j, b]]
    self_bit = bit_of.T.copy()  # [j, l] = bit_of[l, j]
    return NgSets(members, pos, carry, self_bit)
