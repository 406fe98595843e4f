"""What ``cotsfleet run --helm sim|moos|ros2`` starts beside each agent, and how the agent
then reaches its vehicle.

- ``sim``: nothing: the agent flies the simulated vehicle in its own process.
- ``moos``: per vehicle a MOOS-IvP community, its mission files written into the run
  directory (`fleet_agent.helms.moos_mission.write_moos_mission`, ``MOOSTimeWarp`` = the
  warp) and its apps started from ``PATH`` as children in `MOOS_APPS` order (MOOSDB first),
  each through `cotsfleet.mission.native` so that it dies with the launcher; the agent gets
  ``--helm moos --moos-port P --moos-warp W --emulation``. MOOS's clock cannot be held or
  slowed once started, so the launcher keeps the fleet's clock at the warp (no planning
  holds, no pacing): see `pins_clock`.
- ``ros2``: per vehicle the project's simulated vehicle served as a ROS 2 vehicle
  (`fleet_agent.helms.ros2_vehicle` with `fleet_agent.helms.sim.bridged_vehicle`) on the
  fleet's mission clock (``--connect`` with the run's listen-only ``world`` identity); the
  agent gets ``--helm ros2 --ros-namespace NS --emulation``. Both sides run in a ROS domain
  of the run's own with discovery confined to this host (`ros_env`).

A helm's child that dies is not started again (a restarted simulator would put its vehicle
back at its start): the agent sees its navigation stop and acts (`policies.navigation`).
"""

from __future__ import annotations

import hashlib
import shutil
import socket
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

from fleet_agent.helms.choice import HELMS, ros_name
from fleet_agent.helms.moos_mission import MOOS_APPS, write_moos_mission
from fleet_bus.credentials import WORLD_ID
from hfc_core.model.problem import Problem

BRIDGE_READY = "fleet_agent ros2 vehicle ready"  # `fleet_agent.helms.ros2_vehicle.READY`
ROS_DOMAINS = range(1, 101)  # the ids ROS 2 leaves to users on one host (0 is everyone's)


def missing_moos_apps() -> list[str]:
    return [app for app in MOOS_APPS if shutil.which(app) is None]


def check_helm(name: str) -> None:
    """ValueError naming what to install when the helm's software is missing."""
    if name not in HELMS:
        raise ValueError(f"--helm is one of {', '.join(HELMS)}, got {name!r}")
    if name == "moos":
        missing = missing_moos_apps()
        if missing:
            raise ValueError(f"--helm moos needs MOOS-IvP on PATH: {', '.join(missing)} "
                             "missing (build moos-ivp from its sources and put its bin on "
                             "PATH: docs/onboard.md)")
    elif name == "ros2":
        try:
            import rclpy  # noqa: F401  (only whether it imports)
        except ImportError:
            raise ValueError("--helm ros2 needs rclpy: pip install -e '.[ros2]' "
                             "(docs/onboard.md)") from None


def pins_clock(name: str) -> bool:
    """Whether the fleet's clock must run at the requested warp throughout: a MOOS
    community's ``MOOSTimeWarp`` is fixed when it starts, so a clock that held or slowed
    would fall behind the simulated vehicle (it flies on at the warp)."""
    return name == "moos"


def ros_domain(run_id: str) -> int:
    """A ROS 2 domain id of the run's own, from its id (two runs on one host pick the same
    one with odds 1 in 100; the namespaces carry the run's token as well)."""
    digest = hashlib.sha256(run_id.encode()).digest()
    return ROS_DOMAINS[int.from_bytes(digest[:4], "big") % len(ROS_DOMAINS)]


def ros_env(run_id: str) -> dict[str, str]:
    """The environment of every ROS 2 process of the run: its domain, discovery on this
    host only (``ROS_AUTOMATIC_DISCOVERY_RANGE``, Iron and later; ``ROS_LOCALHOST_ONLY``,
    the older distributions' switch)."""
    return {"ROS_DOMAIN_ID": str(ros_domain(run_id)), "ROS_LOCALHOST_ONLY": "1",
            "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@dataclass
class HelmLaunch:
    """The helm children of a run: `plan` per vehicle, `spawn_now` (before the agents: the
    MOOS communities), `spawn_with_clock` (the ROS 2 vehicles, which join the clock), the
    agent's arguments and environment."""

    name: str
    problem: Problem
    run_dir: Path
    warp: float
    run_id: str
    moos_ports: dict[str, int] = field(default_factory=dict)
    children: list[str] = field(default_factory=list)  # names of the helm's processes

    def __post_init__(self) -> None:
        check_helm(self.name)

    @property
    def token(self) -> str:
        return hashlib.sha256(self.run_id.encode()).hexdigest()[:8]

    def namespace(self, vid: str) -> str:
        """The vehicle's ROS 2 namespace: the run's token, then its id."""
        return f"/cf_{self.token}/{ros_name(vid)}"

    def env(self) -> dict[str, str]:
        return ros_env(self.run_id) if self.name == "ros2" else {}

    def agent_argv(self, vid: str) -> list[str]:
        if self.name == "sim":
            return []
        if self.name == "moos":
            return ["--helm", "moos", "--moos-port", str(self.moos_ports[vid]),
                    "--moos-warp", repr(self.warp), "--emulation"]
        return ["--helm", "ros2", "--ros-namespace", self.namespace(vid), "--emulation"]

    def moos_argvs(self, vids: Sequence[str]) -> list[tuple[str, list[str]]]:
        """(child name, argv) of every MOOS app of ``vids``, their mission files written."""
        out = []
        moos_dir = self.run_dir / "moos"
        for vid in vids:
            index = self.problem.vehicle_index[vid]
            port = self.moos_ports.setdefault(vid, free_port())
            mission = write_moos_mission(self.problem, index, moos_dir, self.warp, port)
            for app in MOOS_APPS:
                out.append((f"{vid}.{app}",
                            ["-m", "cotsfleet.mission.native", app, str(mission)]))
        self.children += [name for name, _ in out]
        return out

    def bridge_argvs(self, vids: Sequence[str], endpoint: str, creds: Path
                     ) -> list[tuple[str, list[str]]]:
        """(child name, argv) of the ROS 2 vehicle of each of ``vids``."""
        out = []
        rate = min(50.0, max(10.0, self.warp / 1.5))  # a fix every 1.5 mission s or less
        for vid in vids:
            out.append((f"{vid}.vehicle", [
                "-m", "fleet_agent.helms.ros2_vehicle",
                "--scenario", str(self.run_dir / "scenario.json"),
                "--vehicle", str(self.problem.vehicle_index[vid]),
                "--factory", "fleet_agent.helms.sim:bridged_vehicle",
                "--namespace", self.namespace(vid), "--connect", endpoint,
                "--credentials", str(creds / WORLD_ID), "--rate-hz", f"{rate:g}"]))
        self.children += [name for name, _ in out]
        return out
