"""Any vehicle port served as a ROS 2 vehicle: the other side of `fleet_agent.helms.ros2`.

`VehicleBridge(port, clock, config)` is an rclpy node that carries out the ROS 2 interface of
`fleet_agent.helms.ros2_iface` on a `fleet_bus.vehicle_port.VehiclePort` (the project's
simulated vehicle, or a user's own): it runs the port on the mission clock at ``rate_hz``
(wall), publishes its navigation fixes as ``odom`` (and its true pose as
``ground_truth/odom`` when the port has ``true_pose()``), its sightings, look results and
refusals on ``vehicle_events``, and turns what it is told into helm commands:

- a ``plan`` -> ``GoTo`` (or ``ReturnHome`` / ``Abort`` after ``return_home`` / ``abort``
  said the way home is coming: whichever of the plan and the service arrives first, the
  vehicle ends up on the plan home);
- ``look`` / ``inject`` / ``hold`` -> ``StationKeep`` where it is (``Work.WAIT``: the helm
  times the work; the vehicle holds until the next command);
- ``abort`` with ``data=true`` -> ``Abort(surface=True)``.

After an abort the vehicle takes nothing but another abort (its mission is over): a service
answers ``success=false``, a plan is dropped and counted.

Run one per vehicle with ``python -m fleet_agent.helms.ros2_vehicle --scenario S --vehicle I
--factory module:callable`` (the callable builds the port: ``f(problem, index, clock)``,
e.g. `fleet_agent.helms.sim.bridged_vehicle`); it prints `READY` when serving and ends on
SIGTERM/SIGINT or with its parent. Its clock: ``--epoch``/``--warp`` (a wall-clock
`WarpClock`), or, in a mission (``--connect`` to its router, ``--credentials`` a listen-only
identity), the fleet's own mission clock through `fleet_bus.mission.ClockSync`: the vehicle
then holds and slows with the fleet (planning holds, pacing), which a fixed epoch and warp
would not (the vehicle would run ahead of the agents whenever the operator slows the clock).
"""

from __future__ import annotations

import argparse
import importlib
import json
import logging
import math
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path as FilePath
from typing import Callable, Iterable

import rclpy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry, Path
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from std_msgs.msg import String
from std_srvs.srv import SetBool, Trigger

from fleet_agent.helms.camera import format_detection
from fleet_agent.helms.frames import LocalFrame
from fleet_agent.helms.ros2_iface import (
    EVENTS,
    LATCHED,
    STREAM,
    Ros2Names,
    odometry,
    path_points,
)
from fleet_bus.clock import Clock, WarpClock
from fleet_bus.vehicle_port import (
    Abort,
    GoTo,
    HelmCommand,
    Looked,
    NavFix,
    Refused,
    ReturnHome,
    Sighted,
    StationKeep,
    VehiclePort,
    Work,
)

log = logging.getLogger(__name__)
READY = "fleet_agent ros2 vehicle ready"
PLAN_TARGET = 0  # the target a plan's GoTo is given: the vehicle knows no spot indices


@dataclass(frozen=True)
class BridgeConfig:
    namespace: str = ""
    names: Ros2Names = field(default_factory=Ros2Names)
    frame: LocalFrame = field(default_factory=LocalFrame)
    rate_hz: float = 10.0  # wall: how often the port runs and odometry goes out
    node_name: str = "cotsfleet_vehicle"
    child_frame_id: str = "base_link"

    def __post_init__(self) -> None:
        if not (math.isfinite(self.rate_hz) and 0 < self.rate_hz <= 1000):
            raise ValueError(f"rate_hz must be in (0, 1000], got {self.rate_hz}")


class VehicleBridge:
    """A `VehiclePort` behind the ROS 2 vehicle interface (module docstring)."""

    def __init__(self, port: VehiclePort, clock: Clock,
                 config: BridgeConfig = BridgeConfig()) -> None:
        self.port, self.clock, self.config = port, clock, config
        self._lock = threading.Lock()
        self._plan: tuple | None = None
        self._homeward: str = ""  # "", "return" or "abort": what the next plan is
        self._aborted = False
        self.counters = {"fixes": 0, "plans": 0, "plans_dropped": 0, "events": 0}
        n = config.names
        true_pose = getattr(port, "true_pose", None)  # an emulated vehicle's (not the port's)
        self._true_pose: Callable[[], object] | None = true_pose if callable(true_pose) else None
        self._context = Context()
        rclpy.init(context=self._context, args=[])
        try:
            self.node = node = rclpy.create_node(config.node_name, namespace=config.namespace,
                                                 context=self._context)
            self._odom = node.create_publisher(Odometry, n.odom, STREAM)
            self._truth = (node.create_publisher(Odometry, n.truth, STREAM)
                           if self._true_pose is not None else None)
            self._events = node.create_publisher(String, n.events, EVENTS)
            node.create_subscription(Path, n.plan, self._on_plan, LATCHED)
            node.create_subscription(PoseStamped, n.goal, lambda _m: None, LATCHED)
            for work, name in ((Work.LOOK, n.look), (Work.INJECT, n.inject),
                               (Work.WAIT, n.hold)):
                node.create_service(Trigger, name, self._station_service(work))
            node.create_service(SetBool, n.return_home, self._on_return)
            node.create_service(SetBool, n.abort, self._on_abort)
            node.create_timer(1.0 / config.rate_hz, self._tick)
            self._executor = SingleThreadedExecutor(context=self._context)
            self._executor.add_node(node)
            self._thread = threading.Thread(target=self._spin, name="ros2-vehicle",
                                            daemon=True)
            self._thread.start()
        except Exception:
            rclpy.shutdown(context=self._context)
            raise

    def _spin(self) -> None:
        try:
            self._executor.spin()
        except ExternalShutdownException:
            pass

    def close(self) -> None:
        self._executor.shutdown(timeout_sec=2.0)
        self.node.destroy_node()
        rclpy.shutdown(context=self._context)
        self._thread.join(timeout=5.0)
        self.port.close()

    # -- the port, on the clock ----------------------------------------------------------------

    def _tick(self) -> None:
        with self._lock:
            reports = self.port.poll(self.clock.now())
            truth = self._true_pose() if self._true_pose is not None else None
        c, n, now = self.config, self.config.names, time.time()
        fixes = [r for r in reports if isinstance(r, NavFix)]
        if fixes:
            # Only the newest: odometry is a state, not a log; its stamp is the wall time of
            # the fix (the mission clock's, when it says).
            fix = fixes[-1]
            wall = self._wall_of(fix.t_s, now)
            self._odom.publish(odometry(fix, c.frame, n.frame_id, c.child_frame_id, wall))
            self.counters["fixes"] += 1
            if truth is not None and self._truth is not None:
                pos, yaw = true_position(truth, fix.yaw_deg)
                self._truth.publish(odometry(NavFix(fix.t_s, pos, 0.0, yaw),
                                             c.frame, n.frame_id, c.child_frame_id, wall))
        for r in reports:
            text = ""
            if isinstance(r, Sighted):
                x, y, z = c.frame.to_helm(r.pos)
                text = format_detection("sighting", x=x, y=y, z=z, priority=float(r.priority),
                                        service_s=float(r.service_s))
            elif isinstance(r, Looked):
                text = format_detection("look", task=r.task, present=r.present,
                                        priority=float(r.priority), service_s=float(r.service_s))
            elif isinstance(r, Refused):
                text = f"kind=refused,command={r.command},reason={r.reason}"
            if text:
                self._events.publish(String(data=text))
                self.counters["events"] += 1

    def _wall_of(self, t_s: float, now: float) -> float:
        wall_of = getattr(self.clock, "wall_of", None)
        return float(wall_of(t_s)) if callable(wall_of) else now

    def _command(self, cmd: HelmCommand) -> None:
        with self._lock:
            self.port.command(cmd, self.clock.now())

    # -- what the helm says --------------------------------------------------------------------

    def _on_plan(self, msg: Path) -> None:
        points = path_points(msg, self.config.frame)
        if points is None or self._aborted and self._homeward != "abort":
            self.counters["plans_dropped"] += 1
            return
        self.counters["plans"] += 1
        self._plan = points
        if self._homeward == "return":
            self._command(ReturnHome(points))
        elif self._homeward == "abort":
            self._command(Abort(points, surface=False))
        else:
            self._command(GoTo(PLAN_TARGET, points))

    def _station_service(self, work: Work) -> Callable:
        def serve(_req: Trigger.Request, resp: Trigger.Response) -> Trigger.Response:
            if self._aborted:
                resp.success, resp.message = False, "aborted: the mission is over"
                return resp
            self._command(StationKeep(Work.WAIT, -1, 0.0))
            resp.success, resp.message = True, f"keeping station ({work.value})"
            return resp
        return serve

    def _on_return(self, req: SetBool.Request, resp: SetBool.Response) -> SetBool.Response:
        if self._aborted:
            resp.success, resp.message = False, "aborted: the mission is over"
            return resp
        self._homeward = "return" if req.data else ""
        if req.data and self._plan is not None:
            self._command(ReturnHome(self._plan))
        resp.success, resp.message = True, "returning" if req.data else "return cancelled"
        return resp

    def _on_abort(self, req: SetBool.Request, resp: SetBool.Response) -> SetBool.Response:
        self._aborted = True
        if req.data:
            self._homeward = ""
            self._command(Abort((), surface=True))
        else:
            self._homeward = "abort"
            if self._plan is not None:
                self._command(Abort(self._plan, surface=False))
        resp.success, resp.message = True, "surfacing" if req.data else "aborting home"
        return resp


def true_position(truth: object, yaw_deg: float) -> tuple[tuple[float, float, float], float]:
    """(position, yaw) of a port's ``true_pose()``: ``(pos, yaw, pitch)`` as the simulated
    vehicle gives it (`reef_sim.vehicle.SimVehicle.true_pose`), an object with ``pos``, or
    a bare position (then the fix's yaw)."""
    if hasattr(truth, "pos"):
        truth = getattr(truth, "pos")
    if not isinstance(truth, Iterable):
        raise TypeError(f"not a pose: {truth!r}")
    items = tuple(truth)
    if len(items) == 3 and isinstance(items[0], (tuple, list)):
        pos, yaw = items[0], float(items[1])
    else:
        pos, yaw = items, yaw_deg
    x, y, z = (float(v) for v in pos)
    return (x, y, z), yaw


# -- a process per vehicle --------------------------------------------------------------------


def load_factory(spec: str) -> Callable[..., VehiclePort]:
    """``module:callable`` -> the callable (it builds a port: ``f(problem, index, clock)``)."""
    module, _, name = spec.partition(":")
    if not module or not name:
        raise ValueError(f"factory must be module:callable, got {spec!r}")
    return getattr(importlib.import_module(module), name)


def main(argv: list[str] | None = None) -> int:
    from fleet_bus.process import process_stop, ready
    from hfc_core.formats.scenario import problem_from_dict

    ap = argparse.ArgumentParser(description="serve a simulated vehicle as a ROS 2 vehicle")
    ap.add_argument("--scenario", required=True, help="scenario JSON")
    ap.add_argument("--vehicle", type=int, required=True, help="vehicle index")
    ap.add_argument("--factory", required=True, help="module:callable building the port")
    ap.add_argument("--namespace", default="", help="ROS namespace (default /<vehicle id>)")
    ap.add_argument("--epoch", type=float, default=None, help="mission epoch, unix s")
    ap.add_argument("--warp", type=float, default=1.0)
    ap.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                    help="a mission's Zenoh router: run on the fleet's mission clock, "
                         "followed as it holds and slows (instead of --epoch and --warp)")
    ap.add_argument("--credentials", type=FilePath, metavar="DIR",
                    help="with --connect: a listen-only identity (the run's 'world')")
    ap.add_argument("--clock-timeout", type=float, default=600.0, metavar="S",
                    help="with --connect: wall seconds to wait for the clock")
    ap.add_argument("--rate-hz", type=float, default=10.0)
    args = ap.parse_args(argv)
    stop = process_stop()
    with open(args.scenario) as f:
        problem = problem_from_dict(json.load(f))
    ns = args.namespace or "/" + problem.vehicles[args.vehicle].id
    factory = load_factory(args.factory)
    config = BridgeConfig(namespace=ns, rate_hz=args.rate_hz)
    if not args.connect:
        clock = WarpClock(args.epoch if args.epoch is not None else time.time(), args.warp)
        return _serve(factory(problem, args.vehicle, clock), clock, config, stop, ready, ns)
    from fleet_agent.helms.choice import PendingClock
    from fleet_bus.credentials import load_auth
    from fleet_bus.mission import ClockSync
    from fleet_bus.session import client_config, open_session

    auth = load_auth(args.credentials) if args.credentials else None
    # Serving from now, at the vehicle's start, before the mission clock: the operator serves
    # it once every agent is ready, and an agent is ready once its vehicle answers.
    pending = PendingClock()
    bridge = VehicleBridge(factory(problem, args.vehicle, pending), pending, config)
    try:
        ready(READY, ns)
        with open_session(client_config(args.connect,
                                        credentials=args.credentials)) as session:
            sync = ClockSync(session, auth, stop)  # the operator's clock: offset, holds, pace
            mission_clock = sync.join(args.clock_timeout)
            if mission_clock is None:
                return 0 if stop.is_set() else 3
            pending.clock = mission_clock
            sync.start()
            try:
                stop.wait()
            finally:
                sync.close()
    finally:
        bridge.close()
    return 0


def _serve(port: VehiclePort, clock: Clock, config: BridgeConfig, stop: threading.Event,
           ready: Callable[[str, str], None], ns: str) -> int:
    bridge = VehicleBridge(port, clock, config)
    try:
        ready(READY, ns)
        stop.wait()
    finally:
        bridge.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
