"""Plain-data drawing instructions: what the fleet picture decided to show, at which sim time.

`ground_station.state` emits these; `ground_station.rerun_log` renders them. Keeping them plain
lets the fold be tested without Rerun and the renderer be tested without telemetry.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ground_station.palette import Rgb


@dataclass(frozen=True)
class Spots:
    """Every spot's state (``"pending"``, ``"planned:<vid>"``, ``"claimed:<vid>"``,
    ``"cleared"``, ``"abandoned"``) and the matching colours, in scenario task order."""

    t_s: float
    states: tuple[str, ...]
    colors: np.ndarray  # (n, 3) uint8


@dataclass(frozen=True)
class Pose:
    t_s: float
    vid: str
    xy: tuple[float, float]
    yaw_deg: float
    state: str
    color: Rgb


@dataclass(frozen=True)
class Trail:
    t_s: float
    vid: str
    points: np.ndarray  # (m, 2) where the vehicle has been
    color: Rgb


@dataclass(frozen=True)
class Route:
    """The remaining planned route from the vehicle's position to its rendezvous; empty when
    the vehicle has nothing left to do (drawn as a clear)."""

    t_s: float
    vid: str
    points: np.ndarray  # (m, 2)
    color: Rgb


@dataclass(frozen=True)
class Mark:
    """A vehicle that stopped: ``kind`` in ``aborted``, ``lost``, ``silent``, ``dead``; an
    empty kind removes the mark (a lost vehicle heard again)."""

    t_s: float
    vid: str
    kind: str
    xy: tuple[float, float]


@dataclass(frozen=True)
class LinkLine:
    t_s: float
    src: str
    dst: str
    a: tuple[float, float]
    b: tuple[float, float]
    delivered: bool
    reason: str  # "" when delivered
    nbytes: int


@dataclass(frozen=True)
class LinkClear:
    t_s: float
    src: str
    dst: str


@dataclass(frozen=True)
class Scalar:
    """One time-series sample; ``path`` is relative to the ``series`` root."""

    t_s: float
    path: str
    value: float


@dataclass(frozen=True)
class LogLine:
    t_s: float
    text: str
    level: str  # Rerun TextLog levels: "INFO", "WARN", "ERROR"


Drawing = Spots | Pose | Trail | Route | Mark | LinkLine | LinkClear | Scalar | LogLine
