"""A real short mission (`cotsfleet run`: router, relay, agents, ground station as separate
processes); the ground station's .rrd is read back with Rerun's own API and compared with
the launcher's mission report."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from ground_station.recording_reader import read_recording

REPO = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.integration


@pytest.fixture(scope="module")
def mission(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("gs-mission")
    rrd, report = run_dir / "mission.rrd", run_dir / "report.json"
    proc = subprocess.run(
        [sys.executable, "-m", "cotsfleet", "run", "--viewer", "none", "--rrd", str(rrd),
         "--warp", "150", "--seed", "2", "--abort", "auv2@1200", "--kill", "auv3@1600",
         "--run-dir", str(run_dir / "run"),
         "--report", str(report)],
        cwd=REPO, capture_output=True, text=True, timeout=240)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    gs_log = (run_dir / "run" / "ground_station.log").read_text()
    return json.loads(report.read_text()), read_recording(rrd), gs_log


def last(ents, plot, line):
    """The last value of one line of a plot entity (`EntityRows.line`)."""
    return ents[plot].line(line)[-1][1]


def test_fleet_figures_match_the_report(mission):
    report, ents, _ = mission
    fleet = report["fleet"]
    assert fleet["spots_cleared"] > 0
    assert last(ents, "/series/fleet/spots", "spots_cleared") == fleet["spots_cleared"]
    assert last(ents, "/series/fleet/priority", "priority_collected") == \
        pytest.approx(fleet["priority"], abs=0.01)
    assert last(ents, "/series/fleet/spots", "duplicates") == fleet["duplicate_treatments"]


def test_vehicle_series_match_the_report(mission):
    report, ents, _ = mission
    for v in report["vehicles"]:
        assert last(ents, "/series/spots_treated", v["id"]) == v["tasks_treated"]
        battery = last(ents, "/series/battery_s", v["id"])
        assert 3600.0 - battery == pytest.approx(v["battery_used_s"], abs=0.06)


def test_acoustic_traffic_matches_the_relay_counters(mission):
    report, ents, _ = mission
    link = report["messages"]["link"]
    assert last(ents, "/series/fleet/messages", "delivered") == link["delivered"]
    assert last(ents, "/series/fleet/bytes", "delivered") == link["bytes"]
    for reason in ("range", "sinr", "random", "collision", "half_duplex", "oversize",
                   "partition"):
        plot = f"/series/fleet/drops/{reason}"
        assert (last(ents, plot, f"drops/{reason}") if plot in ents else 0) == link[reason]
    assert ents["/map/links"].rows


def test_a_killed_agent_is_marked_and_the_station_keeps_going(mission):
    report, ents, gs_log = mission
    assert {v["id"]: v["state"] for v in report["vehicles"]}["auv3"] == "dead"
    # the mission goes on long after the kill, so the station's own silence verdict (120 sim s
    # without telemetry) outranks the peers' "lost"
    assert ents["/series/battery_s"].line("auv1")[-1][0] > 1600 + 150
    assert ents["/map/vehicles/auv3/mark"].latest("Points2D:labels") == ["auv3 SILENT"]
    texts = [row["TextLog:text"][0] for _, row in ents["/events"].sorted_rows()]
    assert any(t.startswith("auv3 silent since") for t in texts)


def test_map_abort_mark_and_event_log(mission):
    report, ents, gs_log = mission
    assert len(ents["/map/spots"].static["Points2D:positions"]) == report["fleet"]["spots_total"]
    assert "Image:buffer" in ents["/map/field"].static
    texts = [row["TextLog:text"][0] for _, row in ents["/events"].sorted_rows()]
    assert "auv2 abort" in " ".join(texts)
    assert ents["/map/vehicles/auv2/mark"].latest("Points2D:labels") == ["auv2 ABORTED"]
    trails = [len(row["LineStrips2D:strips"]) for _, row in ents["/map/trails"].sorted_rows()
              if row.get("LineStrips2D:strips")]
    assert max(trails) == len(report["vehicles"]), "every vehicle leaves a trail"
    assert "dropped {}" in gs_log, gs_log
