"""Frames: from a helm's local metres and headings to the scenario's, and back.

The scenario's frame is local metres, x east, y north, z up (depth negative), yaw in degrees
counter-clockwise from east (`fleet_bus.vehicle_port`). A helm has its own local frame:

- MOOS-IvP: ``NAV_X``/``NAV_Y`` metres east/north of the community's ``LatOrigin``/
  ``LongOrigin``; ``NAV_DEPTH`` metres down; ``NAV_HEADING`` degrees clockwise from true
  north (the MOOS-IvP marine convention, uSimMarine and pHelmIvP's ``course`` domain).
- ROS 2 (REP 103, REP 105): x east, y north, z up in an ENU ``map``/``odom`` frame; yaw in
  radians counter-clockwise from x, carried as a quaternion.

Both share the scenario's axes, so a frame is an offset: where the helm's origin lies in the
scenario (``scenario = helm + offset``). When the helm's origin is the scenario's own
(`cotsfleet scenario` puts a geo-referenced scenario's origin at ``geo.origin_m``; a MOOS
community whose LatOrigin/LongOrigin is that point), the offset is zero.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

Point3 = tuple[float, float, float]


@dataclass(frozen=True)
class LocalFrame:
    """``scenario (x, y) = helm (x, y) + (offset_x_m, offset_y_m)``; z is shared."""

    offset_x_m: float = 0.0
    offset_y_m: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.offset_x_m) and math.isfinite(self.offset_y_m)):
            raise ValueError(f"frame offset must be finite, got {self.offset_x_m, self.offset_y_m}")

    def to_scenario(self, x: float, y: float, z: float) -> Point3:
        return (x + self.offset_x_m, y + self.offset_y_m, z)

    def to_helm(self, p: Point3) -> Point3:
        return (p[0] - self.offset_x_m, p[1] - self.offset_y_m, p[2])


def wrap_deg(angle: float) -> float:
    """``angle`` in (-180, 180]."""
    a = math.fmod(angle, 360.0)
    if a <= -180.0:
        a += 360.0
    elif a > 180.0:
        a -= 360.0
    return a


def yaw_from_compass(heading_deg: float) -> float:
    """Yaw (ccw from east, (-180, 180]) of a compass heading (cw from north)."""
    return wrap_deg(90.0 - heading_deg)


def compass_from_yaw(yaw_deg: float) -> float:
    """Compass heading (cw from north, [0, 360)) of a yaw (ccw from east)."""
    return (90.0 - yaw_deg) % 360.0


def yaw_from_quaternion(x: float, y: float, z: float, w: float) -> float:
    """Yaw in degrees (ccw about z, (-180, 180]) of a unit quaternion (ROS ``Quaternion``)."""
    return wrap_deg(math.degrees(math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))))


def quaternion_from_yaw(yaw_deg: float) -> tuple[float, float, float, float]:
    """The quaternion (x, y, z, w) of a pure yaw (roll and pitch zero)."""
    half = math.radians(yaw_deg) / 2.0
    return (0.0, 0.0, math.sin(half), math.cos(half))


def finite_points(points: tuple[Point3, ...]) -> bool:
    return all(len(p) == 3 and all(math.isfinite(float(c)) for c in p) for p in points)
