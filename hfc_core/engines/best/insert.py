"""Repair: greedy insertion of unassigned tasks, best value per extra second first.

The paper's cooperation operator hands abandoned tasks to vehicles with time to spare; this is
that idea made exhaustive: every unassigned task is considered for every route at its cheapest
position, and the best ``value / extra_time**exponent`` (with optional noise) is inserted until
nothing fits. Only the route that changed has its insertion costs recomputed.
"""

from __future__ import annotations

import numpy as np

from hfc_core.engines.best.state import State

# Exponents on extra time: 0 = richest task that fits, 1 = value per second, 2 = cheap first.
# Only 0.5, 1 and 2 are used because sqrt and products are exact IEEE operations: replanning
# agents on different machines must take identical decisions (no libm pow in the choices).
EXPONENTS = (0.5, 1.0, 2.0)


def _weighted(
    value: np.ndarray, extra_s: np.ndarray, exponent: float, floor_s: float
) -> np.ndarray:
    d = np.maximum(extra_s, 0.0) + floor_s
    if exponent == 0.0:
        return value.copy()
    if exponent == 0.5:
        return value / np.sqrt(d)
    if exponent == 1.0:
        return value / d
    if exponent == 2.0:
        return value / (d * d)
    raise ValueError(f"unsupported exponent {exponent}")


def fill(
    state: State,
    rng: np.random.Generator | None = None,
    *,
    exponent: float = 1.0,
    noise: float = 0.0,
    vehicles: list[int] | None = None,
) -> State:
    """Insert tasks greedily until no unassigned task fits any route (``vehicles``: only these)."""
    inst = state.inst
    k = inst.k
    open_v = np.zeros(k, dtype=bool)
    open_v[list(range(k)) if vehicles is None else vehicles] = True
    usable = inst.allowed & (inst.value > 0) & open_v[:, None] & (state.owner < 0)[None, :]
    value = inst.value
    if noise > 0 and rng is not None:
        value = value * (1.0 + noise * (2.0 * rng.random(usable.shape) - 1.0))
    # A floor on the extra time keeps free insertions (zero service, collinear) comparable.
    floor_s = 1e-3 * float(inst.budget_s.mean())
    state.refresh()
    score = np.full((k, inst.n), -np.inf)

    def rescore(v: int) -> None:
        extra = state.ins_s[v] + inst.service_s
        ok = usable[v] & (extra <= state.slack_s(v))
        score[v] = np.where(ok, _weighted(value[v], extra, exponent, floor_s), -np.inf)

    for v in np.flatnonzero(open_v).tolist():
        rescore(v)
    while True:
        flat = int(score.argmax())
        v, u = divmod(flat, inst.n)
        if score[v, u] == -np.inf:
            return state
        if state.try_insert(v, u):
            usable[:, u] = False
            score[:, u] = -np.inf
        else:
            usable[v, u] = False
        state.refresh_route(v)
        rescore(v)
