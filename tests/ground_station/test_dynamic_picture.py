"""The fleet picture of a dynamic mission: spots found empty, finds appearing when reported,
the hidden reef as a layer that starts switched off, the share of the real reef treated."""

from __future__ import annotations

import numpy as np
import pytest
import rerun as rr

from fleet_bus.telemetry import Event
from ground_station import palette
from ground_station.drawing import Finds, SeriesRow, Spots
from ground_station.mapview import map_layers
from ground_station.recording_reader import read_recording
from ground_station.rerun_log import RerunDashboard, log_map
from ground_station.state import FleetPicture
from reef_sim.scenarios.dynamic import DynamicParams, generate_dynamic_doc
from reef_sim.scenarios.field import GeneratorParams


@pytest.fixture(scope="module")
def doc() -> dict:
    params = DynamicParams(base=GeneratorParams(name="gs-dyn", n_tasks=20, n_vehicles=2,
                                                size_m=500.0, battery_s=1500.0), n_unmapped=3)
    return generate_dynamic_doc(params, np.random.default_rng(2))


def parts(doc):
    truth = doc["truth"]["spots"]
    named = {s["task"] for s in truth if s.get("task") is not None}
    empty = next(i for i in range(len(doc["tasks"])) if i not in named)
    present = next(i for i, s in enumerate(truth) if s.get("task") is not None)
    unmapped = next(i for i, s in enumerate(truth) if s.get("task") is None)
    return empty, present, unmapped


def where(pos) -> str:
    return ",".join(f"{c:.1f}" for c in pos)


def test_empty_spots_finds_and_the_reef_share(doc):
    layers = map_layers(doc)
    assert layers.dynamic and len(layers.truth_xy) == len(doc["truth"]["spots"])
    pic = FleetPicture(layers)
    empty, present, unmapped = parts(doc)
    truth = doc["truth"]["spots"]
    total = sum(s["priority"] for s in truth)

    first = pic.initial()[0]
    assert isinstance(first, Spots) and set(first.states) == {"pending"}
    assert {tuple(c) for c in first.colors} == {palette.SPOT_HOLLOW}  # predictions: hollow
    out = pic.apply("auv1", Event(10.0, "auv1", "empty", [doc["tasks"][empty]["id"]]))
    spots = [d for d in out if isinstance(d, Spots)][-1]
    assert spots.states[empty] == "empty"
    assert tuple(spots.colors[empty]) == palette.SPOT_EMPTY

    pos = truth[unmapped]["pos"]
    found = Event(20.0, "auv1", "found", [9001], detail=f"{where(pos)} rho 33")
    finds = [d for d in pic.apply("auv1", found) if isinstance(d, Finds)]
    assert len(finds) == 1 and finds[0].xy[0] == pytest.approx(pos[:2], abs=0.1)
    again = Event(21.0, "auv2", "found", [9025], detail=f"{where(pos)} rho 33")
    assert not [d for d in pic.apply("auv2", again) if isinstance(d, Finds)]  # one aggregation

    out = pic.apply("auv1", Event(300.0, "auv1", "cleared", [9001], detail=where(pos)))
    share = [r.value("fleet/reef_share") for r in out if isinstance(r, SeriesRow)
             and "fleet/reef_share" in r.drawn]
    assert share == [pytest.approx(truth[unmapped]["priority"] / total)]
    tid = doc["tasks"][truth[present]["task"]]["id"]
    out = pic.apply("auv2", Event(400.0, "auv2", "cleared", [tid]))
    share = [r.value("fleet/reef_share") for r in out if isinstance(r, SeriesRow)
             and "fleet/reef_share" in r.drawn]
    want = (truth[unmapped]["priority"] + truth[present]["priority"]) / total
    assert share == [pytest.approx(want)]


def test_the_reef_and_the_finds_are_logged(doc, tmp_path):
    layers = map_layers(doc)
    path = tmp_path / "dyn.rrd"
    rec = rr.RecordingStream("cotsfleet", recording_id="dyn")
    rec.set_sinks(rr.FileSink(path))
    log_map(rec, layers, live=True)
    RerunDashboard(rec).draw([Finds(5.0, np.array([[1.0, 2.0]]), np.array([7.0]), ("find",))])
    rec.disconnect()
    got = read_recording(path)
    assert "/map/reef" in got and "/map/finds" in got and "/map/predictions" in got


def test_a_scenario_without_truth_has_no_reef(small_doc):
    layers = map_layers(small_doc)
    assert not layers.dynamic
    pic = FleetPicture(layers)
    assert "fleet/reef" not in pic._plots
    assert {tuple(c) for c in pic.initial()[0].colors} == {palette.SPOT_PENDING}
