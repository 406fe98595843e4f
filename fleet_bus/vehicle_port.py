"""The vehicle port: what passes between an agent and the vehicle it drives.

The agent never computes where its vehicle is. It reads the vehicle's navigation estimate
(`NavFix`: a position with its uncertainty, at a mission time) and the vehicle's reports of
what it finished (`Arrived`, `Looked`, `Injected`), what its camera saw (`Sighted`) and what it
would not do (`Refused`); it drives the vehicle with helm commands (`GoTo`, `StationKeep`,
`ReturnHome`, `Abort`). Positions are the scenario's local metres (x east, y north, z up:
depth is negative), in the vehicle's own navigation frame: a vehicle whose navigation drifts
reports where it believes it is, and where it believes what it saw lies.

Implementations (each a `VehiclePort`):

- the simulated vehicle (`reef_sim.vehicle`, driven through `fleet_agent.helms.sim`): the
  paper's kinematics (eq. 3-7) through currents, a drifting navigation estimate and a camera
  on the hidden reef;
- a MOOS-IvP helm (`fleet_agent.helms.moos`): NAV_* in, pHelmIvP behaviours out;
- a ROS 2 helm (`fleet_agent.helms.ros2`): nav_msgs/Odometry in, goals and a path out.

A simulated vehicle runs on the caller's mission time: `poll` runs it to the time asked and
returns what happened on the way, each report dated when it happened, so the agent decides at
the exact moment an arrival or an injection end occurs, however late the host runs. A live
helm runs on its own; `poll` returns what it reported since the last call.
"""

from __future__ import annotations

import math

from dataclasses import dataclass
from enum import Enum
from typing import Protocol, Union

Point3 = tuple[float, float, float]
HOME_TARGET = -1  # `GoTo.target` / `Arrived.target` of the rendezvous


class Work(Enum):
    """What a vehicle does while it keeps station (`StationKeep`)."""

    LOOK = "look"  # the camera looks at a predicted spot; ends with `Looked`
    INJECT = "inject"  # the injector treats the COTS of a spot; ends with `Injected`
    WAIT = "wait"  # hold until told otherwise (a claim settling); nothing is reported


# -- commands: agent -> vehicle -------------------------------------------------------------------


@dataclass(frozen=True)
class GoTo:
    """Fly to spot ``target`` (an index of the agent's working problem) through ``waypoints``
    (the path around land, ending at the spot). ``ahead``: the positions of the spots after it,
    in order, for a helm that shows or plans the whole route (a ROS 2 ``nav_msgs/Path``)."""

    target: int
    waypoints: tuple[Point3, ...]
    ahead: tuple[Point3, ...] = ()


@dataclass(frozen=True)
class StationKeep:
    """Keep station where the vehicle is and do ``work`` at spot ``task`` for ``duration_s``
    seconds (`Work.WAIT`: until the next command, ``duration_s`` being the expected wait)."""

    work: Work
    task: int
    duration_s: float


@dataclass(frozen=True)
class ReturnHome:
    """Go to the rendezvous through ``waypoints``; the vehicle reports ``Arrived(HOME_TARGET)``
    there and stays (it is recovered)."""

    waypoints: tuple[Point3, ...]


@dataclass(frozen=True)
class Abort:
    """Give up the mission: return to the rendezvous through ``waypoints``, or surface where
    the vehicle is (``surface``), as the vehicle's configuration says."""

    waypoints: tuple[Point3, ...]
    surface: bool = False


HelmCommand = Union[GoTo, StationKeep, ReturnHome, Abort]


# -- reports: vehicle -> agent --------------------------------------------------------------------


@dataclass(frozen=True)
class NavFix:
    """The vehicle's navigation estimate at mission time ``t_s``: position, its 1-sigma
    horizontal uncertainty, yaw (degrees counter-clockwise from east, eq. 5) and pitch (eq. 6),
    speed over ground, and the distance run since the dive began (None: the vehicle does not
    say; the agent integrates its fixes)."""

    t_s: float
    pos: Point3
    sigma_m: float = 0.0
    yaw_deg: float = 0.0
    pitch_deg: float = 0.0
    speed_mps: float | None = None
    odometer_m: float | None = None


@dataclass(frozen=True)
class Arrived:
    """The vehicle reached the target of its last `GoTo` (or the rendezvous) at ``t_s``."""

    t_s: float
    target: int


@dataclass(frozen=True)
class Looked:
    """The look at spot ``task`` ended at ``t_s``: COTS ``present`` (with their priority rho
    and injection time t, eq. 2, as the camera judges them) or not; ``pos``: where the camera
    saw them, in the vehicle's navigation frame as `Sighted` (None: the helm does not say).
    A look is at a spot the vehicle was sent to, so what it shows is that spot: a landmark
    whose identity a sighting along the track cannot promise (`fleet_agent.landmarks`)."""

    t_s: float
    task: int
    present: bool
    priority: float = 0.0
    service_s: float = 0.0
    pos: Point3 | None = None


@dataclass(frozen=True)
class Injected:
    """The injection at spot ``task`` ended at ``t_s``; ``pos``: where the camera measured
    the COTS it injected, in the vehicle's navigation frame as `Sighted` (None: nothing was
    there, or the helm does not say), and ``priority``: the rho it measured of them (None:
    the helm does not say). A drifted vehicle sent to a spot may inject whatever is in view
    there: the agent holds later sightings against where, and what, it really injected.
    The helm says both or neither: a priority without a position is an error."""

    t_s: float
    task: int
    pos: Point3 | None = None
    priority: float | None = None

    def __post_init__(self) -> None:
        if self.priority is not None:
            if self.pos is None:
                raise ValueError("Injected: a priority needs the position it was measured at")
            if not (math.isfinite(self.priority) and self.priority >= 0):
                raise ValueError(f"Injected: priority must be finite and >= 0, "
                                 f"got {self.priority!r}")


@dataclass(frozen=True)
class Sighted:
    """The camera saw an aggregation at ``t_s``, at ``pos`` in the vehicle's navigation frame
    (its own estimate plus the offset the camera measured), worth ``priority`` and taking
    ``service_s`` to inject."""

    t_s: float
    pos: Point3
    priority: float
    service_s: float


@dataclass(frozen=True)
class Refused:
    """The vehicle did not carry out ``command`` (its kind, e.g. ``"GoTo"``) at ``t_s``."""

    t_s: float
    command: str
    reason: str


VehicleReport = Union[NavFix, Arrived, Looked, Injected, Sighted, Refused]


def report_time(report: VehicleReport) -> float:
    return report.t_s


class VehiclePort(Protocol):
    """A vehicle an agent can drive (see the module docstring)."""

    name: str  # "sim" | "moos" | "ros2": the report's ``vehicles[i].helm``

    def command(self, cmd: HelmCommand, t_s: float) -> None:
        """Carry out ``cmd`` from mission time ``t_s`` on (it replaces the one under way)."""

    def poll(self, until_s: float) -> list[VehicleReport]:
        """What the vehicle reported up to mission time ``until_s``, in time order, a fix of
        its navigation estimate among them (a simulated vehicle gives one at ``until_s``)."""

    def next_report_s(self) -> float | None:
        """When a simulated vehicle next has something to report (an arrival, the end of a
        look or an injection); a live helm, polled at its own rate, says only when the work it
        times ends (None: no such work under way)."""

    def close(self) -> None:
        """Release the vehicle (idempotent)."""
