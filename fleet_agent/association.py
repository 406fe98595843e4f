"""Matching under uncertainty: is what the camera saw a predicted spot, an earlier find, or new?

Every position the agent holds is an estimate: a sighting is the vehicle's navigation estimate
plus the offset its camera measured (`fleet_bus.vehicle_port.Sighted`), uncertain by the
navigation's sigma (`NavFix.sigma_m`) and the camera's; a find heard from another vehicle is
uncertain by *that* vehicle's sigma when it saw it; a predicted spot by the map's error. And an
aggregation is not a point: COTS in one aggregation spread over metres to tens of metres, so
two looks at one aggregation see its centre at different places.

The rule is the tracking literature's gate (Bar-Shalom, Willett & Tian 2011, "Tracking and
Data Fusion", ch. 2-3; Blackman & Popoli 1999, "Design and Analysis of Modern Tracking
Systems", ch. 6): two estimates ``a`` and ``b`` (horizontal, isotropic per-axis sigmas) are of
one aggregation when the squared Mahalanobis distance of their difference,

    d2 = |a - b|^2 / (sigma_a^2 + sigma_b^2 + extent_m^2 / 2),

is within the chi-square gate of 2 degrees of freedom at probability ``gate_p`` (``-2 ln(1 -
p)``: 9.21 at 0.99). The extent term is the spread of two independent looks at one
aggregation of radius ``extent_m`` (a point uniform on a disc of radius R has per-axis variance
R^2 / 4; two of them, R^2 / 2). Among the candidates inside the gate the nearest in
generalised distance ``d2 + 2 ln S`` wins (the log-likelihood of the Gaussian, which does not
let a vague candidate win by its vagueness alone: Blackman & Popoli, sec. 6.2); several
sightings at once are assigned together (`assign`: global nearest neighbour, each candidate
to at most one sighting, by `scipy.optimize.linear_sum_assignment`).

The camera measures what it sees as well as where: an estimate may carry the rho it measured
(eq. 2's priority; feature-aided association, Bar-Shalom, Willett & Tian 2011, sec. 3.6), and
two estimates that both know theirs are one aggregation only if ln rho also falls in its gate
of one degree of freedom. Drifting vehicles' position gates reach 25-40 m; the rho tells
apart most of what they hold (docs/search.md, "The priority beside the position"). Two
estimates inside ``apart_p``'s gate stay one whatever their rho: nobody can aim between them.

"Never treated twice" is the same test with a looser gate (``treated_gate_p``): a candidate
spot is *probably treated* if any treated estimate could be it (`probably_treated`). Skipping
a distinct aggregation that close to a treated one costs its priority; treating one twice
costs an injection's time and is what the project has promised never to do. Which treated
estimates to hold a candidate against: a find (or a new sighting) against every treatment;
a predicted spot only against treated *finds* (a find may have been that spot, seen by a
drifted vehicle), never against other predicted spots: the map says they are distinct, and a
look at the spot (its footprint around where the vehicle really is) tells them apart.

Figures (defaults, per-axis 1-sigma): with 1 % drift over 300 m each, two vehicles' estimates
of one aggregation 8 m apart give d2 = 64 / (9.25 + 9.25 + 12.5) = 2.1: one aggregation; two
aggregations 40 m apart, d2 = 52: two. A sighting with exact navigation 7.4 m from its
predicted spot (Green Island's auv3/auv1 case) gives 54.8 / (0.25 + 9 + 12.5) = 2.5: that spot.
With exact navigation a sighting is a predicted spot out to about 14 m (the gate at 0.99).

Pure: no I/O, no clock, no randomness.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from statistics import NormalDist
from typing import Hashable, Iterable, Sequence, TypeVar

import numpy as np

K = TypeVar("K", bound=Hashable)
_INFEASIBLE = 1e12  # the assignment's cost of a pair outside the gate
PRIORITY_FLOOR = 1.0  # rho below this are alike (eq. 2's priorities run 1..100)
_LN_2PI = math.log(2.0 * math.pi)


def chi2_gate(p: float) -> float:
    """The chi-square quantile of 2 degrees of freedom at probability ``p``: -2 ln(1 - p)."""
    return -2.0 * math.log1p(-p)


@lru_cache(maxsize=16)
def chi2_gate_1(p: float) -> float:
    """The chi-square quantile of 1 degree of freedom at ``p``: the square of the normal
    quantile at (1 + p) / 2 (6.63 at 0.99)."""
    return NormalDist().inv_cdf((1.0 + p) / 2.0) ** 2


@dataclass(frozen=True)
class Estimate:
    """A horizontal position (x, y; a third coordinate is ignored: depth comes from a
    pressure sensor and the seabed) with its isotropic 1-sigma per axis, metres; and, when
    known, the aggregation's priority (eq. 2's rho, as the camera measured it or the map
    predicts it) with the 1-sigma of its natural log (``priority_sigma``: relative)."""

    pos: tuple[float, ...]
    sigma_m: float
    priority: float | None = None
    priority_sigma: float = 0.0

    def __post_init__(self) -> None:
        if len(self.pos) < 2 or not all(math.isfinite(c) for c in self.pos[:2]):
            raise ValueError(f"an estimate needs a finite (x, y), got {self.pos!r}")
        if not (math.isfinite(self.sigma_m) and self.sigma_m >= 0):
            raise ValueError(f"sigma_m must be finite and >= 0, got {self.sigma_m!r}")
        if self.priority is not None and not (math.isfinite(self.priority)
                                              and self.priority >= 0):
            raise ValueError(f"priority must be finite and >= 0, got {self.priority!r}")
        if not (math.isfinite(self.priority_sigma) and self.priority_sigma >= 0):
            raise ValueError(f"priority_sigma must be finite and >= 0, "
                             f"got {self.priority_sigma!r}")

    @property
    def log_priority(self) -> float | None:
        """ln rho (rho below `PRIORITY_FLOOR` counted at the floor: all alike), or None."""
        if self.priority is None:
            return None
        return math.log(max(self.priority, PRIORITY_FLOOR))

    @property
    def xy(self) -> tuple[float, float]:
        return float(self.pos[0]), float(self.pos[1])


@dataclass(frozen=True)
class AssociationParams:
    """``gate_p``: how sure the gate is that one aggregation's estimates fall in it (0.99);
    ``treated_gate_p``: the same for "already treated" (looser: rather skip than treat
    twice); ``extent_m``: an aggregation's radius; ``map_sigma_m``: a predicted spot's
    position error on the map; ``camera_sigma_m``: what the camera's measured offset adds to
    the vehicle's navigation sigma (`reef_sim.navigation`'s ``camera_sigma_m``); ``sure_p``:
    how likely the nearest of several candidates in the gate must be to be taken for the
    one (`resolve`). The priority (feature-aided association, Bar-Shalom, Willett & Tian
    2011, sec. 3.6: a measured attribute beside the position): ``camera_priority_sigma``,
    the camera's error on rho (relative, 1 sigma of ln rho; 0: priorities are not
    compared); ``map_priority_sigma``, the map's (truth / map, the same way; 0: the map's
    priorities say nothing of what is there, and a predicted spot is matched by position
    alone); ``priority_log_span``, how widely ln rho spreads over aggregations (eq. 2's
    1..100: ln 100), the likelihood of a measured rho under a candidate whose rho is
    unknown; ``apart_p``: the position's gate inside which two estimates are one spot
    whatever their rho (the vehicle cannot aim between them: `_inside`)."""

    gate_p: float = 0.99
    treated_gate_p: float = 0.999
    extent_m: float = 5.0
    map_sigma_m: float = 3.0
    camera_sigma_m: float = 0.5
    sure_p: float = 0.9
    camera_priority_sigma: float = 0.1
    map_priority_sigma: float = 0.0
    priority_log_span: float = math.log(100.0)
    apart_p: float = 0.5

    def __post_init__(self) -> None:
        for name in ("gate_p", "treated_gate_p", "sure_p", "apart_p"):
            value = getattr(self, name)
            if not 0.0 < value < 1.0:
                raise ValueError(f"{name} must be in (0, 1), got {value!r}")
        for name in ("extent_m", "map_sigma_m", "camera_sigma_m", "camera_priority_sigma",
                     "map_priority_sigma"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {value!r}")

        if not (math.isfinite(self.priority_log_span) and self.priority_log_span > 0):
            raise ValueError(f"priority_log_span must be > 0, got {self.priority_log_span!r}")

    @property
    def gate(self) -> float:
        return chi2_gate(self.gate_p)

    @property
    def treated_gate(self) -> float:
        return chi2_gate(self.treated_gate_p)

    @property
    def apart_gate(self) -> float:
        return chi2_gate(self.apart_p)

    @property
    def feature_gate(self) -> float:
        """The priority's gate (1 degree of freedom) at ``gate_p``."""
        return chi2_gate_1(self.gate_p)

    @property
    def treated_feature_gate(self) -> float:
        return chi2_gate_1(self.treated_gate_p)

    @property
    def extent_var(self) -> float:
        """Per-axis variance between two looks at one aggregation of radius ``extent_m``."""
        return self.extent_m ** 2 / 2.0


DEFAULT_PARAMS = AssociationParams()
# A map whose predicted spots are exactly where their aggregations are, and aggregations that
# are points (the dynamic generator's reefs, `reef_sim.scenarios.dynamic`): only navigation
# and the camera make two estimates of one aggregation differ.
EXACT_MAP = AssociationParams(map_sigma_m=0.5, extent_m=1.0)


def sighting(pos: Sequence[float], nav_sigma_m: float,
             params: AssociationParams = DEFAULT_PARAMS, priority: float | None = None
             ) -> Estimate:
    """A sighting's estimate: the vehicle's navigation sigma (its `NavFix.sigma_m` when it
    saw it) and the camera's, combined; with the rho the camera measured (``priority``),
    uncertain by ``camera_priority_sigma`` (none when that is 0)."""
    return found(pos, math.hypot(nav_sigma_m, params.camera_sigma_m), params, priority)


def found(pos: Sequence[float], sigma_m: float, params: AssociationParams = DEFAULT_PARAMS,
          priority: float | None = None) -> Estimate:
    """A find's estimate: where its finder named it, with the sigma that travels with it (the
    sighting's, already combined), and the rho its camera measured."""
    return Estimate(tuple(float(c) for c in pos), sigma_m,
                    *_rated(priority, params.camera_priority_sigma))


def predicted(pos: Sequence[float], params: AssociationParams = DEFAULT_PARAMS,
              priority: float | None = None) -> Estimate:
    """A predicted spot's estimate: the map's position, uncertain by ``map_sigma_m``; and
    the map's rho, uncertain by ``map_priority_sigma`` (none when that is 0: the map's
    priorities are not held against what the camera measures)."""
    return Estimate(tuple(float(c) for c in pos), params.map_sigma_m,
                    *_rated(priority, params.map_priority_sigma))


def _rated(priority: float | None, sigma: float) -> tuple[float | None, float]:
    """(rho, its sigma) where rho is known and compared (its error is given: > 0), else
    (None, 0)."""
    return (float(priority), sigma) if priority is not None and sigma > 0 else (None, 0.0)


def innovation_var(a: Estimate, b: Estimate, params: AssociationParams = DEFAULT_PARAMS
                   ) -> float:
    """Per-axis variance of ``a - b`` if both are one aggregation."""
    return a.sigma_m ** 2 + b.sigma_m ** 2 + params.extent_var


def distance2(a: Estimate, b: Estimate, params: AssociationParams = DEFAULT_PARAMS) -> float:
    """The squared Mahalanobis distance of ``a - b`` under "one aggregation"."""
    s = innovation_var(a, b, params)
    d2 = (a.xy[0] - b.xy[0]) ** 2 + (a.xy[1] - b.xy[1]) ** 2
    if s <= 0.0:
        return 0.0 if d2 == 0.0 else math.inf
    return d2 / s


def feature2(a: Estimate, b: Estimate) -> float | None:
    """The squared normalised difference of ln rho under "one aggregation" (one degree of
    freedom: both measure the same rho, each with its relative error), or None when either
    does not know its rho."""
    fv = _feature(a, b)
    return None if fv is None else fv[0]


def _feature(a: Estimate, b: Estimate) -> tuple[float, float] | None:
    """`feature2` and the variance of the difference of ln rho, or None."""
    la, lb = a.log_priority, b.log_priority
    if la is None or lb is None:
        return None
    v = a.priority_sigma ** 2 + b.priority_sigma ** 2
    if v <= 0.0:
        return (0.0 if la == lb else math.inf), v
    return (la - lb) ** 2 / v, v


def _inside(a: Estimate, b: Estimate, params: AssociationParams, gate: float,
            feature_gate: float) -> bool:
    """Inside both gates: the position's and, where both know rho, the priority's (each
    at the same probability: a pair of one aggregation passes both with about p**2). Two
    estimates inside ``apart_gate`` are one whatever their rho: a vehicle sent to inject
    one of them treats whichever its true position is nearer (hard reef seed 6, 1 %
    drift: aggregations of rho 51 and 13.7 lie 1 m apart; auv3 named both, then injected
    the first twice)."""
    d2 = distance2(a, b, params)
    if d2 > gate:
        return False
    if d2 <= params.apart_gate:
        return True
    f = feature2(a, b)
    return f is None or f <= feature_gate


def same_aggregation(a: Estimate, b: Estimate,
                     params: AssociationParams = DEFAULT_PARAMS) -> bool:
    """Are ``a`` and ``b`` one aggregation (inside the gates at ``gate_p``)?"""
    return _inside(a, b, params, params.gate, params.feature_gate)


def unlike_priority(a: Estimate, b: Estimate,
                    params: AssociationParams = DEFAULT_PARAMS) -> bool:
    """Do ``a`` and ``b`` both know rho, and differ beyond the priority's gate at
    ``gate_p``? Then they are two aggregations wherever they lie (a look at one, standing
    over the other, tells them apart)."""
    f = feature2(a, b)
    return f is not None and f > params.feature_gate


def could_be_treated(candidate: Estimate, treated: Estimate,
                     params: AssociationParams = DEFAULT_PARAMS) -> bool:
    """Could ``candidate`` be the aggregation ``treated`` (the looser gates at
    ``treated_gate_p``)?"""
    return _inside(candidate, treated, params, params.treated_gate,
                   params.treated_feature_gate)


def _cost(a: Estimate, b: Estimate, params: AssociationParams) -> float:
    """Generalised distance, -2 ln of the likelihood up to a constant shared by every
    candidate: d2 + ln det S (S isotropic 2x2: ln det = 2 ln s); where ``a`` (the sighting)
    knows its rho, plus the priority's: f + ln v + ln 2 pi for a candidate that knows its
    rho, 2 ln(span) for one that does not (the measured ln rho is then anywhere in
    ``priority_log_span``), so candidates with and without a rho compare fairly."""
    s = innovation_var(a, b, params)
    cost = distance2(a, b, params) + (2.0 * math.log(s) if s > 0 else -_INFEASIBLE)
    if a.priority is None:
        return cost
    fv = _feature(a, b)
    if fv is None:
        return cost + 2.0 * math.log(params.priority_log_span)
    f, v = fv
    return cost + f + (math.log(v) + _LN_2PI if v > 0 else 0.0)


def gated(seen: Estimate, candidates: Iterable[tuple[K, Estimate]],
          params: AssociationParams = DEFAULT_PARAMS) -> list[K]:
    """The candidates ``seen`` may be (inside the gate), nearest in generalised distance
    first (ties in the order listed)."""
    inside = [(_cost(seen, est, params), k, key) for k, (key, est) in enumerate(candidates)
              if same_aggregation(seen, est, params)]
    return [key for _, _, key in sorted(inside, key=lambda e: e[:2])]


def posteriors(seen: Estimate, candidates: Iterable[tuple[K, Estimate]],
               params: AssociationParams = DEFAULT_PARAMS) -> list[tuple[K, float]]:
    """Each candidate inside the gate with the chance it is the one ``seen`` is, given that
    it is one of them (Gaussian likelihoods, equal priors: exp(-cost / 2) normalised),
    nearest first."""
    inside = [(_cost(seen, est, params), k, key) for k, (key, est) in enumerate(candidates)
              if same_aggregation(seen, est, params)]
    if not inside:
        return []
    inside.sort(key=lambda e: e[:2])
    low = inside[0][0]
    w = [math.exp(-(c - low) / 2.0) for c, _, _ in inside]
    total = sum(w)
    return [(key, wi / total) for (_, _, key), wi in zip(inside, w)]


def resolve(seen: Estimate, candidates: Iterable[tuple[K, Estimate]],
            params: AssociationParams = DEFAULT_PARAMS) -> tuple[K | None, bool]:
    """(the candidate ``seen`` is, whether that is sure): (None, True) for a new
    aggregation; (nearest, True) when the nearest in the gate has at least ``sure_p`` of the
    chance; (nearest, False) when several are alike (a look must tell which)."""
    post = posteriors(seen, candidates, params)
    if not post:
        return None, True
    return post[0][0], post[0][1] >= params.sure_p


def match(seen: Estimate, candidates: Iterable[tuple[K, Estimate]],
          params: AssociationParams = DEFAULT_PARAMS) -> K | None:
    """The candidate ``seen`` is (nearest in generalised distance among those inside the
    gate), or None: a new aggregation. ``candidates``: (key, estimate) pairs, e.g. the
    predicted spots not known empty (`predicted`) and the known finds (each with its
    finder's sigma); ties go to the first listed.

    Where the map is denser than the gate (predicted spots closer than ~15 m: half of them in
    the paper's preset) a sighting may fall in the gate of several predicted spots: it is
    not new, but which spot it is only a look can tell (the look is at the spot: see
    `gated`, and `docs/search.md` for the rule the agent follows)."""
    inside = gated(seen, candidates, params)
    return inside[0] if inside else None


def assign(seen: Sequence[Estimate], candidates: Sequence[tuple[K, Estimate]],
           params: AssociationParams = DEFAULT_PARAMS) -> list[K | None]:
    """Global nearest neighbour: for each of several sightings made together, the candidate
    it is (each candidate taken at most once, only inside the gate), or None (new). As many
    sightings as possible are matched, then the total generalised distance is least."""
    if not seen:
        return []
    if not candidates:
        return [None] * len(seen)
    from scipy.optimize import linear_sum_assignment

    cost = np.full((len(seen), len(candidates)), _INFEASIBLE)
    for i, s in enumerate(seen):
        for j, (_, est) in enumerate(candidates):
            if same_aggregation(s, est, params):
                cost[i, j] = _cost(s, est, params)  # tens at most: a miss costs far more
    rows, cols = linear_sum_assignment(cost)
    out: list[K | None] = [None] * len(seen)
    for i, j in zip(rows.tolist(), cols.tolist()):
        if cost[i, j] < _INFEASIBLE:
            out[i] = candidates[j][0]
    return out


def aliases(keyed: Sequence[tuple[int, Estimate]],
            params: AssociationParams = DEFAULT_PARAMS) -> dict[int, int]:
    """Group estimates that are one aggregation (`same_aggregation` for every pair at once)
    as connected components: each key that is not the lowest of its group, mapped to that
    lowest key. Order-free: the same estimates give the same groups in any order (every
    vehicle folds the same aliases from the same finds)."""
    keyed = sorted(keyed, key=lambda e: e[0])
    keys = [k for k, _ in keyed]
    parent = {k: k for k in keys}

    def head(k: int) -> int:
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    ests = [e for _, e in keyed]
    xy = np.array([e.xy for e in ests], dtype=float).reshape(-1, 2)
    var = np.array([e.sigma_m ** 2 for e in ests], dtype=float)
    s = var[:, None] + var[None, :] + params.extent_var
    d2 = ((xy[:, None, :] - xy[None, :, :]) ** 2).sum(axis=2)
    inside = d2 <= params.gate * s
    known = np.array([e.log_priority is not None for e in ests], dtype=bool)
    both = known[:, None] & known[None, :]
    if both.any():  # the priority's gate where both know rho, unless too close to aim
        rho = np.array([0.0 if e.log_priority is None else e.log_priority for e in ests])
        rvar = np.array([e.priority_sigma ** 2 for e in ests], dtype=float)
        alike = (rho[:, None] - rho[None, :]) ** 2 <= \
            params.feature_gate * (rvar[:, None] + rvar[None, :])
        inside &= ~both | alike | (d2 <= params.apart_gate * s)
    for i, j in zip(*np.nonzero(np.triu(inside, 1))):
        ha, hb = head(keys[int(i)]), head(keys[int(j)])
        if ha != hb:
            parent[max(ha, hb)] = min(ha, hb)
    return {k: head(k) for k in keys if head(k) != k}


def probably_treated(candidate: Estimate, treated: Iterable[Estimate],
                     params: AssociationParams = DEFAULT_PARAMS) -> bool:
    """Could ``candidate`` be an aggregation already treated (by anyone: each treated
    estimate with the sigma of the vehicle that treated it)? Inside the looser gates
    ``treated_gate_p`` of any of them (`could_be_treated`)."""
    return any(could_be_treated(candidate, t, params) for t in treated)


def fuse(a: Estimate, b: Estimate) -> Estimate:
    """One estimate of an aggregation seen twice: the inverse-variance weighted mean (the
    aggregation's own extent is not reduced by looking twice; the navigation errors are)."""
    w, var = _inverse_variance(a.sigma_m ** 2, b.sigma_m ** 2)
    x = w * a.xy[0] + (1 - w) * b.xy[0]
    y = w * a.xy[1] + (1 - w) * b.xy[1]
    return Estimate((x, y), math.sqrt(var), *_fused_priority(a, b))


def _inverse_variance(va: float, vb: float) -> tuple[float, float]:
    """The weight of the first of two measures of variances ``va`` and ``vb`` and the
    variance of their weighted mean (equal weights, variance 0, for two exact ones)."""
    if va + vb == 0.0:
        return 0.5, 0.0
    return vb / (va + vb), va * vb / (va + vb)


def _fused_priority(a: Estimate, b: Estimate) -> tuple[float | None, float]:
    """The two rho in ln, inverse-variance weighted (the one known if only one is)."""
    la, lb = a.log_priority, b.log_priority
    if la is None or lb is None:
        known = a if la is not None else b
        return known.priority, known.priority_sigma
    w, var = _inverse_variance(a.priority_sigma ** 2, b.priority_sigma ** 2)
    return math.exp(w * la + (1 - w) * lb), math.sqrt(var)
