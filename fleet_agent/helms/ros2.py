"""`Ros2Helm`: the vehicle port on a ROS 2 vehicle, as an rclpy node (needs the ``ros2`` extra).

It takes the vehicle's ``nav_msgs/Odometry``, publishes each leg as a ``nav_msgs/Path`` (the
``plan``) with its ``geometry_msgs/PoseStamped`` goal and the ``route`` ahead, and calls the
vehicle's ``std_srvs`` services for station keeping, return and abort (the interface:
`fleet_agent.helms.ros2_iface`). The node runs on its own rclpy context and executor thread,
so several helms (a fleet in one process) and the agent's own threads never share one.

- *Arrived*: the first odometry within ``arrive_radius_m`` (horizontal) of the leg's goal.
- *Looked / Injected*: the helm times the work on the mission clock (the vehicle keeps
  station); a look's result is the injected camera's or, on board, the vehicle's last
  ``kind=look`` event for that spot.
- *Refused*: a service that answers ``success=false`` or is not there; a ``kind=refused``
  event (a vehicle that could not take the plan); a command given after close.
- *Navigation that stops*: `nav_age_s`.

Time: a fix is dated by the mission clock at receipt less its lag (the wall time since its
header stamp times the warp). Thread-safe: rclpy callbacks run on the executor thread, the
agent commands and polls from its own; the camera is called under the helm's lock only.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import rclpy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry, Path
from rclpy.client import Client
from rclpy.context import Context
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from std_msgs.msg import String
from std_srvs.srv import SetBool, Trigger

from fleet_agent.helms.camera import (Camera, DetectionError, LookResult, Point3,
                                      parse_detection, sightings)
from fleet_agent.helms.duty import Duty
from fleet_agent.helms.frames import LocalFrame, finite_points
from fleet_agent.helms.reports import NavStats, ReportBuffer
from fleet_agent.helms.ros2_iface import (
    EVENTS,
    LATCHED,
    STREAM,
    Ros2Names,
    fix_of,
    path_msg,
    pose_stamped,
    wall_of,
)
from fleet_bus.clock import Clock
from fleet_bus.vehicle_port import (
    Abort,
    Arrived,
    GoTo,
    HelmCommand,
    Injected,
    Looked,
    NavFix,
    Refused,
    ReturnHome,
    Sighted,
    StationKeep,
    VehicleReport,
    Work,
)

log = logging.getLogger(__name__)
ACK_WAIT_S = 0.5  # how long a plan may take to reach the vehicle before a service follows it


@dataclass(frozen=True)
class Ros2HelmConfig:
    namespace: str = ""  # the vehicle's, e.g. "/auv1"
    names: Ros2Names = field(default_factory=Ros2Names)
    frame: LocalFrame = field(default_factory=LocalFrame)
    warp: float = 1.0  # mission seconds per wall second (1 on board)
    arrive_radius_m: float = 2.0
    use_truth: bool = False  # the camera looks from ``names.truth`` (emulation)
    node_name: str = "cotsfleet_helm"
    service_timeout_s: float = 5.0  # wall: a vehicle that does not answer by then refused
    max_fixes: int = 256
    max_events: int = 1024

    def __post_init__(self) -> None:
        if not (math.isfinite(self.warp) and self.warp > 0):
            raise ValueError(f"warp must be positive, got {self.warp}")
        if not (math.isfinite(self.arrive_radius_m) and self.arrive_radius_m > 0):
            raise ValueError(f"arrive_radius_m must be positive, got {self.arrive_radius_m}")


class Ros2Helm:
    """A `fleet_bus.vehicle_port.VehiclePort` on a ROS 2 vehicle (module docstring)."""

    name = "ros2"

    def __init__(self, clock: Clock, config: Ros2HelmConfig = Ros2HelmConfig(),
                 camera: Camera | None = None) -> None:
        self.clock, self.config, self.camera = clock, config, camera
        self._camera_at: Point3 | None = None  # the camera's last true position
        self._lock = threading.RLock()
        self._duty = Duty()
        self._generation = 0  # bumps with every command: a late service answer is stale
        self._goal: tuple[float, float, float] | None = None
        self._homeward = False
        self._reports = ReportBuffer(config.max_fixes, config.max_events)
        self.stats = NavStats()
        self._truth: tuple[float, float, float] | None = None
        self._truth_yaw = 0.0
        self._look_result: LookResult | None = None
        self._pending: list[tuple] = []  # (future, client, deadline, generation, kind)
        self.dropped = {"odometry": 0, "events": 0}
        self._closed = False
        n = config.names
        self._context = Context()
        rclpy.init(context=self._context, args=[])
        try:
            self.node = rclpy.create_node(config.node_name, namespace=config.namespace,
                                          context=self._context)
            node = self.node
            node.create_subscription(Odometry, n.odom, self._on_odom, STREAM)
            node.create_subscription(String, n.events, self._on_event, EVENTS)
            if config.use_truth:
                node.create_subscription(Odometry, n.truth, self._on_truth, STREAM)
            self._goal_pub = node.create_publisher(PoseStamped, n.goal, LATCHED)
            self._plan_pub = node.create_publisher(Path, n.plan, LATCHED)
            self._route_pub = node.create_publisher(Path, n.route, LATCHED)
            # Any: std_srvs from PyPI has no type information (pyproject's [tool.mypy])
            self._station: dict[Work, Client[Any, Any]] = {
                Work.LOOK: node.create_client(Trigger, n.look),
                Work.INJECT: node.create_client(Trigger, n.inject),
                Work.WAIT: node.create_client(Trigger, n.hold)}
            self._return: Client[Any, Any] = node.create_client(SetBool, n.return_home)
            self._abort: Client[Any, Any] = node.create_client(SetBool, n.abort)
            self._executor = SingleThreadedExecutor(context=self._context)
            self._executor.add_node(node)
            self._thread = threading.Thread(target=self._spin, name="ros2-helm", daemon=True)
            self._thread.start()
        except Exception:
            rclpy.shutdown(context=self._context)
            raise

    def _spin(self) -> None:
        try:
            self._executor.spin()
        except ExternalShutdownException:
            pass

    def wait_for_vehicle(self, timeout_s: float) -> bool:
        """True once the vehicle's services are there and a fix came (wall ``timeout_s``)."""
        end = time.monotonic() + timeout_s
        clients = [*self._station.values(), self._return, self._abort]
        while time.monotonic() < end:
            if all(c.service_is_ready() for c in clients) and self.stats.last_fix is not None:
                return True
            time.sleep(0.05)
        return False

    # -- VehiclePort ---------------------------------------------------------------------------

    def command(self, cmd: HelmCommand, t_s: float) -> None:
        kind = type(cmd).__name__
        with self._lock:
            why = self._cannot(cmd)
            if why:
                self._reports.add(Refused(t_s, kind, why))
                return
            self._duty.start(cmd, t_s)
            self._generation += 1
            gen = self._generation
            self._goal = None
        if isinstance(cmd, StationKeep):
            self._call(self._station[cmd.work], Trigger.Request(), gen, kind)
            return
        if isinstance(cmd, Abort) and cmd.surface:
            self._call(self._abort, SetBool.Request(data=True), gen, kind)
            return
        assert isinstance(cmd, (GoTo, ReturnHome, Abort))
        if isinstance(cmd, GoTo) and self._homeward:
            # A vehicle sent home goes on to a spot only once told the return is off; the
            # answer comes before the plan is published (a service call is in order).
            self._homeward = False
            self._call(self._return, SetBool.Request(data=False), gen, kind, wait_s=2.0)
        self._publish_leg(cmd)
        if isinstance(cmd, GoTo):
            return
        self._homeward = True
        # The plan first, acknowledged by the vehicle's reader, then the service that says
        # what it is (a vehicle also copes with the other order: ros2_vehicle).
        self._plan_pub.wait_for_all_acked(Duration(seconds=ACK_WAIT_S))
        client = self._return if isinstance(cmd, ReturnHome) else self._abort
        # return_home data=true: the plan leads home; abort data=false: return, not surface.
        self._call(client, SetBool.Request(data=isinstance(cmd, ReturnHome)), gen, kind)

    def poll(self, until_s: float) -> list[VehicleReport]:
        self._expire_calls()
        with self._lock:
            due = self._duty.due_work(until_s)
            if due is not None:
                work, task, end_s = due
                if work is Work.LOOK:
                    self._reports.add(Looked(end_s, task, *self._look(task)))
                else:
                    self._reports.add(Injected(end_s, task))
        return self._reports.take(until_s)

    def next_report_s(self) -> float | None:
        """When the look or injection it times ends (its arrivals come when they come)."""
        with self._lock:
            return self._duty.work_end_s

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
        self._executor.shutdown(timeout_sec=2.0)
        self.node.destroy_node()
        rclpy.shutdown(context=self._context)
        self._thread.join(timeout=5.0)

    def nav_age_s(self) -> float:
        """Mission seconds since the last navigation fix (inf: none yet)."""
        return self.stats.age_s(self.clock.now())

    def figures(self) -> dict[str, int]:
        """What the agent's status counts of its helm: the worst lag of a fix from its
        header stamp to its receipt, odometry and events dropped."""
        return {"helm_fix_lag_max_ms": int(round(1000.0 * self.stats.lag_max_s)),
                "helm_fixes_dropped": self._reports.dropped_fixes + self.dropped["odometry"],
                "helm_events_dropped": self._reports.dropped_events + self.dropped["events"]}

    def true_pose(self) -> tuple[tuple[float, float, float], float, float] | None:
        """Where the vehicle really is (emulation: ``ground_truth/odom`` with ``use_truth``,
        else its navigation); None before anything came."""
        with self._lock:
            if self._truth is not None:
                return self._truth, self._truth_yaw, 0.0
            fix = self.stats.last_fix
            return None if fix is None else (fix.pos, fix.yaw_deg, fix.pitch_deg)

    # -- commands ------------------------------------------------------------------------------

    def _cannot(self, cmd: HelmCommand) -> str:
        if self._closed:
            return "helm adapter closed"
        if isinstance(cmd, (GoTo, ReturnHome)) or (isinstance(cmd, Abort) and not cmd.surface):
            if not cmd.waypoints:
                return "no waypoints"
            if not finite_points(cmd.waypoints):
                return "waypoints not finite"
        if isinstance(cmd, StationKeep) and not math.isfinite(cmd.duration_s):
            return "duration not finite"
        return ""

    def _publish_leg(self, cmd: GoTo | ReturnHome | Abort) -> None:
        c, n, now = self.config, self.config.names, time.time()
        goal = cmd.waypoints[-1]
        with self._lock:
            self._goal = goal
        ahead = cmd.ahead if isinstance(cmd, GoTo) else ()
        self._route_pub.publish(path_msg((goal, *ahead), c.frame, n.frame_id, now))
        self._goal_pub.publish(pose_stamped(goal, c.frame, n.frame_id, now))
        self._plan_pub.publish(path_msg(cmd.waypoints, c.frame, n.frame_id, now))

    def _call(self, client, request, gen: int, kind: str, wait_s: float = 0.0) -> None:
        if not client.service_is_ready():
            self._refuse(gen, kind, f"service {client.srv_name} not available")
            return
        future = client.call_async(request)

        def done(f) -> None:
            try:
                resp = f.result()
            except Exception as err:  # the vehicle went away mid-call
                self._refuse(gen, kind, f"{client.srv_name}: {err}")
                return
            if resp is not None and not resp.success:
                self._refuse(gen, kind, f"{client.srv_name}: {resp.message or 'refused'}")

        future.add_done_callback(done)
        with self._lock:
            self._pending.append((future, client, time.monotonic() + self.config.service_timeout_s,
                                  gen, kind))
        if wait_s > 0:
            end = time.monotonic() + wait_s
            while not future.done() and time.monotonic() < end:
                time.sleep(0.005)

    def _expire_calls(self) -> None:
        """Refuse the commands whose service call went unanswered past the timeout (a vehicle
        that vanished: discovery may still list its service for a while)."""
        now = time.monotonic()
        with self._lock:
            pending, self._pending = self._pending, []
            for future, client, deadline, gen, kind in pending:
                if future.done():
                    continue
                if now < deadline:
                    self._pending.append((future, client, deadline, gen, kind))
                    continue
                client.remove_pending_request(future)
                future.cancel()
                self._refuse(gen, kind, f"{client.srv_name}: no answer in "
                             f"{self.config.service_timeout_s:g} s")

    def _refuse(self, gen: int, kind: str, reason: str) -> None:
        with self._lock:
            if gen != self._generation or self._duty.refuse() is None:
                return  # an answer to a command since replaced
            self._reports.add(Refused(self.clock.now(), kind, reason))

    def _look(self, task: int) -> tuple[bool, float, float]:
        if self.camera is not None:  # a find holds what lies under the camera
            return self.camera.inspect(task, self._camera_at)
        seen = self._look_result
        if seen is not None and seen.task == task:
            self._look_result = None
            return seen.present, seen.priority, seen.service_s
        return False, 0.0, 0.0

    # -- callbacks (executor thread) -----------------------------------------------------------

    def _mission_time(self, stamp) -> tuple[float, float]:
        warp = getattr(self.clock, "warp", None) or self.config.warp  # the clock's, as it is
        lag = max(0.0, time.time() - wall_of(stamp)) * warp
        return self.clock.now() - lag, lag

    def _on_odom(self, msg: Odometry) -> None:
        with self._lock:
            if self._closed:
                return
            t_s, lag = self._mission_time(msg.header.stamp)
            last = self.stats.last_fix
            if last is not None and t_s < last.t_s:
                t_s = last.t_s
            fix = fix_of(msg, self.config.frame, t_s)
            if fix is None:
                self.dropped["odometry"] += 1
                return
            self.stats.record(fix, lag)
            self._reports.add(fix)
            if self._goal is not None and math.dist(fix.pos[:2], self._goal[:2]) <= \
                    self.config.arrive_radius_m:
                target = self._duty.arrival(self._duty.leg)
                if target is not None:
                    self._reports.add(Arrived(t_s, target))
            if self.camera is not None:
                self._sweep(fix)

    def _on_truth(self, msg: Odometry) -> None:
        fix = fix_of(msg, self.config.frame, 0.0)
        if fix is not None:
            with self._lock:
                self._truth, self._truth_yaw = fix.pos, fix.yaw_deg

    def _sweep(self, fix: NavFix) -> None:
        true = fix.pos
        if self.config.use_truth:
            if self._truth is None:
                return
            true = self._truth
        if self.camera is not None:  # no camera on this vehicle: nothing to see
            self._camera_at = true  # where a look at a find looks (`_look`)
            for s in sightings(self.camera, fix, true):
                self._reports.add(s)

    def _on_event(self, msg: String) -> None:
        text = msg.data
        if text.startswith("kind=refused"):
            fields = dict(p.partition("=")[::2] for p in text.split(",", 2))
            with self._lock:
                kind = self._duty.refuse()
                if kind is not None:
                    self._reports.add(Refused(self.clock.now(), kind,
                                              fields.get("reason", "")[:200] or "refused"))
            return
        try:
            seen = parse_detection(text)
        except DetectionError as err:
            self.dropped["events"] += 1
            log.warning("ROS 2 %s dropped: %s", self.config.names.events, err)
            return
        with self._lock:
            if isinstance(seen, LookResult):
                self._look_result = seen
            elif self.camera is None:
                x, y, z = seen.pos
                self._reports.add(Sighted(self.clock.now(),
                                          self.config.frame.to_scenario(x, y, z),
                                          seen.priority, seen.service_s))
