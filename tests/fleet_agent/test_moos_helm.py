"""The MOOS-IvP helm: its pure parts always; against real MOOS-IvP apps when they are on PATH.

The integration tests start a vehicle's community (MOOSDB, uSimMarineV22, pMarinePIDV22,
pHelmIvP) from PATH with the mission `write_moos_mission` writes, at warp 10, and drive it
through `MoosHelm`. Build MOOS-IvP from its public sources and put its ``bin`` on PATH to run
them (docs/onboard.md); without the binaries they skip, naming what is missing.
"""

from __future__ import annotations

import math
import shutil
import socket
import struct
import subprocess
import time
from pathlib import Path

import pytest

from fleet_agent.helms import moos_wire as wire
from fleet_agent.helms.camera import (
    DetectionError,
    LookResult,
    Sighting,
    format_detection,
    parse_detection,
)
from fleet_agent.helms.duty import Duty
from fleet_agent.helms.frames import (
    LocalFrame,
    compass_from_yaw,
    quaternion_from_yaw,
    yaw_from_compass,
    yaw_from_quaternion,
)
from fleet_agent.helms.moos import (
    MoosHelm,
    MoosHelmConfig,
    leg_of_flag,
    parse_update_result,
    points_spec,
)
from fleet_agent.helms.moos_client import MoosClient
from fleet_agent.helms.moos_mission import (
    MOOS_APPS,
    render_bhv,
    render_moos,
    write_moos_mission,
)
from fleet_agent.helms.reports import NavStats, ReportBuffer
from fleet_bus.clock import WarpClock
from fleet_bus.vehicle_port import (
    HOME_TARGET,
    Abort,
    Arrived,
    GoTo,
    Injected,
    Looked,
    NavFix,
    Refused,
    ReturnHome,
    StationKeep,
    Work,
)
from reef_sim.scenarios.field import paper_preset_doc
from hfc_core.model.problem import Problem, Task, Vehicle
from hfc_core.formats.scenario import problem_from_dict

# -- the wire codec ---------------------------------------------------------------------------


def test_packet_round_trip_keeps_every_field() -> None:
    msgs = [
        wire.MoosMsg(wire.NOTIFY, "NAV_X", 12.5, 1e9, "uSimMarineV22", "aux", "auv1"),
        wire.MoosMsg(wire.NOTIFY, "WPT_UPDATE", "points=pts={1,2:3,4}", 2.0, "agent"),
        wire.MoosMsg(wire.NOTIFY, "BLOB", b"\x00\x01\xff", 3.0, "x"),
    ]
    back = wire.decode_packet(wire.encode_packet(msgs))
    assert [(m.kind, m.key, m.value, m.time, m.source) for m in back] == [
        (m.kind, m.key, m.value, m.time, m.source) for m in msgs]
    assert back[0].source_aux == "aux" and back[0].community == "auv1"
    assert back[1].text == "points=pts={1,2:3,4}" and back[2].data_type == wire.BINARY


def test_welcome_is_a_double_that_also_says_asynchronous() -> None:
    # MOOSDB's WELCOME: a double (the skew) whose string field says "asynchronous".
    raw = bytearray(wire.encode_packet([wire.MoosMsg(wire.WELCOME, "", 0.25)]))
    msg = wire.decode_packet(bytes(raw))[0]
    assert msg.value == 0.25 and msg.text == ""
    s = b"asynchronous"
    body = (struct.pack("<i", -1) + b"WD" + b"".join(struct.pack("<i", 0) for _ in range(4))
            + struct.pack("<ddd", 0.0, 0.25, -1.0) + struct.pack("<i", len(s)) + s)
    one = struct.pack("<i", len(body) + 4) + body
    pkt = struct.pack("<iib", 9 + len(one), 1, 0) + one
    welcome = wire.decode_packet(pkt)[0]
    assert welcome.kind == wire.WELCOME and welcome.text == "asynchronous"


def test_handshake_opens_with_the_protocol_string() -> None:
    raw = wire.handshake_bytes("agent", 5.0)
    assert raw[:wire.PROTOCOL_BYTES].rstrip(b"\0") == wire.PROTOCOL
    hello = wire.decode_packet(raw[wire.PROTOCOL_BYTES:])[0]
    assert (hello.kind, hello.key, hello.value) == (wire.DATA, "asynchronous", "agent")


@pytest.mark.parametrize("cut", [3, 9, 20, 40])
def test_truncated_or_forged_packets_are_refused(cut: int) -> None:
    good = wire.encode_packet([wire.MoosMsg(wire.NOTIFY, "K", "value", 1.0, "s")])
    with pytest.raises(wire.WireError):
        wire.decode_packet(good[:cut])
    forged = bytearray(good)
    forged[9:13] = struct.pack("<i", 10_000)  # the message claims more than the packet holds
    with pytest.raises(wire.WireError):
        wire.decode_packet(bytes(forged))
    with pytest.raises(wire.WireError):
        wire.packet_length(struct.pack("<i", wire.MAX_PACKET_BYTES + 1))


def test_moos_time_is_warped_unix_time() -> None:
    assert wire.moos_time(100.0, 10.0) == 1000.0
    with pytest.raises(ValueError):
        wire.moos_time(1.0, 0.0)


# -- frames, the helm's text ------------------------------------------------------------------


@pytest.mark.parametrize("heading, yaw", [(0, 90), (90, 0), (180, -90), (270, 180), (45, 45)])
def test_compass_heading_and_yaw(heading: float, yaw: float) -> None:
    assert yaw_from_compass(heading) == pytest.approx(yaw)
    assert compass_from_yaw(yaw) == pytest.approx(heading % 360)


def test_quaternion_yaw_round_trip() -> None:
    for yaw in (-179.0, -90.0, 0.0, 33.3, 180.0):
        assert yaw_from_quaternion(*quaternion_from_yaw(yaw)) == pytest.approx(yaw if yaw != -179.0
                                                                              else -179.0)


def test_local_frame_is_an_offset() -> None:
    f = LocalFrame(1000.0, -50.0)
    assert f.to_scenario(1.0, 2.0, -3.0) == (1001.0, -48.0, -3.0)
    assert f.to_helm(f.to_scenario(1.0, 2.0, -3.0)) == (1.0, 2.0, -3.0)
    with pytest.raises(ValueError):
        LocalFrame(math.nan, 0.0)


def test_points_carry_the_leg_and_the_end_flag_gives_it_back() -> None:
    spec = points_spec(LocalFrame(10.0, 20.0), ((15.0, 25.0, -2.0), (30.5, 40.25, -3.0)), 7)
    assert spec == "points=pts={5.00,5.00:20.50,20.25,cotsleg_7}"
    # BHV_Waypoint's $[POINTS] writes the tagged vertex with a z before its tag.
    assert leg_of_flag("pts={5,5:20.5,20.2,0,cotsleg_7}") == 7
    assert leg_of_flag("pts={5,5}") is None


def test_update_result_keeps_an_update_with_commas() -> None:
    res = parse_update_result(
        "bhv=transit,var=WPT_UPDATE,time=3.20,result=param_error,val=points=pts={1,2:3,4}")
    assert res["result"] == "param_error" and res["val"] == "points=pts={1,2:3,4}"
    assert res["bhv"] == "transit" and res["var"] == "WPT_UPDATE"


def test_detections_round_trip_and_bad_ones_are_refused() -> None:
    text = format_detection("sighting", x=1.5, y=-2.0, z=-8.0, priority=55.0, service_s=70.0)
    seen = parse_detection(text)
    assert seen == Sighting((1.5, -2.0, -8.0), 55.0, 70.0)
    look = parse_detection(format_detection("look", task=17, present=True, priority=3.0))
    assert look == LookResult(17, True, 3.0, 0.0)
    for bad in ("kind=sighting,x=1", "kind=look,task=-1,present=true", "x", "kind=boom",
                "kind=sighting,x=nan,y=0,priority=1,service_s=1", "k=" + "v" * 600):
        with pytest.raises(DetectionError):
            parse_detection(bad)


# -- what the adapter keeps -------------------------------------------------------------------


def test_duty_owes_one_arrival_per_leg_and_work_when_due() -> None:
    d = Duty()
    d.start(GoTo(4, ((1.0, 1.0, 0.0),)), 0.0)
    d.start(GoTo(5, ((2.0, 2.0, 0.0),)), 1.0)  # replaces leg 1 before it ended
    assert d.arrival(1) is None  # a late flag of the replaced leg
    assert d.arrival(2) == 5 and d.arrival(2) is None
    d.start(StationKeep(Work.LOOK, 5, 30.0), 10.0)
    assert d.due_work(39.9) is None and d.due_work(40.0) == (Work.LOOK, 5, 40.0)
    assert d.due_work(50.0) is None
    d.start(Abort((), surface=True), 60.0)
    assert d.target is None and d.refuse() == "Abort" and d.refuse() is None
    d.start(ReturnHome(((0.0, 0.0, 0.0),)), 70.0)
    assert d.arrival(d.leg) == HOME_TARGET


def test_report_buffer_is_bounded_and_ordered() -> None:
    buf = ReportBuffer(max_fixes=3, max_events=2)
    for i in range(5):
        buf.add(NavFix(float(i), (0.0, 0.0, 0.0)))
    for i in range(3):
        buf.add(Arrived(float(i) + 0.5, i))
    out = buf.take(3.0)
    assert [r.t_s for r in out] == [1.5, 2.0, 2.5, 3.0]
    assert buf.dropped_fixes == 2 and buf.dropped_events == 1
    assert [r.t_s for r in buf.take(10.0)] == [4.0]
    stats = NavStats()
    assert stats.age_s(5.0) == math.inf
    stats.record(NavFix(2.0, (0.0, 0.0, 0.0)), 0.1)
    assert stats.age_s(5.0) == 3.0 and stats.lag_max_s == 0.1


# -- the mission files ------------------------------------------------------------------------


@pytest.fixture
def paper() -> Problem:
    return problem_from_dict(paper_preset_doc(1))


def test_mission_files_for_the_paper_preset(paper: Problem, tmp_path: Path) -> None:
    moos = write_moos_mission(paper, 1, tmp_path, 10.0, 9301)
    assert moos == tmp_path.resolve() / "auv2.moos"
    text = moos.read_text()
    assert "ServerPort   = 9301" in text and "MOOSTimeWarp = 10" in text
    assert f"behaviors = {tmp_path.resolve() / 'auv2.bhv'}" in text
    start = paper.vehicles[1].start
    assert f"start_pos = x={start[0]:g}, y={start[1]:g}" in text
    for app in MOOS_APPS[1:]:
        assert f"Run = {app}" in text and f"ProcessConfig = {app}" in text
    bhv = (tmp_path / "auv2.bhv").read_text()
    for needle in ("updates   = WPT_UPDATE", "updates   = RETURN_UPDATE",
                   "endflag   = COTS_LEG_END = $[POINTS]", "BHV_StationKeep",
                   "updates   = DEPTH_UPDATE", "initialize MOOS_MANUAL_OVERRIDE = false"):
        assert needle in bhv
    home = paper.vehicles[1].rendezvous
    assert f"points    = pts={{{home[0]:g},{home[1]:g}}}" in bhv


def test_mission_files_in_a_helm_frame_and_on_board(paper: Problem) -> None:
    frame = LocalFrame(50.0, 60.0)
    text = render_moos(paper, 0, 1.0, 9000, frame, engaged=False)
    start = paper.vehicles[0].start
    assert f"start_pos = x={start[0] - 50:g}, y={start[1] - 60:g}" in text
    assert "start_engaged = false" in text
    assert "MOOS_MANUAL_OVERRIDE" not in render_bhv(paper, 0, frame, engaged=False)


def test_mission_writer_refuses_what_moos_cannot_run(paper: Problem) -> None:
    with pytest.raises(ValueError):
        render_moos(paper, 3, 1.0, 9000)
    with pytest.raises(ValueError):
        render_moos(paper, 0, 0.0, 9000)
    with pytest.raises(ValueError):
        render_moos(paper, 0, 1.0, 70000)
    odd = Problem.build("odd", [Vehicle("auv one", (0, 0, 0), (10, 0, 0), 100.0, 1.0)],
                        [Task(1, (5, 5, -1), 1.0, 1.0)])
    with pytest.raises(ValueError, match="MOOS community"):
        render_bhv(odd, 0)


# -- against MOOS-IvP -------------------------------------------------------------------------

WARP = 10.0
_missing = [a for a in MOOS_APPS if shutil.which(a) is None]
needs_moos = pytest.mark.skipif(
    bool(_missing), reason=f"MOOS-IvP apps not on PATH: {', '.join(_missing)} "
    "(build moos-ivp and put its bin on PATH: docs/onboard.md)")


class ReefStandIn:
    """The camera of a reef with COTS at every spot looked at (priority 42, 75 s)."""

    def __init__(self) -> None:
        self.swept: list[tuple[float, float, float]] = []

    def sweep(self, pos):
        self.swept.append(pos)
        return []

    def inspect(self, task: int, pos=None) -> tuple[bool, float, float]:
        return True, 42.0, 75.0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Community:
    """One vehicle's MOOS community, started from PATH, every process gone at `stop`."""

    def __init__(self, problem: Problem, run_dir: Path, frame: LocalFrame) -> None:
        self.port = _free_port()
        self.moos = write_moos_mission(problem, 0, run_dir, WARP, self.port, frame)
        self.procs: dict[str, subprocess.Popen] = {}
        for app in MOOS_APPS:
            log = open(run_dir / f"{app}.log", "wb")
            self.procs[app] = subprocess.Popen([app, str(self.moos)], stdout=log,
                                               stderr=subprocess.STDOUT, cwd=run_dir)
            log.close()
            time.sleep(0.2)

    def kill(self, app: str) -> None:
        p = self.procs[app]
        p.terminate()
        p.wait(10)

    def stop(self) -> None:
        for p in reversed(list(self.procs.values())):
            if p.poll() is None:
                p.terminate()
        for p in self.procs.values():
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait(5)
        assert all(p.poll() is not None for p in self.procs.values())


@pytest.fixture
def vehicle(tmp_path: Path):
    # The helm's frame is offset from the scenario's: every position crosses the conversion.
    frame = LocalFrame(1000.0, 2000.0)
    problem = Problem.build("moos-test", [
        Vehicle("auv1", (1010.0, 2010.0, 0.0), (1000.0, 2000.0, 0.0), 3600.0, 1.0)],
        [Task(1, (1040.0, 2030.0, -3.0), 50.0, 60.0)])
    community = Community(problem, tmp_path, frame)
    clock = WarpClock(time.time(), WARP)
    camera = ReefStandIn()
    helm = None
    try:
        helm = MoosHelm(clock, MoosHelmConfig(port=community.port, warp=WARP, frame=frame),
                        camera=camera)
        yield helm, clock, community, camera
    finally:
        if helm is not None:
            helm.close()
        community.stop()


def _until(helm: MoosHelm, clock: WarpClock, want, mission_s: float) -> list:
    """Poll until a report of type ``want`` comes (at most ``mission_s`` mission seconds)."""
    got: list = []
    end = time.time() + mission_s / WARP
    while time.time() < end:
        got += helm.poll(clock.now())
        if any(isinstance(r, want) for r in got):
            return got
        time.sleep(0.02)
    return got


def _wait_driving(helm: MoosHelm, clock: WarpClock) -> list:
    got = _until(helm, clock, NavFix, 30.0)
    end = time.time() + 5.0
    while helm.helm_state != "DRIVE" and time.time() < end:
        time.sleep(0.05)
    assert helm.helm_state == "DRIVE"
    return got


@needs_moos
@pytest.mark.integration
def test_goto_arrives_then_a_look_keeps_station_and_reports(vehicle) -> None:
    helm, clock, _, camera = vehicle
    fixes = [r for r in _wait_driving(helm, clock) if isinstance(r, NavFix)]
    assert fixes and math.dist(fixes[-1].pos[:2], (1010.0, 2010.0)) < 1.0  # scenario frame
    spot = (1040.0, 2030.0, -3.0)
    helm.command(GoTo(0, ((1025.0, 2010.0, -3.0), spot)), clock.now())
    got = _until(helm, clock, Arrived, 200.0)
    arrived = [r for r in got if isinstance(r, Arrived)]
    assert arrived and arrived[0].target == 0, [r for r in got if not isinstance(r, NavFix)]
    last = [r for r in got if isinstance(r, NavFix)][-1]
    assert math.dist(last.pos[:2], spot[:2]) < 12.0  # within the helm's slip radius
    assert camera.swept, "the camera swept the track"
    t0 = clock.now()
    helm.command(StationKeep(Work.LOOK, 0, 30.0), t0)
    got = _until(helm, clock, Looked, 120.0)
    looked = [r for r in got if isinstance(r, Looked)]
    assert looked == [Looked(pytest.approx(t0 + 30.0, abs=1.0), 0, True, 42.0, 75.0)]
    held = [r for r in got if isinstance(r, NavFix)]
    assert max(math.dist(f.pos[:2], last.pos[:2]) for f in held) < 10.0  # kept station
    helm.command(StationKeep(Work.INJECT, 0, 10.0), clock.now())
    assert any(isinstance(r, Injected) for r in _until(helm, clock, Injected, 60.0))
    assert helm.stats.fixes > 20 and helm.stats.lag_max_s < 5.0


@needs_moos
@pytest.mark.integration
def test_navigation_that_stops_is_seen_in_the_fix_age(vehicle) -> None:
    helm, clock, community, _ = vehicle
    _wait_driving(helm, clock)
    assert helm.nav_age_s() < 5.0
    community.kill("uSimMarineV22")  # the vehicle's navigation source goes quiet
    time.sleep(0.5)
    helm.poll(clock.now())
    time.sleep(60.0 / WARP)
    assert not [r for r in helm.poll(clock.now()) if isinstance(r, NavFix)]
    assert helm.nav_age_s() > 50.0


@needs_moos
@pytest.mark.integration
def test_a_parked_helm_refuses_commands(vehicle) -> None:
    helm, clock, community, _ = vehicle
    _wait_driving(helm, clock)
    operator = MoosClient("localhost", community.port, "operator", WARP).start()
    try:
        assert operator.wait_connected(5.0)
        helm.command(GoTo(0, ((1040.0, 2030.0, -3.0),)), clock.now())
        # The operator takes manual control: the helm parks and the command under way is
        # refused; the next command is refused at once.
        operator.notify("MOOS_MANUAL_OVERRIDE", "true")
        got = _until(helm, clock, Refused, 60.0)
        refused = [r for r in got if isinstance(r, Refused)]
        assert refused and refused[0].command == "GoTo" and "PARK" in refused[0].reason
        helm.command(ReturnHome(((1000.0, 2000.0, 0.0),)), clock.now())
        now = [r for r in helm.poll(clock.now()) if isinstance(r, Refused)]
        assert now and now[0].command == "ReturnHome"
    finally:
        operator.close()


def test_the_shipped_mission_folder_is_what_the_writer_writes(tmp_path: Path) -> None:
    from fleet_agent.helms.moos_mission import write_example

    shipped = Path(__file__).resolve().parents[2] / "examples" / "moos"
    for path in write_example(tmp_path):
        rel = path.relative_to(tmp_path)
        assert (shipped / rel).read_text() == path.read_text(), f"regenerate {rel}"
