"""The simulated vehicle's navigation: a dead-reckoning estimate that drifts from the truth.

An AUV under water dead-reckons: it integrates the velocity its Doppler velocity log (DVL)
measures over the ground, rotated by the heading of its compass or inertial unit. Its error
comes mostly from two biases that stay put over a dive (Kinsey, Eustice & Whitcomb 2006, "A
survey of underwater vehicle navigation: recent advances and new challenges", IFAC MCMC; Paull,
Saeedi, Seto & Li 2014, "AUV navigation and localization: a review", IEEE J. Oceanic Eng.
39(1)): a heading bias ``b`` (radians) turns every metre run, so a straight run of ``L`` metres
ends ``b L`` off its track; a scale-factor error ``s`` of the measured speed ends it ``s L``
short or long. Manufacturers therefore quote DVL-aided navigation in *percent of distance
travelled* (0.1 % for a navigation-grade INS with DVL, about 1 % for a DVL with an AHRS
heading; Jalving, Gade et al., "Integrated inertial navigation systems for AUVs", and the
figures in Paull et al. 2014). On top, the DVL's ping noise adds a random walk that grows
with the square root of the distance.

The model, per vehicle (x, y only: depth comes from a pressure sensor and is taken as exact)::

    e(p, D) = e_r + A (p - p_r) + W(D) - W(D_r),      A = [[s, -b], [b, s]]

with ``p`` the true position, ``D`` the odometer, ``(p_r, D_r, e_r)`` where the estimate was last
reset (the start, or a fix), ``s, b ~ N(0, (drift_pct / 100)^2)`` drawn once per vehicle and
``W`` a random walk in distance, ``walk_m_per_sqrt_km`` per axis after 1 km, drawn per metre.
The estimate is ``p + e``. Since ``s`` and ``b`` are independent with the same spread,
``A d`` is an isotropic Gaussian of per-axis sigma ``drift_pct % x |d|``: a straight run of
``L`` metres is off by ``drift_pct`` % of ``L`` (1-sigma, per axis), the convention of the
specifications. The vehicle reports that covariance (what its filter would carry for this
model): ``sigma^2 = sigma_r^2 + (drift_pct / 100)^2 |est - est_r|^2 + walk^2 (D - D_r)``, the
net displacement taken from its own estimate.

Fixes (optional): an ultra-short-baseline (USBL) fix every ``fix_period_s`` seconds of
mission time, the truth plus N(0, ``fix_sigma_m``^2) per axis (USBL accuracy is quoted in
percent of slant range, a metre or two at the ranges of a reef patch; Paull et al. 2014). The
estimate takes it as a Kalman update of an isotropic covariance (Bar-Shalom, Li & Kirubarajan
2001, "Estimation with Applications to Tracking and Navigation", ch. 5): gain ``K = P / (P +
R)``, error ``(1 - K) e + K nu``, variance ``P R / (P + R)``; the biases stay (they are the
sensors'), the drift starts again from the fix. The start is a fix too: a GPS position at the
surface, ``start_sigma_m``; so is every return to the surface (`surface_fix`: the vehicle's
GPS takes a position whenever it is there, the same accuracy, the draw keyed by the time).

The camera measures the offset from the vehicle to what it sees; that offset has its own small
error (``camera_sigma_m`` per axis): a sighting reported at ``estimate + offset`` is the true
aggregation moved by the navigation error at the moment of the sighting, plus that.

Everything is seeded from the mission seed and the vehicle's index
(``SeedSequence([NAV_STREAM, seed]).spawn(n)[index]``, written as the child's spawn key so the
fleet's size does not matter), and every draw is keyed by what it is for (the biases, the
random walk's block of metres, the fix's number, the sighting's spot and pass), so what a
vehicle's navigation does never depends on how often it is polled, nor on a restart.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, Mapping

import numpy as np

from hfc_core.model.errors import Point3, ScenarioError

NAV_STREAM = 0x4E41  # keeps the navigation's draws apart from every other seeded stream
WALK_BLOCK_M = 1024  # the random walk is drawn per metre, this many metres per keyed block
_BIASES, _WALK, _FIXES, _CAMERA, _START, _SURFACE = range(6)  # child streams of one vehicle's seed


def _number(raw: Mapping[str, Any], name: str, default: float | None) -> float | None:
    value = raw.get(name, default)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or \
            not math.isfinite(float(value)):
        raise ScenarioError(f"navigation.{name}: expected a finite number, got {value!r}")
    if float(value) < 0:
        raise ScenarioError(f"navigation.{name}: must be >= 0, got {value!r}")
    return float(value)


def _given(raw: Mapping[str, Any], name: str, default: float) -> float:
    """A field that must be a number (only ``fix_period_s`` may be null)."""
    value = _number(raw, name, default)
    if value is None:
        raise ScenarioError(f"navigation.{name}: expected a finite number, got null")
    return value


@dataclass(frozen=True)
class NavigationParams:
    """The scenario's ``navigation`` section (see the module docstring and docs/scenario.md).

    ``drift_pct``: 1-sigma error per axis in percent of the distance run straight since the
    last fix (heading bias and speed scale error, each N(0, drift_pct / 100)).
    ``walk_m_per_sqrt_km``: the DVL noise's random walk, per axis after 1 km.
    ``start_sigma_m``: a GPS fix at the surface (the dive's start, and every return there).
    ``fix_period_s``: a USBL fix this often (None: none), ``fix_sigma_m`` its accuracy.
    ``camera_sigma_m``: the error of the offset the camera measures to an aggregation."""

    drift_pct: float = 1.0
    walk_m_per_sqrt_km: float = 0.5
    start_sigma_m: float = 1.0
    fix_period_s: float | None = None
    fix_sigma_m: float = 2.0
    camera_sigma_m: float = 0.5

    def __post_init__(self) -> None:
        doc = asdict(self)
        for name in doc:
            _number(doc, name, None)
        if self.fix_period_s is not None and not self.fix_period_s > 0:
            raise ScenarioError(f"navigation.fix_period_s: must be > 0 or null, got "
                                f"{self.fix_period_s!r}")

    @property
    def drift(self) -> float:
        """The biases' spread as a fraction (1 % -> 0.01)."""
        return self.drift_pct / 100.0

    @property
    def walk_m2_per_m(self) -> float:
        """The random walk's variance per axis per metre run."""
        return self.walk_m_per_sqrt_km ** 2 / 1000.0

    def to_dict(self) -> dict[str, Any]:
        """The scenario's ``navigation`` section (`navigation_from_doc` reads it back)."""
        return asdict(self)


DEFAULT_NAVIGATION = NavigationParams()  # what `cotsfleet scenario --dynamic` writes


def navigation_from_doc(doc: Mapping[str, Any]) -> NavigationParams | None:
    """The scenario's navigation model, or None without a ``navigation`` section (exact
    navigation: the vehicle knows where it is). Raises `ScenarioError` naming the field."""
    if not isinstance(doc, Mapping) or doc.get("navigation") is None:
        return None
    raw = doc["navigation"]
    if not isinstance(raw, Mapping):
        raise ScenarioError(f"navigation: expected an object, got {type(raw).__name__}")
    known = set(DEFAULT_NAVIGATION.to_dict())
    unknown = sorted(set(raw) - known)
    if unknown:
        raise ScenarioError(f"navigation: unknown field(s) {', '.join(unknown)}; known: "
                            f"{', '.join(sorted(known))}")
    d = DEFAULT_NAVIGATION
    return NavigationParams(
        drift_pct=_given(raw, "drift_pct", d.drift_pct),
        walk_m_per_sqrt_km=_given(raw, "walk_m_per_sqrt_km", d.walk_m_per_sqrt_km),
        start_sigma_m=_given(raw, "start_sigma_m", d.start_sigma_m),
        fix_period_s=_number(raw, "fix_period_s", d.fix_period_s),  # null: no fixes
        fix_sigma_m=_given(raw, "fix_sigma_m", d.fix_sigma_m),
        camera_sigma_m=_given(raw, "camera_sigma_m", d.camera_sigma_m))


def vehicle_seed(seed: int, index: int) -> np.random.SeedSequence:
    """Vehicle ``index``'s navigation seed: ``SeedSequence([NAV_STREAM, seed]).spawn(n)[index]``
    for any fleet size ``n``."""
    return np.random.SeedSequence([NAV_STREAM, int(seed) & 0xFFFFFFFFFFFFFFFF],
                                  spawn_key=(int(index),))


def _rng(root: np.random.SeedSequence, *key: int) -> np.random.Generator:
    """A generator keyed by ``key`` under ``root`` (independent of every other key)."""
    return np.random.default_rng(np.random.SeedSequence(root.entropy,
                                                        spawn_key=(*root.spawn_key, *key)))


class DeadReckoning:
    """One vehicle's navigation estimate as a function of where it really is and how far it
    has run (see the module docstring). ``start``: the true position it starts from (a
    surface fix of ``start_sigma_m``), at odometer ``odometer_m``."""

    def __init__(self, params: NavigationParams, seed: int, index: int, start: Point3,
                 odometer_m: float = 0.0) -> None:
        self.params = params
        self.root = vehicle_seed(seed, index)
        scale, heading = _rng(self.root, _BIASES).normal(0.0, params.drift, size=2)
        self.scale, self.heading_rad = float(scale), float(heading)
        self._a = np.array([[self.scale, -self.heading_rad], [self.heading_rad, self.scale]])
        self._inv = np.linalg.inv(np.eye(2) + self._a)
        self._walk: list[np.ndarray] = []  # per block: W at metres 0..WALK_BLOCK_M (2 axes)
        e0 = _rng(self.root, _START).normal(0.0, params.start_sigma_m, size=2)
        self._reset(np.asarray(start[:2], float), float(odometer_m), e0,
                    params.start_sigma_m ** 2)
        self.fixes = 0  # fixes taken

    # -- the error --------------------------------------------------------------------------

    def walk(self, distance_m: float) -> np.ndarray:
        """The random walk W at odometer ``distance_m`` (linear between whole metres)."""
        d = max(0.0, float(distance_m))
        k = int(d // WALK_BLOCK_M)
        while len(self._walk) <= k:
            b = len(self._walk)
            origin = self._walk[-1][-1] if self._walk else np.zeros(2)
            step = _rng(self.root, _WALK, b).normal(
                0.0, math.sqrt(self.params.walk_m2_per_m), size=(WALK_BLOCK_M, 2))
            self._walk.append(origin + np.vstack([np.zeros(2), np.cumsum(step, axis=0)]))
        block, rest = self._walk[k], d - k * WALK_BLOCK_M
        i = min(int(rest), WALK_BLOCK_M - 1)
        f = rest - i
        return block[i] + (block[i + 1] - block[i]) * f

    def error(self, pos: Point3, odometer_m: float) -> tuple[float, float]:
        """The estimate's error (x, y), the vehicle really at ``pos``, odometer ``odometer_m``."""
        p = np.asarray(pos[:2], float)
        e = self._e_r + self._a @ (p - self._p_r) + self.walk(odometer_m) - self._w_r
        return float(e[0]), float(e[1])

    def estimate(self, pos: Point3, odometer_m: float) -> Point3:
        """Where the vehicle believes it is (depth exact)."""
        ex, ey = self.error(pos, odometer_m)
        return (pos[0] + ex, pos[1] + ey, pos[2])

    def sigma_m(self, pos: Point3, odometer_m: float) -> float:
        """The 1-sigma per-axis uncertainty the vehicle reports with that estimate."""
        est = np.asarray(self.estimate(pos, odometer_m)[:2])
        run = max(0.0, float(odometer_m) - self._d_r)
        var = self._var_r + self.params.drift ** 2 * float(np.sum((est - self._est_r) ** 2)) \
            + self.params.walk_m2_per_m * run
        return math.sqrt(var)

    def heading_deg(self) -> float:
        """The heading bias, degrees (the yaw the vehicle reports is off by it)."""
        return math.degrees(self.heading_rad)

    # -- steering in the estimate's frame ---------------------------------------------------

    def to_true(self, target: Point3, origin: Point3, odometer_m: float) -> Point3:
        """Where the vehicle really ends when it flies straight from ``origin`` (true, at
        odometer ``odometer_m``) until its estimate reads ``target``: the solution p of
        ``p + e(p, D(p)) = target``, D(p) the odometer at the end of the straight run."""
        w = np.asarray(target[:2], float)
        base = w - self._e_r + self._a @ self._p_r + self._w_r
        p = self._inv @ (base - self.walk(odometer_m))
        for _ in range(4):  # the random walk moves with the run's length: a few rounds settle it
            d = odometer_m + math.dist(origin, (p[0], p[1], target[2]))
            p = self._inv @ (base - self.walk(d))
        return (float(p[0]), float(p[1]), float(target[2]))

    # -- fixes ------------------------------------------------------------------------------

    def next_fix_s(self, after_s: float) -> float:
        """When the next USBL fix comes, strictly after mission time ``after_s`` (inf: none)."""
        period = self.params.fix_period_s
        if period is None:
            return math.inf
        return (math.floor(after_s / period) + 1) * period

    def fix(self, t_s: float, pos: Point3, odometer_m: float) -> None:
        """A USBL fix at mission time ``t_s`` with the vehicle really at ``pos``: the Kalman
        update of the estimate, the drift starting again from here."""
        n = round(t_s / self.params.fix_period_s) if self.params.fix_period_s else self.fixes
        self._update(pos, odometer_m, self.params.fix_sigma_m, _rng(self.root, _FIXES, int(n)))

    def surface_fix(self, t_s: float, pos: Point3, odometer_m: float) -> None:
        """A GPS fix at the surface at mission time ``t_s`` (``start_sigma_m``, as the dive's
        start), keyed by the time to the millisecond: the same surfacing draws the same fix
        however the vehicle is polled."""
        self._update(pos, odometer_m, self.params.start_sigma_m,
                     _rng(self.root, _SURFACE, int(round(t_s * 1000.0))))

    def _update(self, pos: Point3, odometer_m: float, sigma_m: float,
                rng: np.random.Generator) -> None:
        """The Kalman update of a fix of per-axis accuracy ``sigma_m`` (module docstring)."""
        e = np.asarray(self.error(pos, odometer_m))
        prior = self.sigma_m(pos, odometer_m) ** 2
        r = sigma_m ** 2
        nu = rng.normal(0.0, sigma_m, size=2)
        gain = prior / (prior + r) if prior + r > 0 else 1.0
        self._reset(np.asarray(pos[:2], float), float(odometer_m), (1 - gain) * e + gain * nu,
                    prior * r / (prior + r) if prior + r > 0 else 0.0)
        self.fixes += 1

    def _reset(self, p: np.ndarray, odometer_m: float, e: np.ndarray, var: float) -> None:
        self._p_r, self._d_r, self._e_r, self._var_r = p, odometer_m, np.asarray(e, float), var
        self._w_r = self.walk(odometer_m)
        self._est_r = p + self._e_r

    # -- the camera -------------------------------------------------------------------------

    def camera_error(self, spot: int, pass_no: int) -> tuple[float, float]:
        """The error of the offset the camera measured to truth spot ``spot`` on pass
        ``pass_no`` (x, y)."""
        ex, ey = _rng(self.root, _CAMERA, spot, pass_no).normal(
            0.0, self.params.camera_sigma_m, size=2)
        return float(ex), float(ey)
