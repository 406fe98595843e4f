"""Dynamic scenarios: the map, and the reef it predicts imperfectly.

The prior is drawn exactly as `reef_sim.scenarios.field` (or `reef_sim.scenarios.area`) draws
it, the same calls on the same stream, first, so a dynamic scenario's tasks and map are those
of the static scenario of the same seed. The hidden reef (`reef_sim.truth`) is drawn after it
from the same stream: which predicted spots are empty, the real priority and injection time of
the others, and aggregations the map missed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from reef_sim.cotsmap import ProbabilityMap, on_land
from reef_sim.navigation import DEFAULT_NAVIGATION
from reef_sim.scenarios.area import AreaParams, generate_area_doc
from reef_sim.scenarios.field import PAPER_PRESET, GeneratorParams, generate_doc
from reef_sim.scenarios.seabed import boundary_distance_m, seabed_depth_m
from reef_sim.truth import DEFAULT_LOOK_RADIUS_M, Reef, TruthSpot

DEFAULT_UNMAPPED_PER_90 = 12  # unmapped aggregations per 90 predicted spots (the paper's count)


@dataclass(frozen=True)
class DynamicParams:
    """A scenario drawn as the paper does (``base``: the eq. 1 field, or a large area) and the
    hidden reef it predicts: ``empty_share`` of the predicted spots hold nothing; the others
    hold a real priority ``predicted * exp(e * z - e**2 / 2)``, z ~ N(0, 1), e =
    ``priority_error`` (lognormal, right on average); ``n_unmapped`` aggregations the map missed
    (or ``unmapped_share`` times the predicted spots, rounded) lie at a Gaussian offset
    (``unmapped_spread_m`` per axis) from a predicted spot chosen at random, in the water and
    the area, with eq. (2)'s priority. With ``unmapped_min_m`` and ``unmapped_max_m`` they lie
    instead in the ring between them around the chosen spot (uniform over its area), never
    nearer than ``unmapped_min_m`` to any predicted spot. ``empty_anchor_weight``: how likely
    an empty predicted spot is to be the one chosen, against 1 for a spot that holds COTS (1:
    any alike; less: COTS gather around live aggregations). Real injection times are drawn
    U(``service_range_s``) (eq. 2; None: the predicted one). ``detect_radius_m``,
    ``p_detect``, ``inspect_s`` and ``look_radius_m`` are the simulated camera's (see
    `reef_sim.truth.Reef`).

    The defaults draw what they always drew: the new knobs at their defaults take no draw
    of their own and change none."""

    base: GeneratorParams | AreaParams = PAPER_PRESET
    empty_share: float = 0.25
    priority_error: float = 0.3
    n_unmapped: int | None = None  # None: 12 per 90 predicted spots (12 for the paper preset)
    unmapped_spread_m: float = 50.0
    service_range_s: tuple[float, float] | None = (60.0, 90.0)
    detect_radius_m: float = 25.0
    p_detect: float = 0.9
    inspect_s: float = 20.0
    unmapped_share: float | None = None  # None: n_unmapped (or 12 per 90 predicted spots)
    unmapped_min_m: float | None = None  # with unmapped_max_m: a ring instead of a Gaussian
    unmapped_max_m: float | None = None
    empty_anchor_weight: float = 1.0
    look_radius_m: float = DEFAULT_LOOK_RADIUS_M

    def __post_init__(self) -> None:
        if not isinstance(self.base, (GeneratorParams, AreaParams)):
            raise ValueError(f"base must be GeneratorParams or AreaParams, got {self.base!r}")
        if not (math.isfinite(self.empty_share) and 0.0 <= self.empty_share <= 1.0):
            raise ValueError(f"empty_share must be in 0..1, got {self.empty_share}")
        if not (math.isfinite(self.priority_error) and self.priority_error >= 0):
            raise ValueError(f"priority_error must be >= 0, got {self.priority_error}")
        if self.n_unmapped is not None and (isinstance(self.n_unmapped, bool)
                                            or not isinstance(self.n_unmapped, int)
                                            or self.n_unmapped < 0):
            raise ValueError(f"n_unmapped must be an integer >= 0, got {self.n_unmapped}")
        if not (math.isfinite(self.unmapped_spread_m) and self.unmapped_spread_m > 0):
            raise ValueError(f"unmapped_spread_m must be positive, got {self.unmapped_spread_m}")
        if self.service_range_s is not None:
            lo, hi = self.service_range_s
            if not (0 <= lo <= hi and math.isfinite(hi)):
                raise ValueError(f"service_range_s needs 0 <= lo <= hi, got {(lo, hi)}")
        for name in ("detect_radius_m", "inspect_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be >= 0, got {value}")
        if not (math.isfinite(self.p_detect) and 0.0 <= self.p_detect <= 1.0):
            raise ValueError(f"p_detect must be in 0..1, got {self.p_detect}")
        if self.unmapped_share is not None:
            if not (math.isfinite(self.unmapped_share) and self.unmapped_share >= 0):
                raise ValueError(f"unmapped_share must be >= 0, got {self.unmapped_share}")
            if self.n_unmapped is not None:
                raise ValueError("give n_unmapped or unmapped_share, not both")
        r_in, r_out = self.unmapped_min_m, self.unmapped_max_m
        if (r_in is None) != (r_out is None):
            raise ValueError("unmapped_min_m and unmapped_max_m go together")
        if r_in is not None and r_out is not None and not (
                math.isfinite(r_in) and math.isfinite(r_out) and 0 <= r_in < r_out):
            raise ValueError(f"unmapped ring needs 0 <= unmapped_min_m < unmapped_max_m, got "
                             f"{(r_in, r_out)}")
        if not (math.isfinite(self.empty_anchor_weight) and self.empty_anchor_weight >= 0):
            raise ValueError(f"empty_anchor_weight must be >= 0, got "
                             f"{self.empty_anchor_weight}")
        if not (math.isfinite(self.look_radius_m) and self.look_radius_m >= 0):
            raise ValueError(f"look_radius_m must be >= 0, got {self.look_radius_m}")

    @property
    def unmapped_count(self) -> int:
        if self.n_unmapped is not None:
            return self.n_unmapped
        if self.unmapped_share is not None:
            return math.floor(self.unmapped_share * self.base.n_tasks + 0.5)  # halves up
        return round(self.base.n_tasks * DEFAULT_UNMAPPED_PER_90 / 90)


def _water(doc: dict[str, Any], base: GeneratorParams | AreaParams) -> tuple[
        tuple[float, float, float, float], list[np.ndarray]]:
    """The area's bounds and every polygon a spot may not lie in (map land, forbidden)."""
    side = base.size_m if isinstance(base, GeneratorParams) else base.area_m
    land = [np.asarray(p, dtype=float) for p in doc.get("cots_map", {}).get("land", [])]
    land += [np.asarray(p, dtype=float) for p in doc.get("forbidden", [])]
    return (0.0, side, 0.0, side), land


def _unmapped_xy(anchors: np.ndarray, count: int, params: DynamicParams, doc: dict[str, Any],
                 rng: np.random.Generator, weights: np.ndarray | None = None) -> np.ndarray:
    """``(count, 2)`` positions near ``anchors``, chosen in proportion to ``weights`` (None:
    alike): a Gaussian offset, or a point of the ring (see `DynamicParams`); redrawn until
    each lies in the area and at least a metre from any land (so rounding never puts one
    ashore), and in a ring, no nearer than its inner radius to any predicted spot."""
    base = params.base
    if count and not len(anchors):
        raise ValueError("no predicted spot to put the unmapped aggregations near")
    (xmin, xmax, ymin, ymax), land = _water(doc, base)
    lo, hi = params.unmapped_min_m, params.unmapped_max_m
    out = np.empty((0, 2))
    for _ in range(1000):
        if len(out) >= count:
            break
        need = count - len(out)
        # The old draws, call for call, for the old knobs (a seed's reef stays the same).
        chosen = rng.integers(len(anchors), size=need) if weights is None else rng.choice(
            len(anchors), size=need, p=weights)
        if lo is None or hi is None:
            xy = anchors[chosen] + rng.normal(0.0, params.unmapped_spread_m, size=(need, 2))
        else:
            r = np.sqrt(rng.uniform(lo ** 2, hi ** 2, size=need))
            theta = rng.uniform(0.0, 2.0 * math.pi, size=need)
            xy = anchors[chosen] + np.column_stack([r * np.cos(theta), r * np.sin(theta)])
        x, y = xy[:, 0], xy[:, 1]
        ok = (x >= xmin) & (x <= xmax) & (y >= ymin) & (y <= ymax)
        if land:
            ok &= ~on_land(land, x, y)
            ok &= np.min([boundary_distance_m(x, y, poly) for poly in land], axis=0) >= 1.0
        if lo is not None:
            nearest = np.min(np.linalg.norm(xy[:, None, :] - anchors[None, :, :], axis=2),
                             axis=1)
            ok &= nearest >= lo
        out = np.vstack([out, xy[ok]])
    if len(out) < count:
        raise ValueError(f"could not place {count} unmapped aggregations in the water near "
                         "the predicted spots (a smaller unmapped_spread_m or ring?)")
    return out[:count]


def _depth_m(doc: dict[str, Any], base: GeneratorParams | AreaParams, xy: np.ndarray
             ) -> np.ndarray:
    """Positive seabed depth at ``xy``, as the predicted spots got theirs."""
    if isinstance(base, AreaParams) or "cots_map" not in doc:
        return np.full(len(xy), base.seabed.deep_m)
    cots_map = ProbabilityMap.from_dict(doc["cots_map"])
    return seabed_depth_m(cots_map, xy[:, 0], xy[:, 1], base.seabed)


def draw_truth(doc: dict[str, Any], params: DynamicParams, rng: np.random.Generator
               ) -> dict[str, Any]:
    """The hidden reef of a drawn scenario ``doc`` (its ``truth`` section; see DynamicParams).
    Draws are made for every predicted spot whatever the knobs, so the empty spots at a share
    include those at any smaller share, and the priority error only scales the same draws."""
    tasks = doc["tasks"]
    n = len(tasks)
    order = rng.permutation(n)
    empty = set(order[: math.floor(params.empty_share * n + 0.5)].tolist())  # halves round up
    z = rng.standard_normal(n)
    e = params.priority_error
    factor = np.exp(e * z - 0.5 * e * e)
    service_range = params.service_range_s
    real_service = rng.uniform(*service_range, size=n) if service_range else None
    spots = [TruthSpot(tuple(t["pos"]), round(float(t["priority"] * factor[i]), 2),
                       round(float(real_service[i]) if real_service is not None
                             else float(t["service_s"]), 2), i)
             for i, t in enumerate(tasks) if i not in empty]
    m = params.unmapped_count
    base = params.base
    priority = rng.uniform(*base.priority_range, size=m)
    if service_range:
        service = rng.uniform(*service_range, size=m)
    elif base.service_s is not None:
        service = np.full(m, base.service_s)
    else:
        service = rng.uniform(*base.service_range_s, size=m)
    anchors = np.array([t["pos"][:2] for t in tasks], dtype=float).reshape(-1, 2)
    weights = None
    if params.empty_anchor_weight != 1.0:
        weights = np.array([params.empty_anchor_weight if i in empty else 1.0
                            for i in range(n)])
        if not weights.sum() > 0:
            raise ValueError("every predicted spot is empty and empty_anchor_weight is 0: no "
                             "spot to put the unmapped aggregations near")
        weights = weights / weights.sum()
    xy = _unmapped_xy(anchors, m, params, doc, rng, weights)
    depth = _depth_m(doc, base, xy)
    spots += [TruthSpot((round(float(x), 2), round(float(y), 2), -round(float(d), 2)),
                        round(float(rho), 2), round(float(t), 2), None)
              for (x, y), d, rho, t in zip(xy, depth, priority, service)]
    reef = Reef(params.detect_radius_m, params.p_detect, params.inspect_s, tuple(spots),
                params.look_radius_m)
    return reef.to_dict()


def generate_dynamic_doc(params: DynamicParams, rng: np.random.Generator) -> dict[str, Any]:
    """A scenario drawn as `generate_doc` (or `generate_area_doc` for an `AreaParams` base)
    draws it, the same draws first, plus its hidden ``truth`` (see `DynamicParams`)."""
    base = params.base
    doc = generate_doc(base, rng) if isinstance(base, GeneratorParams) else generate_area_doc(
        base, rng)
    doc["truth"] = draw_truth(doc, params, rng)
    return doc


DYNAMIC_PRESET = DynamicParams()  # the paper's field with the defaults: the demo's scenario


def dynamic_preset_doc(seed: int) -> dict[str, Any]:
    """`paper_preset_doc(seed)` (the same tasks and map) plus a hidden reef with the defaults
    of `DynamicParams` and the default navigation error (`reef_sim.navigation`); vehicles
    ``auv1..auv3``: what ``cotsfleet scenario --paper --dynamic --seed S`` writes."""
    doc = generate_dynamic_doc(DYNAMIC_PRESET, np.random.default_rng(seed))
    doc["navigation"] = DEFAULT_NAVIGATION.to_dict()
    doc["name"] = f"paper-dynamic-seed{seed}"
    return doc
