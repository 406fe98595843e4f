"""`MoosHelm`: the vehicle port on a MOOS-IvP vehicle (its MOOSDB, pHelmIvP, its navigation).

The agent reads the vehicle's navigation (``NAV_X``, ``NAV_Y``, ``NAV_DEPTH``, ``NAV_HEADING``,
``NAV_SPEED``, placed in the scenario's frame through `LocalFrame`) and drives pHelmIvP through
the behaviours of the ``.bhv`` the project ships (`fleet_agent.helms.moos_mission`):

=================  ===============================================================
command            posts (one packet, in this order)
=================  ===============================================================
GoTo               ``WPT_UPDATE = points=pts={x,y:...:x,y,cotsleg_<n>}``,
                   ``DEPTH_UPDATE = depth=<d>``, ``COTS_ARRIVED = false``,
                   ``COTS_MODE = TRANSIT``
StationKeep        ``COTS_LOOK_REQUEST`` (a look, for an on-board detector),
                   ``COTS_MODE = STATION`` (BHV_StationKeep holds where it is)
ReturnHome         as GoTo with ``RETURN_UPDATE`` and ``COTS_MODE = RETURN``
Abort              as ReturnHome, or ``COTS_MODE = SURFACE`` when it surfaces
=================  ===============================================================

*Arrived* comes from the waypoint behaviour's end flag: its ``endflag = COTS_LEG_END =
$[POINTS]`` posts the points it finished, the last one tagged with the leg number the adapter
gave it; so a flag of a leg the agent has since replaced (one that crossed our new command on
the way) is recognised and ignored, and the arrival is the helm's own judgement (capture and
slip radius), the one it acts on, not a second opinion computed from a distance. The same
flag sets ``COTS_ARRIVED = true``, which idles the waypoint behaviour and holds station: the
vehicle stops at the end of a leg by itself, however late the agent answers.

*Refused*: the helm reports each behaviour update in ``IVPHELM_UPDATE_RESULT``; a
``result=param_error`` for one of ours refuses the command. A command given while the helm
is not driving (``IVPHELM_STATE`` other than ``DRIVE``: parked, manual override) or while the
MOOSDB is not connected is refused at once and not posted; a helm that leaves ``DRIVE``
during a command refuses it. (``BHV_ERROR`` is not a refusal: pHelmIvP posts
``MissingDecVars`` for the one iteration between a leg's end and station keeping.)

*Navigation that stops*: `nav_age_s` says how old the last fix is (mission seconds); the
agent decides what to do about it (`docs/onboard.md`).

Time: a fix is dated by the mission clock at receipt less its lag (the MOOS time since the
helm stamped it; under ``MOOSTimeWarp`` equal to the mission's warp MOOS seconds are mission
seconds). Thread-safe: the MOOS client's thread delivers mail, the agent's thread commands
and polls; the camera is only ever called under the adapter's lock.
"""

from __future__ import annotations

import logging
import math
import re
import threading
from dataclasses import dataclass, field

from fleet_agent.helms.camera import (
    Camera,
    DetectionError,
    LookResult,
    format_detection,
    parse_detection,
    sightings,
)
from fleet_agent.helms.duty import Duty
from fleet_agent.helms.frames import LocalFrame, finite_points, yaw_from_compass
from fleet_agent.helms.moos_client import MoosClient
from fleet_agent.helms.moos_wire import MoosMsg
from fleet_agent.helms.reports import NavStats, ReportBuffer
from fleet_bus.clock import Clock
from fleet_bus.vehicle_port import (
    Abort,
    Arrived,
    GoTo,
    HelmCommand,
    Injected,
    Looked,
    NavFix,
    Point3,
    Refused,
    ReturnHome,
    Sighted,
    StationKeep,
    VehicleReport,
    Work,
)

log = logging.getLogger(__name__)

# The variables of the shipped .bhv (`moos_mission` writes it with these names).
MODE_VAR = "COTS_MODE"
ARRIVED_VAR = "COTS_ARRIVED"
LEG_END_VAR = "COTS_LEG_END"
WPT_UPDATE_VAR = "WPT_UPDATE"
RETURN_UPDATE_VAR = "RETURN_UPDATE"
DEPTH_UPDATE_VAR = "DEPTH_UPDATE"
LOOK_REQUEST_VAR = "COTS_LOOK_REQUEST"
DETECTION_VAR = "COTS_DETECTION"  # on board: the detector's sightings and look results
TRANSIT, STATION, RETURN, SURFACE = "TRANSIT", "STATION", "RETURN", "SURFACE"
LEG_TAG = "cotsleg_"
_LEG_RE = re.compile(LEG_TAG + r"(\d+)")
HELM_STATE_VAR, UPDATE_RESULT_VAR = "IVPHELM_STATE", "IVPHELM_UPDATE_RESULT"
_OUR_UPDATES = (WPT_UPDATE_VAR, RETURN_UPDATE_VAR, DEPTH_UPDATE_VAR)


@dataclass(frozen=True)
class MoosHelmConfig:
    """Where the vehicle's MOOSDB is and how its navigation maps to the scenario."""

    host: str = "localhost"
    port: int = 9000
    client_name: str = "cotsfleet_agent"
    warp: float = 1.0  # the community's MOOSTimeWarp (the mission's warp in emulation)
    frame: LocalFrame = field(default_factory=LocalFrame)
    nav_prefix: str = "NAV"
    # Where the camera is (emulation): the simulator's true pose if it posts one apart from
    # the navigation estimate (uSimMarine's ``<prefix>_GT`` with ``dual_state``); None: the
    # navigation variables (uSimMarine without navigation error posts its true state there).
    truth_prefix: str | None = None
    sigma_m: float = 0.0  # 1-sigma of the navigation estimate (MOOS posts none by default)
    connect_timeout_s: float = 10.0
    max_fixes: int = 256
    max_events: int = 1024

    def __post_init__(self) -> None:
        if not (1 <= int(self.port) <= 65535):
            raise ValueError(f"MOOSDB port out of range: {self.port}")
        if not (math.isfinite(self.sigma_m) and self.sigma_m >= 0):
            raise ValueError(f"sigma_m must be >= 0, got {self.sigma_m}")


def points_spec(frame: LocalFrame, waypoints: tuple[Point3, ...], leg: int) -> str:
    """A waypoint behaviour's ``points=`` value for ``waypoints`` (scenario frame), the last
    vertex tagged with ``leg`` (BHV_Waypoint keeps a vertex's tag, and ``$[POINTS]`` shows it)."""
    verts = []
    for i, p in enumerate(waypoints):
        x, y, _ = frame.to_helm(p)
        tag = f",{LEG_TAG}{leg}" if i == len(waypoints) - 1 else ""
        verts.append(f"{x:.2f},{y:.2f}{tag}")
    return "points=pts={" + ":".join(verts) + "}"


def leg_of_flag(text: str) -> int | None:
    """The leg number in an end flag's ``$[POINTS]`` (None: not one of ours)."""
    found = _LEG_RE.findall(text)
    return int(found[-1]) if found else None


def parse_update_result(text: str) -> dict[str, str]:
    """``IVPHELM_UPDATE_RESULT``: ``bhv=..,var=..,time=..,result=..,val=<the update>`` (the
    update itself may hold commas: it is everything after ``,val=``)."""
    head, _, val = text.partition(",val=")
    out = {}
    for part in head.split(","):
        k, _, v = part.partition("=")
        out[k.strip()] = v.strip()
    out["val"] = val
    return out


class MoosHelm:
    """A `fleet_bus.vehicle_port.VehiclePort` on a MOOS-IvP vehicle (module docstring)."""

    name = "moos"

    def __init__(self, clock: Clock, config: MoosHelmConfig = MoosHelmConfig(),
                 camera: Camera | None = None, connect: bool = True) -> None:
        self.clock, self.config, self.camera = clock, config, camera
        self._camera_at: Point3 | None = None  # the camera's last true position
        self._lock = threading.RLock()
        self._duty = Duty()
        self._reports = ReportBuffer(config.max_fixes, config.max_events)
        self.stats = NavStats()
        self._nav: dict[str, tuple[float, float]] = {}  # var -> (value, MOOS time)
        self._truth: dict[str, float] = {}
        self._last_sent: dict[str, str] = {}
        self._helm_state = ""
        self._cmd_moos_t = math.inf  # MOOS time the command under way was posted
        self._look_result: LookResult | None = None
        self.dropped_detections = 0
        # How far the vehicle's MOOS time has run from the mission clock since the first fix
        # (MOOS seconds less mission seconds): MOOSTimeWarp is fixed, the fleet's clock is not.
        self.clock_drift_s = 0.0
        self.clock_drift_max_s = 0.0
        self._first_stamp: tuple[float, float] | None = None  # (MOOS time, mission time)
        self._closed = False
        p, t = config.nav_prefix, config.truth_prefix
        self._nav_vars = {f"{p}_{s}": s for s in ("X", "Y", "DEPTH", "HEADING", "SPEED")}
        self._truth_vars = {f"{t}_{s}": s for s in ("X", "Y", "DEPTH")} if t else {}
        self.client = MoosClient(config.host, config.port, config.client_name, config.warp,
                                 on_mail=self._on_mail)
        self.client.register(*self._nav_vars, *self._truth_vars, LEG_END_VAR, HELM_STATE_VAR,
                             UPDATE_RESULT_VAR, DETECTION_VAR)
        if connect:
            self.client.start()
            if not self.client.wait_connected(config.connect_timeout_s):
                self.client.close()
                reason = self.client.refused_reason or "no answer"
                raise ConnectionError(
                    f"no MOOSDB at {config.host}:{config.port} ({reason})")

    # -- VehiclePort ---------------------------------------------------------------------------

    def command(self, cmd: HelmCommand, t_s: float) -> None:
        with self._lock:
            why = self._cannot(cmd)
            if why:
                self._reports.add(Refused(t_s, type(cmd).__name__, why))
                return
            self._duty.start(cmd, t_s)
            self._cmd_moos_t = self.client.moos_now()
            posts = self._posts(cmd, self._duty.leg)
            for key, value in posts:
                self._last_sent[key] = str(value)
            if not self.client.notify_many(posts):
                self._duty.refuse()
                self._reports.add(Refused(t_s, type(cmd).__name__, "MOOSDB not connected"))

    def poll(self, until_s: float) -> list[VehicleReport]:
        with self._lock:
            due = self._duty.due_work(until_s)
            if due is not None:
                work, task, end_s = due
                if work is Work.LOOK:
                    present, prio, service = self._look(task)
                    self._reports.add(Looked(end_s, task, present, prio, service))
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
        self.client.close()

    # -- what the agent may ask besides the port ----------------------------------------------

    def nav_age_s(self) -> float:
        """Mission seconds since the last navigation fix (inf: none yet)."""
        return self.stats.age_s(self.clock.now())

    @property
    def helm_state(self) -> str:
        return self._helm_state

    def figures(self) -> dict[str, int]:
        """What the agent's status counts of its helm: the worst lag of a fix from the
        helm's stamp to its receipt, fixes and detections dropped, the MOOS clock's drift."""
        return {"helm_fix_lag_max_ms": int(round(1000.0 * self.stats.lag_max_s)),
                "helm_fixes_dropped": self._reports.dropped_fixes,
                "helm_events_dropped": self._reports.dropped_events + self.dropped_detections,
                "helm_clock_drift_max_ms": int(round(1000.0 * self.clock_drift_max_s))}

    def true_pose(self) -> tuple[Point3, float, float] | None:
        """Where the vehicle really is, for the simulation's bookkeeping (emulation): the
        simulator's true state if it posts one apart (``truth_prefix``), else its navigation
        (uSimMarine without navigation error); None before the first fix."""
        with self._lock:
            fix = self.stats.last_fix
            if fix is None:
                return None
            if self._truth_vars and "X" in self._truth and "Y" in self._truth:
                pos = self.config.frame.to_scenario(self._truth["X"], self._truth["Y"],
                                                    -self._truth.get("DEPTH", 0.0))
                return pos, fix.yaw_deg, fix.pitch_deg
            return fix.pos, fix.yaw_deg, fix.pitch_deg

    # -- commands ------------------------------------------------------------------------------

    def _cannot(self, cmd: HelmCommand) -> str:
        if self._closed:
            return "helm adapter closed"
        if not self.client.connected:
            return "MOOSDB not connected"
        if self._helm_state and self._helm_state != "DRIVE":
            return f"helm is {self._helm_state}, not DRIVE"
        if isinstance(cmd, (GoTo, ReturnHome)) or (isinstance(cmd, Abort) and not cmd.surface):
            if not cmd.waypoints:
                return "no waypoints"
            if not finite_points(cmd.waypoints):
                return "waypoints not finite"
        if isinstance(cmd, StationKeep) and not math.isfinite(cmd.duration_s):
            return "duration not finite"
        return ""

    def _posts(self, cmd: HelmCommand, leg: int) -> list[tuple[str, float | str]]:
        if isinstance(cmd, StationKeep):
            posts: list[tuple[str, float | str]] = []
            if cmd.work is Work.LOOK:
                fix = self.stats.last_fix
                at = self.config.frame.to_helm(fix.pos) if fix else (math.nan,) * 3
                posts.append((LOOK_REQUEST_VAR, format_detection(
                    "look", task=cmd.task, x=at[0], y=at[1], z=at[2],
                    duration_s=float(cmd.duration_s))))
            return posts + [(MODE_VAR, STATION)]
        if isinstance(cmd, Abort) and cmd.surface:
            return [(MODE_VAR, SURFACE)]
        assert isinstance(cmd, (GoTo, ReturnHome, Abort))
        update, mode = ((WPT_UPDATE_VAR, TRANSIT) if isinstance(cmd, GoTo)
                        else (RETURN_UPDATE_VAR, RETURN))
        depth = max(0.0, -float(cmd.waypoints[-1][2]))
        return [(update, points_spec(self.config.frame, cmd.waypoints, leg)),
                (DEPTH_UPDATE_VAR, f"depth={depth:.2f}"),
                (ARRIVED_VAR, "false"), (MODE_VAR, mode)]

    def _look(self, task: int) -> tuple[bool, float, float]:
        if self.camera is not None:  # a find holds what lies under the camera
            return self.camera.inspect(task, self._camera_at)
        seen = self._look_result
        if seen is not None and seen.task == task:
            self._look_result = None
            return seen.present, seen.priority, seen.service_s
        return False, 0.0, 0.0  # the detector said nothing of this spot: nothing seen

    # -- mail ----------------------------------------------------------------------------------

    def _mission_time(self, moos_t: float) -> tuple[float, float]:
        """(mission time, lag) of a MOOS time stamp: now less the MOOS seconds since it."""
        lag = max(0.0, self.client.moos_now() - moos_t) if moos_t > 0 else 0.0
        return self.clock.now() - lag, lag

    def _on_mail(self, mail: list[MoosMsg]) -> None:
        with self._lock:
            if self._closed:
                return
            nav_seen = False
            for m in mail:
                if m.key in self._nav_vars and m.is_double:
                    self._nav[self._nav_vars[m.key]] = (float(m.value), m.time)
                    nav_seen = nav_seen or self._nav_vars[m.key] in ("X", "Y")
                elif m.key in self._truth_vars and m.is_double:
                    self._truth[self._truth_vars[m.key]] = float(m.value)
                else:
                    self._on_event(m)
            if nav_seen:
                self._on_nav()

    def _on_nav(self) -> None:
        if "X" not in self._nav or "Y" not in self._nav:
            return
        stamp = max(self._nav["X"][1], self._nav["Y"][1])
        t_s, lag = self._mission_time(stamp)
        self._clock_drift(stamp, t_s)
        last = self.stats.last_fix
        if last is not None and t_s <= last.t_s:  # never a fix older than the last one
            t_s = last.t_s
        val = {k: v for k, (v, _) in self._nav.items()}
        if not all(math.isfinite(v) for v in val.values()):
            return
        pos = self.config.frame.to_scenario(val["X"], val["Y"], -val.get("DEPTH", 0.0))
        fix = NavFix(t_s, pos, self.config.sigma_m, yaw_from_compass(val.get("HEADING", 90.0)),
                     0.0, val.get("SPEED"))
        self.stats.record(fix, lag)
        self._reports.add(fix)
        if self.camera is not None:
            self._sweep(fix)

    def _clock_drift(self, stamp: float, t_s: float) -> None:
        """MOOS seconds less mission seconds since the first fix, from the simulator's own
        stamps: the vehicle's clock against the fleet's."""
        if stamp <= 0 or t_s < 0:  # from the mission's start on
            return
        if self._first_stamp is None:
            self._first_stamp = (stamp, t_s)
            return
        drift = (stamp - self._first_stamp[0]) - (t_s - self._first_stamp[1])
        self.clock_drift_s = drift
        self.clock_drift_max_s = max(self.clock_drift_max_s, abs(drift))

    def _sweep(self, fix: NavFix) -> None:
        true = fix.pos
        if self._truth_vars:
            if "X" not in self._truth or "Y" not in self._truth:
                return
            true = self.config.frame.to_scenario(
                self._truth["X"], self._truth["Y"], -self._truth.get("DEPTH", 0.0))
        if self.camera is not None:  # no camera on this vehicle: nothing to see
            self._camera_at = true  # where a look at a find looks (`_look`)
            for s in sightings(self.camera, fix, true):
                self._reports.add(s)

    def _on_event(self, m: MoosMsg) -> None:
        text = m.text if not m.is_double else ""
        if m.key == LEG_END_VAR:
            leg = leg_of_flag(text)
            target = self._duty.arrival(leg) if leg is not None else None
            if target is not None:
                self._reports.add(Arrived(self._mission_time(m.time)[0], target))
        elif m.key == HELM_STATE_VAR:
            before, self._helm_state = self._helm_state, text
            if before == "DRIVE" and text != "DRIVE":
                self._refuse(m, f"helm left DRIVE for {text}")
        elif m.key == UPDATE_RESULT_VAR:
            res = parse_update_result(text)
            var = res.get("var", "")
            if (var in _OUR_UPDATES and res.get("result") == "param_error"
                    and res["val"] == self._last_sent.get(var)):
                self._refuse(m, f"{res.get('bhv', '?')} rejected {var}: {res['val']}")
        elif m.key == DETECTION_VAR and self.camera is None:
            self._on_detection(m, text)

    def _refuse(self, m: MoosMsg, reason: str) -> None:
        if m.time < self._cmd_moos_t:  # said before our command (a value the DB kept)
            return
        kind = self._duty.refuse()
        if kind is not None:
            self._reports.add(Refused(self._mission_time(m.time)[0], kind, reason))

    def _on_detection(self, m: MoosMsg, text: str) -> None:
        try:
            seen = parse_detection(text)
        except DetectionError as err:
            self.dropped_detections += 1
            log.warning("MOOS %s dropped: %s", DETECTION_VAR, err)
            return
        if isinstance(seen, LookResult):
            self._look_result = seen
            return
        x, y, z = seen.pos
        self._reports.add(Sighted(self._mission_time(m.time)[0],
                                  self.config.frame.to_scenario(x, y, z),
                                  seen.priority, seen.service_s))
