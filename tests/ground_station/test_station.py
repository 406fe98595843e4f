"""A scripted mission through the ground station into a real .rrd, read back with Rerun."""

from __future__ import annotations

import numpy as np
import pytest
from rerun.chunk import RrdReader

from fleet_bus.telemetry import Status, Truth
from gs_scripted import mission_of, scripted_mission, small_scenario
from ground_station import palette
from ground_station.blueprint import live_blueprint
from ground_station.recording_reader import read_recording
from ground_station.station import APPLICATION_ID, GroundStation, mission_layers
from ground_station.viewer import ViewerOptions, close_recording, open_recording

ROUTES = {"auv1": [10, 11], "auv2": [13, 14], "auv3": [15]}


def run_station(doc, samples, rrd, run_id="test-run", after=None):
    mission = mission_of(doc, run_id)
    layers = mission_layers(mission)
    rec, url = open_recording(APPLICATION_ID, run_id, ViewerOptions("none", rrd),
                              live_blueprint(layers[0].bounds))
    assert url is None
    station = GroundStation(mission, rec, layers)
    for key, payload in samples:
        station.handle(key, payload)
    if after is not None:
        after(station)
    close_recording(rec)
    return station


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    doc = small_scenario()
    samples = scripted_mission(doc, ROUTES, end_s=400, abort=("auv2", 60), taker="auv1")
    garbage = [("fleet/status/auv3", b"\x00not msgpack"), ("fleet/truth/auv1", b""),
               ("fleet/link/auv1/auv2", b"\x93\x01\x02\x03")]
    mixed = samples[:50] + garbage + samples[50:]
    rrd = tmp_path_factory.mktemp("gs") / "mission.rrd"
    station = run_station(doc, mixed, rrd)
    last = {}
    for key, payload in samples:
        if key.startswith("fleet/status/"):
            s = Status.decode(payload)
            last[s.id] = s
    return doc, station, rrd, read_recording(rrd), last


def test_garbage_is_dropped_counted_and_survived(recorded):
    _, station, _, ents, _ = recorded
    assert station.dropped["malformed"] == 3
    assert station.dropped["malformed:status"] == 1 and station.dropped["malformed:link"] == 1
    assert ents["/series/ground_station/dropped/malformed"].series("Scalars:scalars")[-1][1] == [3]
    assert station.dropped["error"] == 0


def test_static_map_and_mission_text(recorded):
    doc, _, rrd, ents, _ = recorded
    spots = ents["/map/spots"]
    np.testing.assert_allclose(spots.static["Points2D:positions"],
                               [t["pos"][:2] for t in doc["tasks"]])
    assert ents["/map"].static["Transform3D:scale"] == [[1.0, -1.0, 1.0]]
    assert "test-run" in ents["/mission"].static["TextDocument:text"][0]
    assert ents["/map/stations"].static["Points2D:labels"] == ["start", "rendezvous"]
    assert RrdReader(rrd).blueprints(), "the layout travels with the recording"


def test_series_end_where_the_last_statuses_do(recorded):
    _, station, _, ents, last = recorded
    for vid, s in last.items():
        treated = ents[f"/series/spots_treated/{vid}"].series("Scalars:scalars")
        assert treated[-1][1] == [float(len(s.treated))]
        assert ents[f"/series/battery_s/{vid}"].series("Scalars:scalars")[-1][1] == [s.battery_s]
        assert ents[f"/series/battery_s/{vid}"].static["SeriesLines:names"] == [vid]
    cleared = set().union(*(s.treated for s in last.values()))
    assert cleared == {10, 11, 13, 14, 15}  # auv1 took over auv2's spot 14
    fleet = {name: ents[f"/series/fleet/{name}"].series("Scalars:scalars")[-1][1][0]
             for name in ("spots_cleared", "priority_collected", "duplicates")}
    assert fleet == {"spots_cleared": 5.0, "priority_collected": 10 + 50 + 30 + 70 + 90,
                     "duplicates": 0.0}


def test_spot_colours_vehicle_marks_and_event_log(recorded):
    _, _, _, ents, _ = recorded
    colors = ents["/map/spots"].latest("Points2D:colors")
    cleared_rgba = (palette.SPOT_CLEARED[0] << 24) | (palette.SPOT_CLEARED[1] << 16) | \
        (palette.SPOT_CLEARED[2] << 8) | 0xFF
    assert [c == cleared_rgba for c in colors] == [True, True, False, True, True, True]
    assert ents["/map/vehicles/auv2/mark"].latest("LineStrips2D:labels")[0] == "auv2 ABORTED"
    assert "/map/vehicles/auv1/mark" not in ents
    texts = [row["TextLog:text"][0] for _, row in ents["/events"].sorted_rows()]
    assert "auv2 abort: fault" in texts
    assert "auv1 takeover spots 13,14 peer auv2" in texts or \
        "auv1 takeover spots 14 peer auv2" in texts
    assert "auv2 is aborted" in texts and "auv1 is home" in texts


def test_link_lines_are_drawn_then_cleared(recorded):
    _, _, _, ents, _ = recorded
    rows = ents["/map/links/auv1/auv3"].sorted_rows()
    drawn = [t for t, r in rows if r.get("LineStrips2D:strips")]
    cleared = [t for t, r in rows if r.get("Clear:is_recursive") is not None]
    assert drawn and cleared
    assert all(any(0 < c - d <= 20.0 + 1e-9 for c in cleared) for d in drawn[:-1])
    delivered = ents["/series/fleet/messages/delivered"].series("Scalars:scalars")[-1][1][0]
    dropped = ents["/series/fleet/messages/dropped"].series("Scalars:scalars")[-1][1][0]
    assert dropped == ents["/series/fleet/drops/collision"].series("Scalars:scalars")[-1][1][0]
    assert delivered > dropped > 0


def test_an_undrawable_scenario_still_gives_a_dashboard(tmp_path):
    rrd = tmp_path / "bad.rrd"
    truth = Truth(1.0, (1.0, 2.0, 0.0)).encode()
    run_station({"name": "broken", "tasks": "nope"}, [], rrd,
                after=lambda station: station.handle("fleet/truth/auv9", truth))
    ents = read_recording(rrd)
    assert "scenario cannot be drawn" in ents["/events"].sorted_rows()[0][1]["TextLog:text"][0]
    assert ents["/map/vehicles/auv9"].latest("Points2D:positions") == [[1.0, 2.0]]
