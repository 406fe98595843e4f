"""The map as a landmark: the offset between the vehicle's dead-reckoned frame and the map's.

A vehicle's navigation (DVL dead reckoning, `reef_sim.navigation`) drifts: its estimate is the
truth plus an error that grows with the distance run. When its camera sees an aggregation
that is surely a predicted spot (`fleet_agent.association.resolve`), the difference between
where it saw it (in its own frame) and where the map puts it *is* that error, give or take the
map's and the camera's errors and the aggregation's extent: a landmark fix, the idea behind
terrain- and feature-aided navigation (Paull et al. 2014, "AUV navigation and localization: a
review", IEEE J. Oceanic Eng. 39(1), sec. V; Kinsey et al. 2006).

`MapFrame` keeps that offset ``o`` (vehicle frame minus map frame, x and y) as a Kalman
estimate with an isotropic variance ``P`` (Bar-Shalom et al. 2001): between fixes the offset
is uncertain by what the vehicle's own navigation sigma grew since the last one (the drift is
the offset's process noise); a landmark ``z`` (sighting minus spot) of variance ``R`` (the
map's, the camera's and a point of an aggregation about its centre) updates it with gain
``K = P / (P + R)``. A navigation fix of the vehicle (its sigma falls: a USBL fix) moves its
frame: the offset starts again at zero with the vehicle's sigma.

The agent works in the map's frame: its position is the vehicle's minus ``o``, its
sightings too, its sigma ``sqrt(P)``; the waypoints it commands get ``o`` back. With exact
navigation the vehicle's sigma is zero, so ``P`` stays zero and nothing ever moves.

Pure: no I/O, no clock, no randomness.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

Point3 = tuple[float, float, float]


class MapFrame:
    """The offset of the vehicle's navigation frame from the map's (see the module)."""

    def __init__(self, enabled: bool = True) -> None:
        self.enabled = enabled
        self.offset = (0.0, 0.0)
        self.var = 0.0  # P: per-axis variance of the offset
        self._nav_var = 0.0  # the vehicle's own variance when P was last brought up to date
        self.fixes = 0  # landmarks taken

    def nav(self, sigma_m: float) -> None:
        """The vehicle reports its own sigma: the offset grows as uncertain as the drift
        since; a fall (the vehicle took a position fix) starts the offset again."""
        v = float(sigma_m) ** 2
        if v < self._nav_var:
            self.offset, self.var = (0.0, 0.0), v
        else:
            self.var += v - self._nav_var
        self._nav_var = v

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
        self.var = self.var * var_m2 / (self.var + var_m2)
        self.fixes += 1
        return True

    def key(self) -> tuple[float, float]:
        """The offset to half a metre: what changes the commanded waypoints."""
        return (round(self.offset[0] * 2) / 2, round(self.offset[1] * 2) / 2)
