"""The simulated vehicle as an agent's vehicle (``--helm sim``, the default in emulation).

The vehicle lives in the simulated world (`reef_sim.vehicle`); this binds it to one agent's
process: it starts where the agent last knew it was (a restarted agent: its last journal
checkpoint, the vehicle having been dead in the water meanwhile), carries the camera on the
hidden reef when the mission has one, and navigates as the scenario's ``navigation`` section
says (`reef_sim.navigation`; None: exact).
"""

from __future__ import annotations

from fleet_agent.sensor import Camera
from fleet_bus.clock import Clock
from hfc_core.model.paths import Point3
from hfc_core.model.problem import Problem
from reef_sim.camera import ReefCamera
from reef_sim.navigation import DeadReckoning, NavigationParams
from reef_sim.truth import Reef
from reef_sim.vehicle import SimVehicle


def camera_figures(reef: Reef) -> Camera:
    """What the agent may know of the simulated camera: its figures, never the reef."""
    return Camera(reef.detect_radius_m, reef.p_detect, reef.inspect_s, reef.look_radius_m)


def sim_vehicle(scenario: Problem, index: int, *, seed: int, reef: Reef | None, t_s: float,
                pos: Point3, odometer_m: float,
                navigation: NavigationParams | None = None) -> SimVehicle:
    """Vehicle ``index`` of ``scenario`` (its real water), at ``pos`` at mission time ``t_s``,
    with a camera on ``reef`` (seeded by the mission ``seed``) if there is one, and a drifting
    navigation estimate if ``navigation`` says so (seeded by the mission ``seed`` and
    ``index``). A restarted agent's vehicle starts at the position the agent last knew: with
    navigation error that is its estimate, taken as the truth again with a fresh start fix
    (the world does not outlive the agent's process)."""
    camera = None if reef is None else ReefCamera(reef, seed, index, scenario.n_tasks)
    nav = None if navigation is None else DeadReckoning(navigation, seed, index, pos, odometer_m)
    return SimVehicle(scenario, index, camera=camera, t_s=t_s, pos=pos, odometer_m=odometer_m,
                      navigation=nav)


def bridged_vehicle(problem: Problem, index: int, clock: Clock) -> SimVehicle:
    """The simulated vehicle a ROS 2 bridge serves in a mission (``python -m
    fleet_agent.helms.ros2_vehicle --factory fleet_agent.helms.sim:bridged_vehicle``): at
    its start, from mission time now, without a camera. The camera is the agent's helm's
    (`fleet_agent.helms.choice`, on the true pose the bridge publishes): the ROS 2 interface
    has the helm time a look (``look`` is a ``Trigger`` with no spot), so only the helm knows
    which spot it looks at."""
    return SimVehicle(problem, index, t_s=clock.now())
