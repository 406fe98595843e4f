"""Which vehicle an agent drives: `HelmChoice` (what ``--helm`` and its options say) and
`open_vehicle`, the one place a process shell turns it into a `VehiclePort`.

- ``sim``: the simulated vehicle (`fleet_agent.helms.sim`), on the caller's mission time;
- ``moos``: `MoosHelm` on the vehicle's MOOSDB (``moos_host:moos_port``), MOOS time at
  ``moos_warp`` (the community's ``MOOSTimeWarp``; None: the mission clock's warp now);
- ``ros2``: `Ros2Helm` in ``ros_namespace`` (default ``/<vehicle id>``), needs rclpy.

With ``emulated`` the helm drives a simulator (uSimMarine, the project's vehicle behind
`ros2_vehicle`): its true pose goes out on ``fleet/truth/<id>`` (the emulated water's
positions, the ground station's picture), the ROS 2 helm reads ``ground_truth/odom``, and the
camera is the hidden reef's at that true position (`reef_sim.camera.ReefCamera`) when the
scenario has one. On board (not ``emulated``) there is no truth and no reef: detections come
from the vehicle. The decision logic never imports this module.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

from fleet_agent.helms.sim import sim_vehicle
from fleet_bus.clock import Clock, MissionClock
from fleet_bus.vehicle_port import Point3, VehiclePort
from hfc_core.model.problem import Problem
from reef_sim.camera import ReefCamera
from reef_sim.truth import Reef

if TYPE_CHECKING:  # imported where used: the ROS 2 helm needs rclpy
    from fleet_agent.helms.moos import MoosHelm
    from fleet_agent.helms.ros2 import Ros2Helm

HELMS = ("sim", "moos", "ros2")
BEFORE_S = -1.0  # mission time before the clock record came: nothing is dated at 0 or later
TruePose = Callable[[], tuple[Point3, float, float]]


@dataclass(frozen=True)
class HelmChoice:
    """What the command line chose (module docstring)."""

    name: str = "sim"
    moos_host: str = "localhost"
    moos_port: int = 9000
    moos_warp: float | None = None
    ros_namespace: str = ""
    emulated: bool = False
    ready_timeout_s: float = 30.0  # wall: the live helm's first fix (and DRIVE, emulated)

    def __post_init__(self) -> None:
        if self.name not in HELMS:
            raise ValueError(f"--helm is one of {', '.join(HELMS)}, got {self.name!r}")
        if not 1 <= int(self.moos_port) <= 65535:
            raise ValueError(f"--moos-port out of range: {self.moos_port}")
        if self.moos_warp is not None and not (math.isfinite(self.moos_warp)
                                               and self.moos_warp > 0):
            raise ValueError(f"--moos-warp must be positive, got {self.moos_warp}")
        if not (math.isfinite(self.ready_timeout_s) and self.ready_timeout_s > 0):
            raise ValueError(f"helm ready timeout must be positive, got {self.ready_timeout_s}")

    def namespace(self, vid: str) -> str:
        return self.ros_namespace or "/" + ros_name(vid)


class PendingClock:
    """Mission time once the mission clock is set (``clock``), `BEFORE_S` until then: a live
    helm, or the vehicle a ROS 2 bridge serves, opens before the operator serves the clock
    (which it does only once every agent is ready) and goes on seamlessly once it comes."""

    def __init__(self) -> None:
        self.clock: MissionClock | None = None

    def now(self) -> float:
        clock = self.clock
        return BEFORE_S if clock is None else clock.now()

    @property
    def warp(self) -> float:
        clock = self.clock
        return 1.0 if clock is None else clock.warp

    def wall_of(self, t_s: float) -> float:
        clock = self.clock
        return time.time() if clock is None else clock.wall_of(t_s)

    def wall_delay(self, sim_dt_s: float) -> float:
        return max(0.0, sim_dt_s) / self.warp


def ros_name(text: str) -> str:
    """``text`` as a ROS 2 name token (letters, digits, underscores; not a digit first)."""
    out = "".join(c if c.isalnum() or c == "_" else "_" for c in text) or "_"
    return out if not out[0].isdigit() else "_" + out


def open_vehicle(choice: HelmChoice, problem: Problem, index: int, *, clock: Clock, seed: int,
                 reef: Reef | None, t_s: float, pos: Point3, odometer_m: float
                 ) -> tuple[VehiclePort, TruePose | None]:
    """Vehicle ``index``'s port and, in emulation, where it really is (None on board).
    ``t_s``, ``pos``, ``odometer_m``: where the agent last knew it was (the simulated
    vehicle starts there; a live vehicle is where it is). A live helm is returned once it
    gave a first fix (and, emulated, drives); ConnectionError if it did not within
    ``choice.ready_timeout_s``, ImportError if the ROS 2 helm's rclpy is missing."""
    if choice.name == "sim":
        sim = sim_vehicle(problem, index, seed=seed, reef=reef, t_s=t_s, pos=pos,
                          odometer_m=odometer_m)
        return sim, sim.true_pose
    camera = (ReefCamera(reef, seed, index, problem.n_tasks)
              if choice.emulated and reef is not None else None)
    start = problem.vehicles[index].start
    port: MoosHelm | Ros2Helm
    if choice.name == "moos":
        port = _moos(choice, problem, index, clock, camera)
    else:
        port = _ros2(choice, problem, index, clock, camera)
    if not choice.emulated:
        return port, None

    def truth() -> tuple[Point3, float, float]:
        pose = port.true_pose()
        return pose if pose is not None else (start, 0.0, 0.0)

    return port, truth


def _moos(choice: HelmChoice, problem: Problem, index: int, clock: Clock,
          camera: ReefCamera | None) -> MoosHelm:
    from fleet_agent.helms.moos import MoosHelm, MoosHelmConfig

    warp = choice.moos_warp or float(getattr(clock, "warp", 1.0))
    config = MoosHelmConfig(host=choice.moos_host, port=choice.moos_port, warp=warp,
                            client_name=f"cotsfleet_{ros_name(problem.vehicles[index].id)}",
                            connect_timeout_s=choice.ready_timeout_s)
    helm = MoosHelm(clock, config, camera=camera)  # ConnectionError: no MOOSDB there
    end = time.monotonic() + choice.ready_timeout_s
    while time.monotonic() < end:
        if helm.stats.last_fix is not None and (helm.helm_state == "DRIVE"
                                                or not choice.emulated):
            return helm
        time.sleep(0.05)
    state = helm.helm_state or "no IVPHELM_STATE"
    fixes = helm.stats.fixes
    helm.close()
    raise ConnectionError(f"MOOS vehicle at {choice.moos_host}:{choice.moos_port} not ready "
                          f"in {choice.ready_timeout_s:g} s ({fixes} fixes, helm {state})")


def _ros2(choice: HelmChoice, problem: Problem, index: int, clock: Clock,
          camera: ReefCamera | None) -> Ros2Helm:
    from fleet_agent.helms.ros2 import Ros2Helm, Ros2HelmConfig  # needs rclpy

    ns = choice.namespace(problem.vehicles[index].id)
    config = Ros2HelmConfig(namespace=ns, warp=float(getattr(clock, "warp", 1.0)),
                            use_truth=choice.emulated,
                            node_name=f"cotsfleet_helm_{ros_name(problem.vehicles[index].id)}")
    helm = Ros2Helm(clock, config, camera=camera)
    if helm.wait_for_vehicle(choice.ready_timeout_s):
        return helm
    helm.close()
    raise ConnectionError(f"no ROS 2 vehicle in {ns} within {choice.ready_timeout_s:g} s "
                          "(its services and a first odometry)")
