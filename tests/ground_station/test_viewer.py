"""Sinks: the web viewer URL, the disabled stream, and restart-safe recording paths."""

from __future__ import annotations

from urllib.parse import parse_qs, urlparse

import pytest
import rerun as rr

from ground_station.blueprint import live_blueprint
from ground_station.recording_reader import read_recording
from ground_station.viewer import ViewerOptions, close_recording, open_recording, rrd_for_run, \
    web_viewer_url


def test_web_viewer_url_points_the_bundled_viewer_at_the_grpc_server():
    url = web_viewer_url("127.0.0.1", 9090, "rerun+http://127.0.0.1:9876/proxy")
    parsed = urlparse(url)
    assert (parsed.scheme, parsed.netloc) == ("http", "127.0.0.1:9090")
    assert parse_qs(parsed.query) == {"url": ["rerun+http://127.0.0.1:9876/proxy"],
                                      "renderer": ["webgl"]}


def test_no_viewer_and_no_file_means_a_disabled_stream():
    rec, url = open_recording("cotsfleet", "r0", ViewerOptions("none"),
                              live_blueprint((0, 1, 0, 1)))
    assert url is None and not rec.is_enabled()


def test_unknown_viewer_is_refused():
    with pytest.raises(ValueError):
        ViewerOptions("vr")


def record(path, run_id):
    rec, _ = open_recording("cotsfleet", run_id, ViewerOptions("none", path),
                            live_blueprint((0, 1, 0, 1)))
    rec.set_time("sim_time", duration=1.0)
    rec.log("events", rr.TextLog(run_id))
    close_recording(rec)


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
