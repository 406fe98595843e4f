"""Plain-data drawing instructions: what the fleet picture decided to show, at which sim time.

`ground_station.state` emits these; `ground_station.rerun_log` renders them. Keeping them plain
lets the fold be tested without Rerun and the renderer be tested without telemetry.

Layers that change often hold the whole fleet (every vehicle's pose in one `Vehicles`, every
live link in one `Links`): the viewer ingests one row per change of the layer instead of one
per vehicle or per frame, which is what lets a browser keep up with a warped mission.
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
class Finds:
    """The aggregations the map missed, each drawn from the moment a vehicle reported it
    (dynamic missions): positions, priorities, labels."""

    t_s: float
    xy: np.ndarray  # (m, 2)
    priority: np.ndarray  # (m,)
    labels: tuple[str, ...]


@dataclass(frozen=True)
class Vehicles:
    """Every located vehicle's position, heading and label (empty where the label is drawn
    elsewhere: on a cluster's first vehicle, or on the station it is at), and where each
    label stands (`ground_station.labels.stack`: labels never pile up)."""

    t_s: float
    vids: tuple[str, ...]
    xy: np.ndarray  # (n, 2)
    yaw_deg: np.ndarray  # (n,)
    labels: tuple[str, ...]
    colors: np.ndarray  # (n, 3) uint8
    label_xy: np.ndarray | None = None  # (n, 2); None: at the vehicles


@dataclass(frozen=True)
class Stations:
    """The start and rendezvous labels, naming the vehicles that are at each station."""

    t_s: float
    labels: tuple[str, ...]  # in `MapLayers.stations` order


@dataclass(frozen=True)
class Trails:
    """Where the vehicles have been. ``part`` ``"recent"``: each vehicle's latest stretch,
    redrawn as it grows; ``"earlier"``: the finished stretches, redrawn only when one more
    finishes (so a long trail is never logged again point by point)."""

    t_s: float
    part: str
    strips: tuple[np.ndarray, ...]  # (m, 2) each
    colors: tuple[Rgb, ...]


@dataclass(frozen=True)
class Routes:
    """Each active vehicle's remaining planned route, from where it was when the route last
    changed, through its spots, to its rendezvous."""

    t_s: float
    vids: tuple[str, ...]
    strips: tuple[np.ndarray, ...]  # (m, 2) each
    colors: tuple[Rgb, ...]


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
    """One frame's fate, drawn from the sender to the receiver as they were when it settled."""

    t_s: float
    src: str
    dst: str
    a: tuple[float, float]
    b: tuple[float, float]
    delivered: bool
    reason: str  # "" when delivered
    nbytes: int
    snr_db: float | None = None
    sinr_db: float | None = None

    def label(self) -> str:
        """Dropped frames say why and how strong they were; delivered ones show it by colour."""
        if self.delivered:
            return ""
        figures = [f"{name} {value:.0f} dB" for name, value in
                   (("SNR", self.snr_db), ("SINR", self.sinr_db)) if value is not None]
        return " ".join([self.reason, *figures])


@dataclass(frozen=True)
class Links:
    """The latest frame of every link that settled within the link time-to-live, and where
    each line's label stands (stacked, so labels of links between nearby vehicles do not
    pile up; unlabelled lines' entries are unused)."""

    t_s: float
    lines: tuple[LinkLine, ...]
    label_xy: np.ndarray | None = None  # (n, 2); None: at the lines' middles


@dataclass(frozen=True)
class Current:
    """The water current on a grid of the map at ``t_s``; ``steady`` ones are drawn once."""

    t_s: float
    xy: np.ndarray  # (n, 2) arrow origins
    uv_mps: np.ndarray  # (n, 2) velocity
    scale_s: float  # arrow length = velocity x scale
    steady: bool


@dataclass(frozen=True)
class Scalar:
    """One time-series sample worth drawing; ``path`` names the line (``battery_s/auv1``,
    ``fleet/messages/delivered``). The picture draws it as part of a `SeriesRow`."""

    t_s: float
    path: str
    value: float


@dataclass(frozen=True)
class SeriesRow:
    """One row of a plot (``entity``, relative to the ``series`` root): every line's newest
    value at ``t_s`` (NaN for a line with none yet). One entity per plot, not per line: the
    viewer's cost is per entity that changes, and a plot's lines change together."""

    t_s: float
    entity: str
    names: tuple[str, ...]
    paths: tuple[str, ...]  # each line's series path, as in `Scalar`
    values: tuple[float, ...]
    drawn: tuple[str, ...]  # the lines that asked for this row (a change, a heartbeat)

    def value(self, path: str) -> float:
        return self.values[self.paths.index(path)]


@dataclass(frozen=True)
class LogLine:
    t_s: float
    text: str
    level: str  # Rerun TextLog levels: "INFO", "WARN", "ERROR"


Drawing = (Spots | Finds | Vehicles | Stations | Trails | Routes | Mark | Links | Current
           | SeriesRow | LogLine)
