"""The ROS 2 helm and the ROS 2 vehicle bridge, as two real rclpy processes on loopback.

The vehicle process serves `LineVehicle` (below: the vehicle under test's stand-in, a port
that flies straight legs at constant speed) through `VehicleBridge`; the test process drives
it with `Ros2Helm`. Discovery stays on this host (``ROS_LOCALHOST_ONLY=1``,
``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) in a domain of this run's own, so parallel runs
never meet. Skipped when rclpy is not installed (the ``ros2`` extra).

Run as a script (``python test_ros2_helm.py serve ...``) this file is the vehicle process.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fleet_bus.vehicle_port import (
    HOME_TARGET,
    Abort,
    Arrived,
    GoTo,
    HelmCommand,
    Looked,
    NavFix,
    Refused,
    ReturnHome,
    Sighted,
    StationKeep,
    VehicleReport,
    Work,
)

WARP = 10.0
START = (10.0, 20.0, 0.0)
HOME = (0.0, 0.0, 0.0)
REGION_M = 300.0  # the stand-in refuses a leg that leaves this radius around its start
AGGREGATION = (40.0, 20.0, -2.0)  # what the stand-in's camera sees when it passes by


class LineVehicle:
    """Straight legs at ``speed_mps``, exact arrivals, a camera that sees `AGGREGATION`
    within 5 m of the track, an operating region it will not leave."""

    name = "line"

    def __init__(self, start=START, speed_mps: float = 1.0) -> None:
        self.pos, self.speed = tuple(start), speed_mps
        self.path: list[tuple[float, float, float]] = []
        self.target: int | None = None
        self.t_s = 0.0
        self.out: list[VehicleReport] = []
        self.seen = False

    def command(self, cmd: HelmCommand, t_s: float) -> None:
        self._advance(t_s)
        if isinstance(cmd, (GoTo, ReturnHome)) or (isinstance(cmd, Abort) and not cmd.surface):
            far = [p for p in cmd.waypoints if math.dist(p[:2], START[:2]) > REGION_M]
            if far:
                self.out.append(Refused(t_s, type(cmd).__name__, "outside operating region"))
                return
            self.path = list(cmd.waypoints)
            self.target = cmd.target if isinstance(cmd, GoTo) else HOME_TARGET
        elif isinstance(cmd, Abort):
            self.path, self.target = [(self.pos[0], self.pos[1], 0.0)], None
        else:
            self.path, self.target = [], None

    def _advance(self, until_s: float) -> None:
        dt = max(0.0, until_s - self.t_s)
        while dt > 0 and self.path:
            nxt = self.path[0]
            d = math.dist(self.pos, nxt)
            step = min(d, self.speed * dt)
            f = step / d if d > 0 else 1.0
            self.pos = tuple(a + f * (b - a) for a, b in zip(self.pos, nxt))
            dt -= step / self.speed
            if not self.seen and math.dist(self.pos[:2], AGGREGATION[:2]) < 5.0:
                self.seen = True
                self.out.append(Sighted(until_s - dt, AGGREGATION, 66.0, 80.0))
            if f >= 1.0:
                self.path.pop(0)
                if not self.path and self.target is not None:
                    self.out.append(Arrived(until_s - dt, self.target))
        self.t_s = until_s

    def poll(self, until_s: float) -> list[VehicleReport]:
        self._advance(until_s)
        out, self.out = self.out, []
        return out + [NavFix(until_s, self.pos, 0.5, 0.0, 0.0, self.speed if self.path else 0.0)]

    def true_pose(self):
        return self.pos

    def next_report_s(self) -> float | None:
        return None

    def close(self) -> None:
        pass


def serve(namespace: str, epoch: float) -> None:
    """The vehicle process: `LineVehicle` behind `VehicleBridge` until SIGTERM."""
    from fleet_agent.helms.ros2_vehicle import READY, BridgeConfig, VehicleBridge
    from fleet_bus.clock import WarpClock
    from fleet_bus.process import process_stop, ready

    stop = process_stop()
    clock = WarpClock(epoch, WARP)
    vehicle = LineVehicle()
    vehicle.t_s = clock.now()
    bridge = VehicleBridge(vehicle, clock, BridgeConfig(namespace=namespace, rate_hz=20.0))
    try:
        ready(READY, namespace)
        stop.wait()
    finally:
        bridge.close()


if __name__ == "__main__" and len(sys.argv) == 4 and sys.argv[1] == "serve":
    serve(sys.argv[2], float(sys.argv[3]))
    raise SystemExit(0)

# -- the tests --------------------------------------------------------------------------------

rclpy = pytest.importorskip("rclpy", reason="rclpy not installed (pip install -e .[ros2])")

from fleet_agent.helms.frames import LocalFrame  # noqa: E402
from fleet_agent.helms.ros2 import Ros2Helm, Ros2HelmConfig  # noqa: E402
from fleet_agent.helms.ros2_iface import fix_of, odometry, path_msg, path_points  # noqa: E402
from fleet_agent.helms.ros2_vehicle import READY  # noqa: E402
from fleet_bus.clock import WarpClock  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


class ReefStandIn:
    def sweep(self, pos):
        return []

    def inspect(self, task: int, pos=None) -> tuple[bool, float, float]:
        return True, 42.0, 75.0


@pytest.fixture
def ros_env(monkeypatch: pytest.MonkeyPatch) -> dict[str, str]:
    # A domain of this run's own (ids 1..100), discovery on this host only.
    env = {"ROS_DOMAIN_ID": str(1 + os.getpid() % 100), "ROS_LOCALHOST_ONLY": "1",
           "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    return env


class VehicleProcess:
    def __init__(self, namespace: str, epoch: float, env: dict[str, str]) -> None:
        full = {**os.environ, **env, "PYTHONPATH": f"{ROOT}{os.pathsep}"
                f"{os.environ.get('PYTHONPATH', '')}"}
        self.proc = subprocess.Popen(
            [sys.executable, __file__, "serve", namespace, repr(epoch)], env=full,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=ROOT)
        line = self.proc.stdout.readline()  # type: ignore[union-attr]
        if not line.startswith(READY):
            self.stop()
            raise AssertionError(f"vehicle process did not get ready: {line!r}")

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        assert self.proc.poll() is not None
        if self.proc.stdout is not None:
            self.proc.stdout.close()


@pytest.fixture
def pair(ros_env, request):
    ns = f"/auv_{os.getpid()}_{request.node.name[:20]}".replace("-", "_").replace("[", "_")
    ns = "".join(c if c.isalnum() or c in "/_" else "_" for c in ns)
    epoch = time.time()
    clock = WarpClock(epoch, WARP)
    vehicle = VehicleProcess(ns, epoch, ros_env)
    helm = None
    try:
        camera = ReefStandIn() if "camera" in request.node.name else None
        helm = Ros2Helm(clock, Ros2HelmConfig(namespace=ns, warp=WARP, arrive_radius_m=1.0),
                        camera=camera)
        assert helm.wait_for_vehicle(20.0), "the vehicle's services and odometry came"
        yield helm, clock, vehicle
    finally:
        if helm is not None:
            helm.close()
        vehicle.stop()


def _until(helm, clock, want, mission_s: float) -> list:
    got: list = []
    end = time.time() + mission_s / WARP
    while time.time() < end:
        got += helm.poll(clock.now())
        if any(isinstance(r, want) for r in got):
            return got
        time.sleep(0.02)
    return got


@pytest.mark.integration
def test_goto_arrives_and_a_look_with_the_camera_reports(pair) -> None:
    helm, clock, _ = pair
    fixes = [r for r in helm.poll(clock.now()) if isinstance(r, NavFix)]
    assert fixes and math.dist(fixes[-1].pos, START) < 0.5 and fixes[-1].sigma_m == 0.5
    spot = (30.0, 40.0, -3.0)
    t_go = clock.now()
    helm.command(GoTo(3, ((30.0, 20.0, -3.0), spot), ahead=((60.0, 60.0, -4.0),)), t_go)
    got = _until(helm, clock, Arrived, 120.0)
    arrived = [r for r in got if isinstance(r, Arrived)]
    assert arrived and arrived[0].target == 3
    # 40.2 m at 1 m/s, judged from odometry sent at 20 Hz wall (0.5 mission s apart).
    assert arrived[0].t_s - t_go == pytest.approx(40.2 - 1.0, abs=2.0)
    t0 = clock.now()
    helm.command(StationKeep(Work.LOOK, 3, 20.0), t0)
    got = _until(helm, clock, Looked, 60.0)
    assert [r for r in got if isinstance(r, Looked)] == [
        Looked(pytest.approx(t0 + 20.0), 3, True, 42.0, 75.0)]
    assert not [r for r in got if isinstance(r, Refused)]
    assert helm.stats.fixes > 30 and helm.stats.lag_max_s < 5.0


@pytest.mark.integration
def test_sightings_from_the_vehicle_and_return_home(pair) -> None:
    helm, clock, _ = pair
    helm.command(GoTo(1, ((50.0, 20.0, -2.0),)), clock.now())  # passes the aggregation
    got = _until(helm, clock, Arrived, 120.0)
    seen = [r for r in got if isinstance(r, Sighted)]
    assert seen and seen[0].pos == pytest.approx(AGGREGATION) and seen[0].priority == 66.0
    helm.command(ReturnHome(((20.0, 0.0, 0.0), HOME)), clock.now())
    got = _until(helm, clock, Arrived, 150.0)
    assert [r.target for r in got if isinstance(r, Arrived)] == [HOME_TARGET]
    last = [r for r in got if isinstance(r, NavFix)][-1]
    assert math.dist(last.pos, HOME) < 1.0


@pytest.mark.integration
def test_refusals_from_the_vehicle_and_after_an_abort(pair) -> None:
    helm, clock, _ = pair
    helm.command(GoTo(2, ((900.0, 900.0, -2.0),)), clock.now())  # outside its region
    got = _until(helm, clock, Refused, 30.0)
    refused = [r for r in got if isinstance(r, Refused)]
    assert refused and refused[0].command == "GoTo" and "region" in refused[0].reason
    helm.command(Abort((), surface=True), clock.now())
    time.sleep(0.3)
    helm.command(StationKeep(Work.INJECT, 2, 30.0), clock.now())
    got = _until(helm, clock, Refused, 30.0)
    refused = [r for r in got if isinstance(r, Refused)]
    assert refused and refused[0].command == "StationKeep" and "aborted" in refused[0].reason
    helm.command(GoTo(2, ((float("nan"), 0.0, 0.0),)), clock.now())
    assert [r.reason for r in helm.poll(clock.now()) if isinstance(r, Refused)] == [
        "waypoints not finite"]


@pytest.mark.integration
def test_navigation_that_stops_is_seen_in_the_fix_age(pair) -> None:
    helm, clock, vehicle = pair
    assert helm.nav_age_s() < 5.0
    vehicle.stop()
    helm.poll(clock.now())
    time.sleep(40.0 / WARP)
    assert not [r for r in helm.poll(clock.now()) if isinstance(r, NavFix)]
    assert helm.nav_age_s() > 30.0
    helm.command(StationKeep(Work.WAIT, -1, 0.0), clock.now())
    refused = [r for r in _until(helm, clock, Refused, 100.0) if isinstance(r, Refused)]
    assert refused and ("not available" in refused[0].reason
                        or "no answer" in refused[0].reason)


def test_odometry_and_paths_cross_the_frame_both_ways() -> None:
    frame = LocalFrame(100.0, -50.0)
    fix = NavFix(3.0, (110.0, -40.0, -6.0), 0.8, 135.0, 0.0, 1.2)
    msg = odometry(fix, frame, "map", "base_link", 1e9)
    assert (msg.pose.pose.position.x, msg.pose.pose.position.y) == (10.0, 10.0)
    back = fix_of(msg, frame, 3.0)
    assert back is not None and back.pos == pytest.approx(fix.pos)
    assert back.yaw_deg == pytest.approx(135.0) and back.sigma_m == pytest.approx(0.8)
    assert back.speed_mps == pytest.approx(1.2)
    msg.pose.pose.position.x = float("nan")
    assert fix_of(msg, frame, 3.0) is None
    pts = ((110.0, -40.0, -1.0), (120.0, -40.0, -2.0))
    path = path_msg(pts, frame, "map", 1e9)
    assert path_points(path, frame) == pts
    assert path_points(path_msg((), frame, "map", 0.0), frame) is None
