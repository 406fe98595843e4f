"""When a route fits its battery: the one rule of the planner, the replanner, the paper's
operators, the vehicle model and the checker.

A route fits when its mission time (eq. 8: travel plus injections) is at most the battery
(the paper's T^M <= T^B, i.e. T_diff >= 0 in eq. 12). A route whose time equals the battery
counts, to the last digit: the best-known solutions of some Team Orienteering instances use
such routes (Chao's p7.2.a: a spot exactly ``tmax`` away through start and end).

The same route summed in two orders (the planner's cached legs, numpy's pairwise sums, the
checker's `math.dist` loop) differs by a few units in the last place of each term: at most
about ``legs * 2**-52 * time``, i.e. 5e-11 s on the paper preset (60 legs, 3600 s) and 2e-8 s
for 1000 legs and a 10^5 s mission. So the comparison allows ``FEASIBILITY_TOL_S`` = 1
microsecond, fifty times the worst of that and far below anything physical (a vehicle moves
1 um in that time): every part agrees on a route at exactly the budget however it sums it.
Nothing else is a tolerance: there is no margin on top, and no part uses a stricter or looser
rule. (Only a route whose exact time lies within ~1e-8 s of ``budget + 1 us`` could be judged
differently by two summation orders; the planner re-checks every route it changes with its
own sum, so its plans never depend on an estimate.)
"""

from __future__ import annotations

from typing import TypeVar

import numpy as np

FEASIBILITY_TOL_S = 1e-6

Number = TypeVar("Number", float, np.ndarray)


def fits(time_s: Number, budget_s: Number) -> Number:
    """True where a mission of ``time_s`` fits a battery of ``budget_s`` (scalars or arrays)."""
    return time_s <= budget_s + FEASIBILITY_TOL_S


def room_s(time_s: float, budget_s: float) -> float:
    """How much longer a mission of ``time_s`` may get and still fit ``budget_s``:
    ``fits(time_s + extra, budget_s)`` exactly when ``extra <= room_s(time_s, budget_s)``
    (up to one rounding of the sum)."""
    return (budget_s - time_s) + FEASIBILITY_TOL_S
