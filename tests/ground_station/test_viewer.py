"""Sinks: the web viewer where it is told to listen (and gone when the station goes), busy
ports, the disabled stream, restart-safe recording paths, the compacted file."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import textwrap
import time
import urllib.request
from pathlib import Path
from urllib.parse import parse_qs, urlparse

import pytest
import rerun as rr
from rerun.chunk import RrdReader

from ground_station.blueprint import live_blueprint
from ground_station.recording_reader import read_recording
from ground_station.viewer import SinkError, ViewerOptions, compact_rrd, open_recording, \
    pick_port, rrd_for_run, web_viewer_url

REPO = Path(__file__).resolve().parents[2]


def test_web_viewer_url_points_the_bundled_viewer_at_the_grpc_server():
    url = web_viewer_url("127.0.0.1", 9090, "rerun+http://127.0.0.1:9876/proxy")
    parsed = urlparse(url)
    assert (parsed.scheme, parsed.netloc) == ("http", "127.0.0.1:9090")
    assert parse_qs(parsed.query) == {"url": ["rerun+http://127.0.0.1:9876/proxy"],
                                      "renderer": ["webgl"]}


def test_a_wildcard_bind_is_announced_by_this_machines_name():
    assert urlparse(web_viewer_url("0.0.0.0", 9090, "x")).hostname == socket.gethostname().lower()
    assert urlparse(web_viewer_url("::1", 9090, "x")).netloc == "[::1]:9090"


def test_no_viewer_and_no_file_means_a_disabled_stream():
    sinks = open_recording("cotsfleet", "r0", ViewerOptions("none"), live_blueprint((0, 1, 0, 1)))
    assert sinks.url is None and not sinks.rec.is_enabled()


def test_unknown_viewer_is_refused():
    with pytest.raises(ValueError):
        ViewerOptions("vr")


@pytest.fixture
def busy_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        yield s.getsockname()[1]


def test_a_busy_port_is_replaced_by_a_free_one_and_said_so(busy_port):
    port, note = pick_port("127.0.0.1", busy_port, "web viewer")
    assert port != busy_port and f"{busy_port}" in note and f"{port}" in note
    assert pick_port("127.0.0.1", port, "web viewer") == (port, "")


def test_an_address_not_of_this_machine_is_a_clear_error():
    with pytest.raises(SinkError, match="cannot listen on 192.0.2.1"):
        pick_port("192.0.2.1", 9090, "web viewer")  # TEST-NET-1: never a local address


def listeners(port: int) -> set[str]:
    """Local addresses listening on ``port`` (IPv4), from /proc/net/tcp."""
    found = set()
    for line in Path("/proc/net/tcp").read_text().splitlines()[1:]:
        local, state = line.split()[1], line.split()[3]
        addr, hex_port = local.split(":")
        if state == "0A" and int(hex_port, 16) == port:  # 0A: LISTEN
            found.add(socket.inet_ntoa(bytes.fromhex(addr)[::-1]))
    return found


@pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="reads Linux's /proc/net/tcp")
def test_the_web_viewer_listens_on_loopback_only_and_stops_with_the_station(busy_port):
    sinks = open_recording("cotsfleet", "r-web", ViewerOptions("web", web_port=busy_port),
                           live_blueprint((0, 1, 0, 1)))
    server = sinks.web_server
    try:
        url = urlparse(sinks.url)
        data = urlparse(parse_qs(url.query)["url"][0].replace("rerun+http", "http"))
        assert url.hostname == data.hostname == "127.0.0.1"
        assert url.port != busy_port and any(str(busy_port) in n for n in sinks.notes)
        assert listeners(url.port) == {"127.0.0.1"} and listeners(data.port) == {"127.0.0.1"}
        with urllib.request.urlopen(sinks.url, timeout=10) as page:
            assert b"re_viewer" in page.read()  # the bundled viewer, from this machine
    finally:
        sinks.close()
    assert server is not None and server.poll() is not None
    # The data port is the recording stream's, closed by its own thread: give a busy machine
    # a few seconds to let go of it.
    deadline = time.monotonic() + 5.0
    while (listeners(url.port) or listeners(data.port)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert listeners(url.port) == set() and listeners(data.port) == set()


STATION = textwrap.dedent("""
    import sys, time
    from ground_station.blueprint import live_blueprint
    from ground_station.viewer import ViewerOptions, open_recording
    sinks = open_recording("cotsfleet", "r-kill", ViewerOptions("web", web_port=0),
                           live_blueprint((0, 1, 0, 1)))
    print(sinks.web_server.pid, flush=True)
    time.sleep(60)
""")


def test_the_web_server_dies_with_a_killed_station():
    station = subprocess.Popen([sys.executable, "-c", STATION], cwd=REPO, text=True,
                               stdout=subprocess.PIPE)
    try:
        server_pid = int(station.stdout.readline())
        os.kill(server_pid, 0)  # alive
    finally:
        station.send_signal(signal.SIGKILL)
        station.wait(10)
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        try:
            os.kill(server_pid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.1)
    os.kill(server_pid, signal.SIGKILL)
    pytest.fail("the web server outlived the station")


def record(path, run_id):
    sinks = open_recording("cotsfleet", run_id, ViewerOptions("none", path),
                           live_blueprint((0, 1, 0, 1)))
    sinks.rec.set_time("sim_time", duration=1.0)
    sinks.rec.log("events", rr.TextLog(run_id))
    sinks.close()


def test_a_restart_of_the_same_run_never_overwrites_its_first_part(tmp_path):
    path = tmp_path / "m.rrd"
    assert rrd_for_run(path, "run-a") == path
    record(path, "run-a")
    second = rrd_for_run(path, "run-a")
    assert second == tmp_path / "m.part2.rrd"
    record(second, "run-a")
    assert rrd_for_run(path, "run-a") == tmp_path / "m.part3.rrd"
    assert rrd_for_run(path, "run-b") == path  # another mission: overwrite as asked
    assert read_recording(path)["/events"].rows


def test_an_unreadable_file_is_simply_overwritten(tmp_path):
    path = tmp_path / "junk.rrd"
    path.write_bytes(b"not a recording")
    assert rrd_for_run(path, "run-a") == path


def test_compaction_keeps_every_row_and_a_failure_keeps_the_file(tmp_path):
    path = tmp_path / "c.rrd"
    rec = rr.RecordingStream("cotsfleet", recording_id="run-c")
    rec.set_sinks(rr.FileSink(path))
    for i in range(50):
        rec.set_time("sim_time", duration=float(i))
        rec.log("series/x", rr.Scalars(float(i)))
        rec.flush()  # one chunk per row, as a slow live stream makes them
    rec.disconnect()
    before = path.stat().st_size
    compact_rrd(path, "cotsfleet", "run-c", None)
    assert path.stat().st_size < before / 3
    rows = read_recording(path)["/series/x"].series("Scalars:scalars")
    assert [v for _, (v,) in rows] == [float(i) for i in range(50)]
    compact_rrd(path, "cotsfleet", "run-c", live_blueprint((0, 1, 0, 1)))
    assert RrdReader(path).blueprints() and len(read_recording(path)["/series/x"].rows) == 50
    broken = tmp_path / "broken.rrd"
    broken.write_bytes(b"not a recording")
    with pytest.raises(Exception):
        compact_rrd(broken, "cotsfleet", "run-c", None)
    assert broken.read_bytes() == b"not a recording"
    assert not list(tmp_path.glob(".*compacting"))
