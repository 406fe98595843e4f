"""Where the map's missed aggregations are likely, and what a short search there is worth.

The belief is a Poisson intensity of aggregations not found yet (per square metre, on a grid),
the model of classical search theory (Koopman 1946, "Search and Screening"; Stone 1975,
"Theory of Optimal Search"): unmapped aggregations are scattered around the predicted spots,
more around a spot that holds COTS than around an empty one (COTS aggregate; Pratchett et al.
2017, "Thirty years of research on crown-of-thorns starfish", Diversity 9(4):41), and every
pass of the camera over a place that shows nothing leaves ``1 - p_detect`` of what was
expected there (Bayes' rule for a Poisson field and a detector that misses with that chance).

    lambda(x) = M * sum_i w_i k(x - p_i) * allowed(x) / Z  *  prod_passes (1 - p_detect)

- ``M``: the aggregations the map missed (``per_spot`` times the predicted spots);
- ``w_i``: 1 for a predicted spot seen holding COTS, ``empty_weight`` for one seen empty,
  ``p_cots + (1 - p_cots) empty_weight`` for one not seen yet;
- ``k``: where a missed aggregation lies from its spot: uniform over a ring ``ring_min_m`` to
  ``ring_max_m``, or a 2-D Gaussian of ``spread_m`` per axis;
- ``allowed``: the area, and in a ring model no nearer than ``ring_min_m`` to any predicted
  spot; ``Z`` normalises the prior over it to ``M``.

These are the generator's own knobs (`reef_sim.scenarios.dynamic.DynamicParams`:
``n_unmapped`` or ``unmapped_share``, ``unmapped_spread_m`` or the ring,
``empty_anchor_weight``), so with `BeliefParams.for_generator` the prior *is* the generator's
distribution (`tests/fleet_agent/test_search.py` checks it against its draws). On a real reef
they would be fitted to survey data.

A search pattern (`orbit`, `expanding_square`) starts and ends at its centre, so a planner can
take it as one more spot there: worth ``expected_priority`` (expected finds x the mean priority
of an aggregation) and taking ``duration_s`` plus ``expected_service_s`` (the injections of
what it is expected to find). `worth_searching` is the comparison a vehicle makes between that
and its next known spot: expected priority per second of each, the way there included (the
ratio rule of greedy orienteering heuristics, e.g. Tsiligirides 1984, J. Oper. Res. Soc.
35(9)).

Pure: numpy only, no I/O, no clock, no randomness.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

Point = Sequence[float]  # (x, y) or (x, y, z): only x, y are used


@dataclass(frozen=True)
class BeliefParams:
    """The belief's figures (see the module docstring). ``mean_priority`` and
    ``mean_service_s``: what a missed aggregation is worth and takes to inject, on average
    (eq. 2: U(1, 100) and U(60, 90) s); ``cell_m``: the grid's resolution."""

    per_spot: float = 12 / 90
    ring_min_m: float | None = None
    ring_max_m: float | None = None
    spread_m: float = 50.0
    empty_weight: float = 1.0
    p_cots: float = 0.75
    mean_priority: float = 50.5
    mean_service_s: float = 75.0
    cell_m: float = 10.0

    def __post_init__(self) -> None:
        for name in ("per_spot", "spread_m", "empty_weight", "mean_priority",
                     "mean_service_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {value!r}")
        if not (math.isfinite(self.cell_m) and self.cell_m > 0):
            raise ValueError(f"cell_m must be > 0, got {self.cell_m!r}")
        if not 0.0 <= self.p_cots <= 1.0:
            raise ValueError(f"p_cots must be in 0..1, got {self.p_cots!r}")
        r_in, r_out = self.ring_min_m, self.ring_max_m
        if (r_in is None) != (r_out is None):
            raise ValueError("ring_min_m and ring_max_m go together")
        if r_in is not None and r_out is not None and not 0 <= r_in < r_out:
            raise ValueError(f"the ring needs 0 <= ring_min_m < ring_max_m, got {(r_in, r_out)}")

    @classmethod
    def for_generator(cls, n_predicted: int, n_unmapped: int, *, empty_share: float,
                      spread_m: float = 50.0, ring: tuple[float, float] | None = None,
                      empty_anchor_weight: float = 1.0,
                      priority_range: tuple[float, float] = (1.0, 100.0),
                      service_range_s: tuple[float, float] = (60.0, 90.0),
                      cell_m: float = 10.0) -> "BeliefParams":
        """The belief that is the dynamic generator's distribution for these knobs (plain
        numbers: the agent never imports the simulated world)."""
        return cls(per_spot=n_unmapped / max(1, n_predicted),
                   ring_min_m=None if ring is None else float(ring[0]),
                   ring_max_m=None if ring is None else float(ring[1]),
                   spread_m=float(spread_m), empty_weight=float(empty_anchor_weight),
                   p_cots=1.0 - float(empty_share), mean_priority=sum(priority_range) / 2,
                   mean_service_s=sum(service_range_s) / 2, cell_m=cell_m)

    @property
    def reach_m(self) -> float:
        """How far from its spot a missed aggregation may lie (for the grid's margin)."""
        return float(self.ring_max_m) if self.ring_max_m is not None else 3.0 * self.spread_m


UNKNOWN, PRESENT, EMPTY = 0, 1, 2  # a predicted spot's state, as the belief weighs it


class SearchBelief:
    """The intensity of unfound missed aggregations over ``bounds`` (xmin, xmax, ymin, ymax),
    around the predicted spots ``spots`` ((n, 2) or (n, 3) metres). Tell it what the fleet
    learns (`learn`: a spot seen present or empty) and where cameras have been (`swept`)."""

    def __init__(self, params: BeliefParams, spots: np.ndarray,
                 bounds: tuple[float, float, float, float]) -> None:
        self.params = params
        self.spots = np.asarray(spots, dtype=float).reshape(-1, np.shape(spots)[-1])[:, :2]
        xmin, xmax, ymin, ymax = bounds
        c = params.cell_m
        self.xs = np.arange(xmin + c / 2, xmax, c)
        self.ys = np.arange(ymin + c / 2, ymax, c)
        gx, gy = np.meshgrid(self.xs, self.ys)
        self._cells = np.column_stack([gx.ravel(), gy.ravel()])
        self.cell_area = c * c
        self.state = np.full(len(self.spots), UNKNOWN, dtype=np.int8)
        self.miss = np.ones(len(self._cells))  # chance every pass so far missed a spot here
        n = len(self.spots)
        self._kernel = self._kernels()  # (n, cells): k(x - p_i), allowed
        self.total = params.per_spot * n  # M
        prior_w = params.p_cots + (1 - params.p_cots) * params.empty_weight
        # Z: the prior's mass over the allowed cells, every spot at its prior weight
        self._z = float(prior_w * self._kernel.sum()) * self.cell_area
        self._prior: np.ndarray | None = None

    # -- the prior ----------------------------------------------------------------------------

    def _kernels(self) -> np.ndarray:
        p = self.params
        if not len(self.spots):
            return np.zeros((0, len(self._cells)))
        d = np.linalg.norm(self._cells[None, :, :] - self.spots[:, None, :], axis=2)
        if p.ring_min_m is not None and p.ring_max_m is not None:
            lo, hi = p.ring_min_m, p.ring_max_m
            k = ((d >= lo) & (d <= hi)) / (math.pi * (hi * hi - lo * lo))
            allowed = d.min(axis=0) >= lo  # never nearer than the ring's inside to any spot
            return k * allowed[None, :]
        s2 = p.spread_m ** 2
        return np.exp(-d * d / (2 * s2)) / (2 * math.pi * s2)

    def weights(self) -> np.ndarray:
        """Each predicted spot's weight as an anchor of missed aggregations, by its state."""
        p = self.params
        w = np.full(len(self.spots), p.p_cots + (1 - p.p_cots) * p.empty_weight)
        w[self.state == PRESENT] = 1.0
        w[self.state == EMPTY] = p.empty_weight
        return w

    def prior(self) -> np.ndarray:
        """Intensity per m2 before any pass, given what is known of the spots."""
        if self._prior is None:
            if self._z <= 0:
                self._prior = np.zeros(len(self._cells))
            else:
                self._prior = self.total * (self.weights() @ self._kernel) / self._z
        return self._prior

    def intensity(self) -> np.ndarray:
        """Intensity per m2 of missed aggregations not found yet, per cell (flattened;
        `grid` gives it the grid's shape)."""
        return self.prior() * self.miss

    def grid(self) -> np.ndarray:
        return self.intensity().reshape(len(self.ys), len(self.xs))

    def expected(self, centre: Point, radius_m: float) -> float:
        """Expected unfound missed aggregations within ``radius_m`` of ``centre``."""
        d = np.hypot(self._cells[:, 0] - centre[0], self._cells[:, 1] - centre[1])
        return float(self.intensity()[d <= radius_m].sum() * self.cell_area)

    # -- what the fleet learns ----------------------------------------------------------------

    def learn(self, spot: int, present: bool) -> None:
        """Predicted spot ``spot`` was seen holding COTS (``present``) or empty."""
        new = PRESENT if present else EMPTY
        if self.state[spot] != new:
            self.state[spot] = new
            self._prior = None

    def swept(self, track: Sequence[Point], detect_radius_m: float, p_detect: float) -> None:
        """A camera flew ``track`` (a polyline, one pass per place it came within reach of:
        call it once per leg) and saw nothing new there: what was expected in reach is left
        at ``1 - p_detect`` per pass (a find is the planner's from then on, not the
        belief's)."""
        passes = self.passes(track, detect_radius_m)
        self.miss *= (1.0 - p_detect) ** passes

    def passes(self, track: Sequence[Point], detect_radius_m: float) -> np.ndarray:
        """How many separate passes ``track`` makes within ``detect_radius_m`` of each cell
        (a straight segment meets a disc in one interval; two segments make one pass where
        the corner between them is within reach)."""
        pts = [np.asarray(p[:2], dtype=float) for p in track]
        out = np.zeros(len(self._cells), dtype=np.int64)
        if not pts:
            return out
        if len(pts) == 1:
            return (np.hypot(*(self._cells - pts[0]).T) <= detect_radius_m).astype(np.int64)
        prev_covered = np.zeros(len(self._cells), dtype=bool)
        for k, (a, b) in enumerate(zip(pts[:-1], pts[1:])):
            covered = _segment_distance(self._cells, a, b) <= detect_radius_m
            corner_in = np.hypot(*(self._cells - a).T) <= detect_radius_m if k else \
                np.zeros(len(self._cells), dtype=bool)
            out += covered & ~(prev_covered & corner_in)
            prev_covered = covered
        return out


def _segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    denom = float(ab @ ab)
    pa = points - a
    if denom <= 0.0:
        return np.hypot(pa[:, 0], pa[:, 1])
    f = np.clip(pa @ ab / denom, 0.0, 1.0)
    r = pa - f[:, None] * ab
    return np.hypot(r[:, 0], r[:, 1])


# -- patterns ---------------------------------------------------------------------------------


def ring_middle(p: BeliefParams) -> float:
    """An orbit's default radius: the middle of the belief's ring, or its Gaussian spread."""
    if p.ring_min_m is not None and p.ring_max_m is not None:
        return (p.ring_min_m + p.ring_max_m) / 2
    return p.spread_m


def orbit(centre: Point, radius_m: float, step_deg: float = 30.0) -> list[tuple[float, float]]:
    """A circle of ``radius_m`` around ``centre`` (a polygon of ``step_deg`` sides' angles),
    from the centre and back: the camera sweeps the ring ``radius_m`` +- its reach, where
    the ring model puts missed aggregations."""
    x, y = float(centre[0]), float(centre[1])
    n = max(3, round(360.0 / step_deg))
    angles = [2 * math.pi * k / n for k in range(n + 1)]
    ring = [(x + radius_m * math.cos(a), y + radius_m * math.sin(a)) for a in angles]
    return [(x, y), *ring, (x, y)]


def expanding_square(centre: Point, spacing_m: float, legs: int) -> list[tuple[float, float]]:
    """The search-and-rescue expanding square (IAMSAR Manual vol. II): legs of 1, 1, 2, 2, 3,
    3, ... times ``spacing_m`` turning 90 degrees, from the centre and back to it."""
    x, y = float(centre[0]), float(centre[1])
    out = [(x, y)]
    dirs = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)]
    for k in range(legs):
        dx, dy = dirs[k % 4]
        length = spacing_m * (k // 2 + 1)
        x, y = x + dx * length, y + dy * length
        out.append((x, y))
    out.append((float(centre[0]), float(centre[1])))
    return out


def path_length_m(waypoints: Sequence[Point]) -> float:
    return float(sum(math.dist(a[:2], b[:2]) for a, b in zip(waypoints[:-1], waypoints[1:])))


@dataclass(frozen=True)
class SearchOption:
    """A search pattern as a planner takes it: one more spot at ``centre`` worth
    ``expected_priority`` that takes ``duration_s + expected_service_s`` there."""

    centre: tuple[float, float]
    waypoints: tuple[tuple[float, float], ...]
    duration_s: float  # flying the pattern, centre to centre
    expected_finds: float
    expected_priority: float
    expected_service_s: float  # injecting what it is expected to find

    @property
    def time_s(self) -> float:
        """The time the planner should count for it at its centre."""
        return self.duration_s + self.expected_service_s


def evaluate(belief: SearchBelief, waypoints: Sequence[Point], *, speed_mps: float,
             detect_radius_m: float, p_detect: float) -> SearchOption:
    """What flying ``waypoints`` (a pattern, centre to centre) is expected to reveal: each
    place within reach is seen with ``1 - (1 - p_detect)^passes``."""
    if not speed_mps > 0:
        raise ValueError(f"speed_mps must be > 0, got {speed_mps!r}")
    passes = belief.passes(waypoints, detect_radius_m)
    seen = 1.0 - (1.0 - p_detect) ** passes
    finds = float((belief.intensity() * seen).sum() * belief.cell_area)
    p = belief.params
    centre = (float(waypoints[0][0]), float(waypoints[0][1]))
    return SearchOption(centre, tuple((float(w[0]), float(w[1])) for w in waypoints),
                        path_length_m(waypoints) / speed_mps, finds,
                        finds * p.mean_priority, finds * p.mean_service_s)


def best_search(belief: SearchBelief, centres: Sequence[Point], *, speed_mps: float,
                detect_radius_m: float, p_detect: float,
                radius_m: float | None = None) -> SearchOption | None:
    """The orbit around one of ``centres`` (e.g. the spots just seen holding COTS) expected
    to reveal the most priority per second of its own time; None without centres. The orbit's
    radius defaults to the middle of the belief's ring (or its Gaussian spread)."""
    p = belief.params
    if radius_m is None:
        radius_m = ring_middle(p)
    best, best_rate = None, -1.0
    for c in centres:
        option = evaluate(belief, orbit(c, radius_m), speed_mps=speed_mps,
                          detect_radius_m=detect_radius_m, p_detect=p_detect)
        rate = option.expected_priority / option.time_s if option.time_s > 0 else 0.0
        if rate > best_rate:
            best, best_rate = option, rate
    return best


def worth_searching(search: SearchOption, search_travel_s: float, spot_priority: float,
                    spot_travel_s: float, spot_service_s: float, *,
                    slack_s: float = math.inf, margin: float = 1.0) -> bool:
    """Should the vehicle fly ``search`` (reached in ``search_travel_s``) rather than go to its
    next known spot (``spot_priority``, reached in ``spot_travel_s``, ``spot_service_s`` to
    inject)? Only when the search fits the battery's ``slack_s`` (its whole time, the way there
    included) and its expected priority per second beats the spot's by ``margin`` (1: any
    better). A spot of no priority (none left, or an empty one) loses to any search worth
    something."""
    cost_search = search_travel_s + search.time_s
    if cost_search > slack_s or search.expected_priority <= 0:
        return False
    rate_search = search.expected_priority / cost_search if cost_search > 0 else math.inf
    cost_spot = spot_travel_s + spot_service_s
    rate_spot = spot_priority / cost_spot if cost_spot > 0 else (
        math.inf if spot_priority > 0 else 0.0)
    return rate_search > margin * rate_spot
