"""The Zenoh layer for real: an embedded router, a mission queryable and publishers on
loopback, the ground station's `main` in a thread, its .rrd read back afterwards."""

from __future__ import annotations

import re
import signal
import socket
import subprocess
import sys
import threading
import time
from contextlib import ExitStack
from pathlib import Path
from urllib.parse import urlparse

import pytest
import zenoh

from fleet_bus.session import client_config, free_tcp_endpoint, open_session, router_config
from fleet_bus.telemetry import Status
from gs_scripted import mission_of, scripted_mission, small_scenario
from ground_station.__main__ import main
from ground_station.recording_reader import read_recording
from ground_station.viewer import ViewerOptions

ROUTES = {"auv1": [10, 11], "auv2": [13], "auv3": [15]}
REPO = Path(__file__).resolve().parents[2]


class Launcher:
    """The launcher's side of the bus: the mission queryable (optionally garbled first)."""

    def __init__(self, session: zenoh.Session, payload: bytes, garbled_first: int = 0) -> None:
        self.payload = payload
        self.garbled_left = garbled_first
        self.queries = 0
        self.queryable = session.declare_queryable("fleet/mission", self.on_query)

    def on_query(self, query: zenoh.Query) -> None:
        self.queries += 1
        if self.garbled_left > 0:
            self.garbled_left -= 1
            query.reply("fleet/mission", b"\x00garbage")
        else:
            query.reply("fleet/mission", self.payload)


def start_station(endpoint: str, rrd: Path, stop: threading.Event) -> tuple[threading.Thread, list]:
    result: list[int] = []
    thread = threading.Thread(target=lambda: result.append(main(
        client_config([endpoint]), ViewerOptions("none", rrd), stop, mission_timeout_s=30.0)))
    thread.start()
    return thread, result


def publish(session: zenoh.Session, samples: list[tuple[str, bytes]]) -> None:
    for i, (key, payload) in enumerate(samples):
        session.put(key, payload)
        if i % 50 == 49:
            time.sleep(0.01)  # the fleet never bursts thousands of samples at once


def last_battery(rrd: Path, vid: str) -> float:
    return read_recording(rrd)["/series/battery_s"].line(vid)[-1][1]


@pytest.fixture
def bus():
    endpoint = free_tcp_endpoint()
    with ExitStack() as stack:
        stack.enter_context(open_session(router_config([endpoint])))
        yield endpoint, stack.enter_context(open_session(client_config([endpoint])))


def test_station_joins_before_the_mission_exists_and_survives_a_garbled_answer(bus, tmp_path):
    endpoint, session = bus
    doc = small_scenario()
    samples = scripted_mission(doc, ROUTES, end_s=300)
    rrd = tmp_path / "live.rrd"
    stop = threading.Event()
    thread, result = start_station(endpoint, rrd, stop)
    try:
        time.sleep(1.0)  # the station is up and asking before the launcher answers
        launcher = Launcher(session, mission_of(doc, "late-run").encode(), garbled_first=1)
        time.sleep(2.5)
        publish(session, samples[:5] + [("fleet/status/auv1", b"junk")] + samples[5:])
        time.sleep(1.5)
    finally:
        stop.set()
        thread.join(30)
    assert result == [0] and launcher.queries >= 2
    last = max((Status.decode(p) for k, p in samples if k == "fleet/status/auv1"),
               key=lambda s: s.t_s)
    assert last_battery(rrd, "auv1") == last.battery_s  # every sample made it
    ents = read_recording(rrd)
    assert ents["/series/ground_station/dropped/malformed"].line("malformed")[-1][1] == 1


def test_a_restarted_station_picks_up_from_current_statuses(bus, tmp_path):
    endpoint, session = bus
    doc = small_scenario()
    samples = scripted_mission(doc, ROUTES, end_s=400)
    half = len(samples) // 2
    launcher = Launcher(session, mission_of(doc, "restart-run").encode())
    rrd = tmp_path / "mission.rrd"
    parts = []
    for chunk in (samples[:half], samples[half:]):
        stop = threading.Event()
        thread, result = start_station(endpoint, rrd, stop)
        try:
            time.sleep(2.0)
            publish(session, chunk)
            time.sleep(1.5)
        finally:
            stop.set()
            thread.join(30)
        assert result == [0]
        parts.append(sorted(tmp_path.glob("mission*.rrd")))
    assert launcher.queries >= 2
    assert [p.name for p in parts[-1]] == ["mission.part2.rrd", "mission.rrd"]
    second = read_recording(tmp_path / "mission.part2.rrd")
    statuses = [Status.decode(p) for k, p in samples[half:] if k.startswith("fleet/status/")]
    final = {s.id: s for s in statuses}
    first_t = min(s.t_s for s in statuses)
    spots = second["/map/spots"].series("Points2D:colors")
    assert spots[0][0] == 0.0 and spots[1][0] >= first_t  # initial picture, then rebuilt
    for vid, s in final.items():
        t, battery = second["/series/battery_s"].line(vid)[-1]
        assert battery == s.battery_s and t >= s.t_s
        assert second["/series/spots_treated"].line(vid)[-1][1] == float(len(s.treated))
    assert read_recording(tmp_path / "mission.rrd")["/series/battery_s"].line("auv1"), \
        "the first part survives the restart"


def run_cli(endpoint: str, *args: str, until: str | None = None,
            timeout_s: float = 60.0) -> tuple[int, str, str]:
    """``python -m ground_station`` on the bus; stopped with SIGTERM once ``until`` is printed."""
    proc = subprocess.Popen([sys.executable, "-m", "ground_station", "--connect", endpoint,
                             "--mission-timeout", "30", *args], cwd=REPO, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out = []
    try:
        if until is not None:
            deadline = time.monotonic() + timeout_s
            for line in proc.stdout:
                out.append(line)
                if until in line or time.monotonic() > deadline:
                    break
            proc.send_signal(signal.SIGTERM)
        stdout, stderr = proc.communicate(timeout=timeout_s)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
    return proc.returncode, "".join(out) + stdout, stderr


def test_a_busy_web_port_gets_a_free_one_named_in_the_url(bus):
    endpoint, session = bus
    Launcher(session, mission_of(small_scenario(), "busy-run").encode())
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        code, out, err = run_cli(endpoint, "--viewer", "web", "--web-port", str(port),
                                 until="web viewer at")
    assert code == 0, err
    assert f"web viewer port {port} on 127.0.0.1 is busy" in out
    url = urlparse(re.search(r"web viewer at (\S+)", out).group(1))
    assert url.hostname == "127.0.0.1" and url.port != port
    with pytest.raises(OSError):  # the station stopped its web server on the way out
        socket.create_connection(("127.0.0.1", url.port), timeout=1).close()


def test_a_web_host_that_is_not_ours_is_one_line_and_exit_code_2(bus):
    endpoint, session = bus
    Launcher(session, mission_of(small_scenario(), "bad-host-run").encode())
    code, out, err = run_cli(endpoint, "--viewer", "web", "--web-host", "192.0.2.1")
    assert code == 2
    assert "Traceback" not in err and "cannot listen on 192.0.2.1" in err, err
    assert len([line for line in err.splitlines() if line.startswith("ground_station:")]) == 1
