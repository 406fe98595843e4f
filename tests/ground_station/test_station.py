"""A scripted mission through the ground station into a real .rrd, read back with Rerun."""

from __future__ import annotations

import numpy as np
import pytest
from gs_scripted import mission_of, scripted_mission, small_scenario
from rerun.chunk import RrdReader

from fleet_bus.telemetry import Status, Truth
from ground_station import palette
from ground_station.blueprint import live_blueprint
from ground_station.recording_reader import read_recording
from ground_station.rerun_log import legend_bounds
from ground_station.station import APPLICATION_ID, GroundStation, mission_layers
from ground_station.viewer import ViewerOptions, open_recording

ROUTES = {"auv1": [10, 11], "auv2": [13, 14], "auv3": [15]}


def run_station(doc, samples, rrd, run_id="test-run", after=None):
    mission = mission_of(doc, run_id)
    layers = mission_layers(mission)
    sinks = open_recording(APPLICATION_ID, run_id, ViewerOptions("none", rrd),
                           live_blueprint(layers[0].bounds, legend_bounds(layers[0])))
    assert sinks.url is None
    station = GroundStation(mission, sinks.rec, layers)
    for key, payload in samples:
        station.handle(key, payload)
    if after is not None:
        after(station)
    station.close()
    sinks.close()
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
    assert ents["/series/ground_station/dropped/malformed"].line("malformed")[-1][1] == 3
    assert station.dropped["error"] == 0


def test_static_map_mission_card_and_legend(recorded):
    doc, _, rrd, ents, _ = recorded
    spots = ents["/map/spots"]
    np.testing.assert_allclose(spots.static["Points2D:positions"],
                               [t["pos"][:2] for t in doc["tasks"]])
    assert ents["/map"].static["Transform3D:scale"] == [[1.0, -1.0, 1.0]]
    card = ents["/mission"].static["TextDocument:text"][0]
    assert "test-run" in card and "rgb" not in card  # colours are swatches in the legend
    legend = ents["/legend/vehicles"].static
    assert legend["Points2D:colors"][0] == rgba(palette.vehicle_color(0))
    assert ents["/legend/links"].static["LineStrips2D:colors"][2] == rgba(palette.LINK_DROPPED)
    names = ents["/legend/labels"].static
    assert names["Points2D:labels"][0] == "auv1, its planned spots"
    assert "abandoned spot" in names["Points2D:labels"]
    assert set(names["Points2D:colors"]) == {rgba(palette.LABEL_TEXT)}  # readable on grey
    assert RrdReader(rrd).blueprints(), "the layout travels with the recording"


def test_the_map_has_a_grid_and_a_scale_bar(recorded):
    _, _, _, ents, _ = recorded
    grid = ents["/map/grid"].static
    assert len(grid["LineStrips2D:strips"]) >= 4
    assert grid["Points2D:labels"] and all(label.endswith(" m")
                                           for label in grid["Points2D:labels"])
    scale = ents["/map/scale"].static
    assert len(scale["LineStrips2D:strips"]) == 3  # the bar and its two end ticks
    (a, b), = [s for s in scale["LineStrips2D:strips"] if s[0][1] == s[1][1]]
    assert scale["Points2D:labels"] == [f"{abs(b[0] - a[0]):g} m"]


def test_vehicles_start_together_without_piling_their_labels(recorded):
    _, _, _, ents, _ = recorded
    labels = ents["/map/vehicle_labels"]
    at_start = [row.get("Points2D:labels") for t, row in labels.sorted_rows() if t == 0.0]
    assert at_start[-1] in ([], None)  # the station's label names them instead
    stations = [row["Points2D:labels"] for t, row in ents["/map/stations"].sorted_rows()
                if t == 0.0]
    assert stations[0] == ["start", "rendezvous"]
    assert stations[-1] == ["start: auv1 auv2 auv3 transit", "rendezvous"]
    rows = [row for _, row in labels.sorted_rows() if row.get("Points2D:labels")]
    assert any(len(row["Points2D:labels"]) >= 2 for row in rows)  # apart
    for row in rows:  # a label per vehicle (or group), never two on one spot
        xy = row["Points2D:positions"]
        assert len(xy) == len(row["Points2D:labels"])
        assert len({tuple(p) for p in xy}) == len(xy)
    assert labels.static["Points2D:colors"] == [rgba(palette.LABEL_TEXT)]
    assert "Points2D:labels" not in (ents["/map/vehicles"].latest("Points2D:labels") or {})


def test_series_end_where_the_last_statuses_do(recorded):
    _, station, _, ents, last = recorded
    assert ents["/series/battery_s"].static["SeriesLines:names"] == ["auv1", "auv2", "auv3"]
    for vid, s in last.items():
        assert ents["/series/spots_treated"].line(vid)[-1][1] == float(len(s.treated))
        assert ents["/series/battery_s"].line(vid)[-1][1] == s.battery_s
    cleared = set().union(*(s.treated for s in last.values()))
    assert cleared == {10, 11, 13, 14, 15}  # auv1 took over auv2's spot 14
    fleet = {name: ents[f"/series/fleet/{plot}"].line(name)[-1][1]
             for plot, name in (("spots", "spots_cleared"), ("priority", "priority_collected"),
                                ("spots", "duplicates"))}
    assert fleet == {"spots_cleared": 5.0, "priority_collected": 10 + 50 + 30 + 70 + 90,
                     "duplicates": 0.0}


def rgba(c) -> int:
    return (c[0] << 24) | (c[1] << 16) | (c[2] << 8) | 0xFF


def test_spot_colours_vehicle_marks_and_event_log(recorded):
    _, _, _, ents, _ = recorded
    colors = ents["/map/spots"].latest("Points2D:colors")
    assert [c == rgba(palette.SPOT_CLEARED) for c in colors] == [True, True, False, True, True,
                                                                 True]
    mark = ents["/map/vehicles/auv2/mark"]
    assert mark.latest("Points2D:labels") == ["auv2 ABORTED"]
    assert mark.latest("Points2D:colors") == [rgba(palette.LABEL_TEXT)]
    assert "/map/vehicles/auv1/mark" not in ents
    texts = [row["TextLog:text"][0] for _, row in ents["/events"].sorted_rows()]
    assert "auv2 aborted its mission (fault)" in texts  # the why, as the event said it
    assert "auv1 took over spots 13 and 14 from auv2" in texts or \
        "auv1 took over spot 14 from auv2" in texts
    assert "auv1 treated spot 10" in texts and "auv1 reached its rendezvous" in texts
    assert "auv1 is home" not in texts  # its arrival says it once
    assert "auv2 is aborted" not in texts  # its abort says it once


def test_links_are_one_layer_drawn_then_cleared(recorded):
    _, _, _, ents, _ = recorded
    assert not [p for p in ents if p.startswith("/map/links/")], "one entity for every link"
    rows = ents["/map/links"].sorted_rows()
    drawn = [(t, r) for t, r in rows if r.get("LineStrips2D:strips")]
    cleared = [t for t, r in rows if r.get("Clear:is_recursive") is not None]
    assert drawn and cleared  # frames every 30 s, each shown for 20 s
    assert max(len(r["LineStrips2D:strips"]) for _, r in drawn) <= 6  # the latest per link
    labels = {label for _, r in drawn for label in r.get("Points2D:labels") or []}
    assert labels and all(label.startswith("collision SNR ") for label in labels)
    colors = {c for _, r in drawn for c in r["LineStrips2D:colors"]}
    assert rgba(palette.LINK_DROPPED) in colors and len(colors) >= 3  # SNR as colour
    assert all(b - a <= 5.0 + 30.0 for a, b in zip([t for t, _ in rows], [t for t, _ in rows][1:]))
    messages = ents["/series/fleet/messages"]
    delivered, dropped = messages.line("delivered")[-1][1], messages.line("dropped")[-1][1]
    assert dropped == ents["/series/fleet/drops/collision"].line("drops/collision")[-1][1]
    assert delivered > dropped > 0


def test_an_undrawable_scenario_still_gives_a_dashboard(tmp_path):
    rrd = tmp_path / "bad.rrd"
    truth = Truth(1.0, (1.0, 2.0, 0.0)).encode()
    run_station({"name": "broken", "tasks": "nope"}, [], rrd,
                after=lambda station: station.handle("fleet/truth/auv9", truth))
    ents = read_recording(rrd)
    assert "scenario cannot be drawn" in ents["/events"].sorted_rows()[0][1]["TextLog:text"][0]
    assert ents["/map/vehicles"].latest("Points2D:positions") == [[1.0, 2.0]]


def test_the_recording_is_compacted_at_close(recorded):
    _, _, rrd, ents, _ = recorded
    chunks = list(RrdReader(rrd).stream())
    rows = sum(len(e.rows) for e in ents.values())
    assert len(chunks) < rows / 5, (len(chunks), rows)  # merged, not a chunk per row or tick
    assert not list(rrd.parent.glob(".*compacting*"))


def test_every_row_of_a_plot_has_all_its_lines(recorded):
    """Rerun draws only the lines every row of a plot has: a line appearing later (a drop
    reason) must not change a plot's row length, or it silently disappears."""
    _, _, _, ents, _ = recorded
    for path, entity in ents.items():
        if path.startswith("/series/"):
            names = entity.static["SeriesLines:names"]
            assert {len(v) for _, v in entity.series("Scalars:scalars")} == {len(names)}, path
