"""The states a vehicle reports and the states a vehicle gives its peers, named once.

Both are `StrEnum`s: a member is its string (equal to it, hashed like it, packed by msgpack
and written by json as it), so the bus records, the journal and report.json carry exactly the
words they carried before these names existed (``"transit"``, ``"lost"``...).
"""

from __future__ import annotations

from enum import StrEnum


class VehicleState(StrEnum):
    """A vehicle's state as its agent reports it (`fleet_bus.telemetry.Status.state`) and the
    dashboard and the report show it."""

    TRANSIT = "transit"
    INJECTING = "injecting"
    RETURNING = "returning"
    HOME = "home"
    ABORTED = "aborted"
    DEAD = "dead"  # the mission runner's word for an agent killed and not restarted


FINAL_STATES = (VehicleState.HOME, VehicleState.ABORTED, VehicleState.DEAD)  # left the mission
STOPPED_STATES = (VehicleState.ABORTED, VehicleState.DEAD)  # its route is abandoned


class PeerState(StrEnum):
    """What a vehicle makes of a peer (`fleet_bus.telemetry.Status.peers`)."""

    ALIVE = "alive"
    SUSPECT = "suspect"
    LOST = "lost"
    ABORTED = "aborted"
    HOME = "home"
