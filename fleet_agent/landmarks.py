"""The map as a landmark: the offset between the vehicle's dead-reckoned frame and the map's.

A vehicle's navigation (DVL dead reckoning, `reef_sim.navigation`) drifts: its estimate is the
truth plus an error that grows with the distance run. When its camera looks at a predicted
spot it was sent to and shows the COTS there (`fleet_bus.vehicle_port.Looked` with ``pos``),
the difference between where it saw them (in its own frame) and where the map puts the spot
*is* that error, give or take the map's and the camera's errors and the aggregation's extent:
a landmark fix, the idea behind terrain- and feature-aided navigation (Paull et al. 2014, "AUV
navigation and localization: a review", IEEE J. Oceanic Eng. 39(1), sec. V; Kinsey et al.
2006). Only looks: a sighting along the track is matched to a spot *through* the frame, so
where the map missed aggregations near its spots a wrong match moves the frame with a small
variance and then confirms itself (measured on the hard dynamic reefs: duplicate treatments).

`MapFrame` keeps that offset ``o`` (vehicle frame minus map frame, x and y) as a Kalman
estimate with an isotropic variance ``P`` (Bar-Shalom et al. 2001). A landmark ``z`` (sighting
minus spot) of variance ``R`` (the map's, the camera's and a point of an aggregation about its
centre) updates it with gain ``K = P / (P + R)``. A navigation fix of the vehicle (a USBL
fix: its sigma falls by more than moving could make it, `MapFrame._fixed`) moves its frame:
the offset starts again at zero with the vehicle's sigma.

Between landmarks the offset is uncertain by how the error *field* differs from where it was
measured. Dead reckoning's error is mostly biases (`reef_sim.navigation`: heading and scale,
``e(p) = e_r + A (p - p_r)``), so the error at ``p`` differs from the error at the landmark
``p_L`` by ``A (p - p_L)``: per axis ``k |p - p_L|`` with ``k`` the drift rate, plus the random
walk. Hence, after a landmark taken with variance ``P_L`` at ``p_L``::

    P(p) = P_L + max(k^2 |p - p_L|^2, v - v_L)

with ``v`` the vehicle's reported variance (``v - v_L`` its growth since: the random walk's
share and a floor). Growing ``P`` by ``v - v_L`` alone (the vehicle's sigma counts net
displacement from its *start*) is wrong after a landmark far from the start: a vehicle
crossing a patch at a constant distance from home would keep a sigma of a metre while its
error changed by metres; its sightings of known spots would then fail the gate and become
"new" aggregations treated twice. ``k`` is read from what the vehicle reports: its variance
grows as ``k^2 |est - est_r|^2`` (+ the walk) from where it was last reset (the start or a
fix), so ``(v - v_r) / |est - est_r|^2`` bounds ``k^2`` from above; the largest such ratio
over a displacement of at least `RATE_BASE_M` is kept (the walk makes it a little
pessimistic, which errs toward "already treated").

The agent works in the map's frame: its position is the vehicle's minus ``o``, its
sightings too, its sigma ``sqrt(P)``; the waypoints it commands get ``o`` back. With exact
navigation the vehicle's sigma is zero, so ``P`` stays zero and nothing ever moves.

Pure: no I/O, no clock, no randomness.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

Point3 = tuple[float, float, float]


RATE_BASE_M = 100.0  # displacement from a reset before the drift rate is read (see above)
FIX_SLACK_M2 = 0.25  # a fall of the variance this much below what moving explains is a fix


def _d2(a: Sequence[float], b: Sequence[float]) -> float:
    return (float(a[0]) - float(b[0])) ** 2 + (float(a[1]) - float(b[1])) ** 2


class MapFrame:
    """The offset of the vehicle's navigation frame from the map's (see the module)."""

    def __init__(self, enabled: bool = True) -> None:
        self.enabled = enabled
        self.offset = (0.0, 0.0)
        self.var = 0.0  # P: per-axis variance of the offset where the vehicle is now
        self._nav_var = 0.0  # the vehicle's own variance at its last report
        self._pos: tuple[float, float] | None = None  # its last position (vehicle frame)
        # Where the offset was last measured (a landmark, a fix, the start): P_L, p_L, v_L.
        self._at_var, self._at_pos, self._at_nav_var = 0.0, (0.0, 0.0), 0.0
        # Where the vehicle's navigation was last reset, and the drift rate k^2 read since.
        self._reset_pos: tuple[float, float] | None = None
        self._reset_var = 0.0
        self.rate2 = 0.0
        self.fixes = 0  # landmarks taken

    def nav(self, sigma_m: float, pos: Sequence[float] | None = None) -> None:
        """The vehicle reports its own sigma (and where it believes it is): the offset grows
        as uncertain as the error field allows since it was measured; a fall of the sigma
        (the vehicle took a position fix) starts the offset again."""
        v = float(sigma_m) ** 2
        here = (float(pos[0]), float(pos[1])) if pos is not None else self._pos
        fixed = self._fixed(v, here)
        if fixed or self._reset_pos is None and here is not None:
            # A fix, or the first position heard: the drift rate is read from here on. Only
            # a fix measures the offset (at the start it is as uncertain as the vehicle).
            if fixed:
                self.offset = (0.0, 0.0)
                self._at_var, self._at_nav_var = v, v
            self._reset_pos, self._reset_var = here, v
            if here is not None:
                self._at_pos = here
        if here is not None and self._reset_pos is not None:
            base2 = _d2(here, self._reset_pos)
            if base2 >= RATE_BASE_M ** 2:
                self.rate2 = max(self.rate2, (v - self._reset_var) / base2)
        self._nav_var, self._pos = v, here
        moved2 = _d2(here, self._at_pos) if here is not None else 0.0
        self.var = self._at_var + max(self.rate2 * moved2, v - self._at_nav_var, 0.0)

    def _fixed(self, v: float, here: tuple[float, float] | None) -> bool:
        """Did the vehicle take a position fix (its variance fell by more than moving could
        make it)? Its variance counts the net displacement from where it was last reset, so
        it also falls, smoothly, as the vehicle heads back toward that place: at most to
        ``v_r + k^2 (r - step)^2`` in one report (``r``: the distance from there, ``step``:
        how far it moved). Before ``k`` is read, a fall to under half is taken for a fix."""
        if v >= self._nav_var:
            return False
        if self.rate2 <= 0.0 or here is None or self._pos is None or self._reset_pos is None:
            return v < 0.5 * self._nav_var
        r = math.sqrt(_d2(self._pos, self._reset_pos))
        step = math.sqrt(_d2(here, self._pos))
        least = self._reset_var + self.rate2 * max(0.0, r - step) ** 2
        return v < 0.9 * least - FIX_SLACK_M2

    @property
    def sigma_m(self) -> float:
        """The map-frame estimate's per-axis sigma."""
        return math.sqrt(self.var)

    def to_map(self, pos: Sequence[float]) -> Point3:
        ox, oy = self.offset
        return (float(pos[0]) - ox, float(pos[1]) - oy, float(pos[2]) if len(pos) > 2 else 0.0)

    def to_vehicle(self, pos: Sequence[float]) -> Point3:
        ox, oy = self.offset
        return (float(pos[0]) + ox, float(pos[1]) + oy, float(pos[2]) if len(pos) > 2 else 0.0)

    def landmark(self, seen_vehicle: Sequence[float], spot: Sequence[float],
                 var_m2: float) -> bool:
        """The camera saw, at ``seen_vehicle`` (the vehicle's frame), what is surely the
        predicted spot at ``spot`` (the map's), with measurement variance ``var_m2``: the
        Kalman update of the offset. True if the offset moved."""
        if not self.enabled or self.var <= 0.0:
            return False
        zx, zy = seen_vehicle[0] - spot[0], seen_vehicle[1] - spot[1]
        k = self.var / (self.var + var_m2)
        ox, oy = self.offset
        self.offset = (ox + k * (zx - ox), oy + k * (zy - oy))
        self.var = self._at_var = self.var * var_m2 / (self.var + var_m2)
        self._at_pos = (float(seen_vehicle[0]), float(seen_vehicle[1]))
        self._at_nav_var = self._nav_var
        self.fixes += 1
        return True

    def key(self) -> tuple[float, float]:
        """The offset to half a metre: what changes the commanded waypoints."""
        return (round(self.offset[0] * 2) / 2, round(self.offset[1] * 2) / 2)
