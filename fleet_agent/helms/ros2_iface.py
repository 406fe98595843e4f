"""The ROS 2 interface between the agent's helm and a vehicle, both sides (needs rclpy).

Only interface types installable from PyPI are used (no rosidl generation), so a vehicle
built with any ROS 2 distribution's standard packages can take part. Names are relative (put
each vehicle in its own namespace, ``/auv1``) and configurable (`Ros2Names`):

===================  ==========================  =====================================
name                 type                        meaning
===================  ==========================  =====================================
``odom``             nav_msgs/msg/Odometry       vehicle -> helm: navigation estimate
                                                 (pose in ``frame_id``, ENU, REP 103/105;
                                                 covariance[0], [7]: its x, y variance)
``ground_truth/odom`` nav_msgs/msg/Odometry      vehicle -> helm, emulation only: the true
                                                 pose, where the simulated camera looks
``goal_pose``        geometry_msgs/msg/PoseStamped  helm -> vehicle: the end of the leg
``plan``             nav_msgs/msg/Path           helm -> vehicle: the leg's waypoints, ending
                                                 at the goal: the path to follow
``route``            nav_msgs/msg/Path           helm -> vehicle: the goal then the spots
                                                 after it (display, a vehicle's own planner)
``vehicle_events``   std_msgs/msg/String         vehicle -> helm: ``kind=sighting,...``,
                                                 ``kind=look,...`` (`camera`),
                                                 ``kind=refused,command=GoTo,reason=...``
``look`` ``inject``  std_srvs/srv/Trigger        keep station here and look / inject / wait
``hold``                                         (until the next command; the helm times the
                                                 work and owes Looked / Injected)
``return_home``      std_srvs/srv/SetBool        true: the plan now published leads home:
                                                 follow it and stay there; false: cancel
``abort``            std_srvs/srv/SetBool        give up the mission: true surface here,
                                                 false follow the plan home
===================  ==========================  =====================================

A service answers ``success=false`` (its ``message`` the reason) to refuse. The vehicle need
not say when it arrived: the helm judges it from odometry (within ``arrive_radius_m`` of the
goal, as Nav2's goal checker does), since no standard message says so without actions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from builtin_interfaces.msg import Time as TimeMsg
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry, Path
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from fleet_agent.helms.frames import (
    LocalFrame,
    quaternion_from_yaw,
    yaw_from_quaternion,
)
from fleet_bus.vehicle_port import NavFix, Point3

# Commands last: a late joiner (a vehicle restarting) gets the leg under way.
LATCHED = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
STREAM = QoSProfile(depth=20, history=HistoryPolicy.KEEP_LAST,
                    reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE)
EVENTS = QoSProfile(depth=100, history=HistoryPolicy.KEEP_LAST,
                    reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE)
MAX_PATH_POSES = 10_000  # a path longer than this is not a leg (dropped, counted)


@dataclass(frozen=True)
class Ros2Names:
    """Topic and service names (relative: under the vehicle's namespace) and the frame."""

    odom: str = "odom"
    truth: str = "ground_truth/odom"
    goal: str = "goal_pose"
    plan: str = "plan"
    route: str = "route"
    events: str = "vehicle_events"
    look: str = "look"
    inject: str = "inject"
    hold: str = "hold"
    return_home: str = "return_home"
    abort: str = "abort"
    frame_id: str = "map"


def stamp_of(wall_s: float) -> TimeMsg:
    sec = math.floor(wall_s)
    return TimeMsg(sec=int(sec), nanosec=min(999_999_999, int((wall_s - sec) * 1e9)))


def wall_of(stamp: TimeMsg) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def pose_stamped(p: Point3, frame: LocalFrame, frame_id: str, wall_s: float,
                 yaw_deg: float = 0.0) -> PoseStamped:
    x, y, z = frame.to_helm(p)
    msg = PoseStamped()
    msg.header.frame_id, msg.header.stamp = frame_id, stamp_of(wall_s)
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = float(x), float(y), float(z)
    q = quaternion_from_yaw(yaw_deg)
    msg.pose.orientation.x, msg.pose.orientation.y = q[0], q[1]
    msg.pose.orientation.z, msg.pose.orientation.w = q[2], q[3]
    return msg


def path_msg(points: tuple[Point3, ...], frame: LocalFrame, frame_id: str,
             wall_s: float) -> Path:
    """A Path through ``points`` (scenario frame), each pose facing the next."""
    msg = Path()
    msg.header.frame_id, msg.header.stamp = frame_id, stamp_of(wall_s)
    prev = None
    for i, p in enumerate(points):
        nxt = points[i + 1] if i + 1 < len(points) else None
        a, b = (p, nxt) if nxt is not None else (prev, p)
        yaw = math.degrees(math.atan2(b[1] - a[1], b[0] - a[0])) if a is not None else 0.0
        msg.poses.append(pose_stamped(p, frame, frame_id, wall_s, yaw))
        prev = p
    return msg


def path_points(msg: Path, frame: LocalFrame) -> tuple[Point3, ...] | None:
    """The points of a Path in the scenario frame (None: empty, too long or not finite)."""
    if not msg.poses or len(msg.poses) > MAX_PATH_POSES:
        return None
    out = []
    for ps in msg.poses:
        q = ps.pose.position
        if not all(math.isfinite(c) for c in (q.x, q.y, q.z)):
            return None
        out.append(frame.to_scenario(q.x, q.y, q.z))
    return tuple(out)


def odometry(fix: NavFix, frame: LocalFrame, frame_id: str, child_frame_id: str,
             wall_s: float) -> Odometry:
    """A navigation fix as Odometry (twist along the body x axis, REP 105)."""
    msg = Odometry()
    msg.header.frame_id, msg.header.stamp = frame_id, stamp_of(wall_s)
    msg.child_frame_id = child_frame_id
    ps = pose_stamped(fix.pos, frame, frame_id, wall_s, fix.yaw_deg)
    msg.pose.pose = ps.pose
    var = float(fix.sigma_m) ** 2
    cov = [0.0] * 36
    cov[0] = cov[7] = var
    msg.pose.covariance = cov
    msg.twist.twist.linear.x = float(fix.speed_mps or 0.0)
    return msg


def fix_of(msg: Odometry, frame: LocalFrame, t_s: float) -> NavFix | None:
    """The navigation fix an Odometry carries, dated ``t_s`` (None: not finite)."""
    p, o = msg.pose.pose.position, msg.pose.pose.orientation
    v = msg.twist.twist.linear
    vals = (p.x, p.y, p.z, o.x, o.y, o.z, o.w, v.x, v.y, v.z)
    if not all(math.isfinite(c) for c in vals):
        return None
    cov = msg.pose.covariance
    var = max(float(cov[0]), float(cov[7])) if len(cov) == 36 else 0.0
    sigma = math.sqrt(var) if math.isfinite(var) and var > 0 else 0.0
    return NavFix(t_s, frame.to_scenario(p.x, p.y, p.z), sigma,
                  yaw_from_quaternion(o.x, o.y, o.z, o.w), 0.0, math.hypot(v.x, v.y, v.z))
