"""A vehicle at sea as the replanner takes it: where it is, the battery it has left, and its
current route, all in indices of the `Problem` (vehicle index, task indices).

Ids (scenario vehicle names, task ids) belong to the edges (scenario documents, the wire,
reports); `hfc_core.replan.replan` turns them into these at its edge.
"""

from __future__ import annotations

from dataclasses import dataclass

from hfc_core.model.errors import Point3


@dataclass(frozen=True)
class IndexedVehicle:
    index: int  # the vehicle's index in ``problem.vehicles``
    pos: Point3  # where it is now
    battery_s: float  # battery time left
    speed_mps: float | None = None  # None = the scenario vehicle's speed
    route: tuple[int, ...] = ()  # its current planned route (task indices), for stability
    locked: tuple[int, ...] = ()  # task indices it must keep at the head of its route, in order
