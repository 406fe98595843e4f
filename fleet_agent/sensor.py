"""The camera's figures: what an agent may know of the instrument its vehicle carries.

A look at a spot takes ``inspect_s`` and sees the seabed within ``look_radius_m`` of where the
vehicle really is; along the track an aggregation within
``detect_radius_m`` is seen with probability ``p_detect`` per pass. The camera itself (on a
real vehicle, its detector; in emulation, `reef_sim.camera` on the hidden reef) reports
through the vehicle port (`fleet_bus.vehicle_port`: `Looked`, `Sighted`): the decision logic
never reads the reef, only these figures, to plan looks and to judge what a sighting is.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Camera:
    """The camera's figures, known to the vehicle that carries it (never the reef)."""

    detect_radius_m: float
    p_detect: float
    inspect_s: float
    look_radius_m: float  # the look's footprint around the true position
