"""The restricted master LP: the set-packing relaxation over the routes found so far.

maximise ``sum_r value_r x_r`` subject to ``sum_r count_ir x_r <= 1`` for every task ``i`` and
``sum_{r in class c} x_r <= size_c`` for every vehicle class, ``x >= 0``. Its optimum is a
lower-or-equal figure of the full LP (it sees only some routes); only the dual values matter
for the bound, and `benchmarks.bound.upper_bound` makes any dual values give a valid bound.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import OptimizeWarning, linprog
from scipy.sparse import csc_array


@dataclass(frozen=True)
class Duals:
    value: float  # the restricted LP's optimum
    task: np.ndarray  # (n,) >= 0
    vehicle: np.ndarray  # (classes,) >= 0
    x: np.ndarray  # primal values of the columns


@dataclass
class Master:
    """Columns: ``(class, route)``; a route may visit a task twice (ng-routes): its count."""

    n: int
    sizes: list[int]
    priority: np.ndarray
    columns: list[tuple[int, tuple[int, ...]]] = field(default_factory=list)
    _seen: set[tuple[int, tuple[int, ...]]] = field(default_factory=set)
    # The coefficients of every column, made once when it is added (the LP is solved twice
    # per iteration over thousands of columns): row, column, value triplets and priorities.
    _rows: list[int] = field(default_factory=list)
    _cols: list[int] = field(default_factory=list)
    _vals: list[float] = field(default_factory=list)
    _value: list[float] = field(default_factory=list)

    def add(self, cls: int, route: tuple[int, ...]) -> bool:
        key = (cls, tuple(int(t) for t in route))
        if not key[1] or key in self._seen:
            return False
        self._seen.add(key)
        j = len(self.columns)
        self.columns.append(key)
        tasks, counts = np.unique(np.asarray(key[1], dtype=np.int64), return_counts=True)
        self._rows += [*tasks.tolist(), self.n + cls]
        self._cols += [j] * (len(tasks) + 1)
        self._vals += [*counts.astype(float).tolist(), 1.0]
        self._value.append(float(self.priority[list(key[1])].sum()))
        return True

    def _matrix(self) -> tuple[csc_array, np.ndarray]:
        """(n + classes, columns) coefficients and the columns' priorities."""
        shape = (self.n + len(self.sizes), len(self.columns))
        return (csc_array((self._vals, (self._rows, self._cols)), shape=shape),
                np.asarray(self._value, dtype=float))

    def solve(self, interior: bool = True) -> Duals:
        """Optimum and duals; ``interior``: HiGHS's interior-point method without crossover,
        whose duals lie inside the optimal face instead of at one of its vertices."""
        n = self.n
        if not self.columns:
            return Duals(0.0, np.zeros(n), np.zeros(len(self.sizes)), np.zeros(0))
        a, value = self._matrix()
        b = np.r_[np.ones(n), np.asarray(self.sizes, dtype=float)]
        res = None
        if interior:
            with warnings.catch_warnings():  # run_crossover is passed to HiGHS verbatim
                warnings.simplefilter("ignore", OptimizeWarning)
                res = linprog(-value, A_ub=a, b_ub=b, bounds=(0, None), method="highs-ipm",
                              options={"run_crossover": "off"})
        if res is None or res.status != 0:  # no interior answer: the simplex's vertex
            res = linprog(-value, A_ub=a, b_ub=b, bounds=(0, None), method="highs")
        if res.status != 0:
            raise RuntimeError(f"restricted master LP failed: {res.message}")
        dual = np.maximum(-np.asarray(res.ineqlin.marginals, dtype=float), 0.0)
        return Duals(float(-res.fun), dual[:n], dual[n:], np.asarray(res.x))

    def box_dual(self, center: np.ndarray, delta: float) -> tuple[np.ndarray, np.ndarray, float]:
        """The dual of the restricted LP with every task price kept within ``delta`` of
        ``center`` (BoxStep stabilisation): minimise ``sum(pi) + sum(size_c * mu_c)`` subject
        to ``pi(r) + mu_c >= priority(r)`` for every column. Returns (pi, mu, value): ``value``
        is the cutting-plane model of the Lagrangian bound at ``pi``, a lower figure."""
        n, k = self.n, len(self.sizes)
        if not self.columns:
            return np.maximum(center - delta, 0.0), np.zeros(k), float(
                np.maximum(center - delta, 0.0).sum())
        a, value = self._matrix()
        cost = np.r_[np.ones(n), np.asarray(self.sizes, dtype=float)]
        lower = np.r_[np.maximum(center - delta, 0.0), np.zeros(k)]
        upper = np.r_[center + delta, np.full(k, np.inf)]
        res = linprog(cost, A_ub=-a.T.tocsc(), b_ub=-value, bounds=np.c_[lower, upper],
                      method="highs")
        if res.status != 0:
            raise RuntimeError(f"stabilised dual LP failed: {res.message}")
        x = np.asarray(res.x)
        return np.maximum(x[:n], 0.0), np.maximum(x[n:], 0.0), float(res.fun)
