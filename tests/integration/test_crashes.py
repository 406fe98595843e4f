"""A mission outlives its parts: the crash cases of `benchmarks.crash_table`, each a real
3-AUV mission (paper preset, seed 7) beside the same mission without a crash, at warp 120
where the benchmark runs warp 60: what a crash costs is in mission time, and a machine that
falls behind slows the clock (correctness never depends on keeping up). The file's six
missions took 290 s against 428 s at warp 60 (stop 62's host).

A passive process (the ground station) that dies is started again and the mission goes on;
the relay too, with the clock held while it comes back; a full disk loses the agents that
cannot write their journals, names them, and still leaves the report and the whole event
log; every crash is named with its last output. An agent restarted on an empty or cut
journal keeps station until it has learned the fleet's cleared set from its peers
(`fleet_agent.policies.rejoin`), treats nothing twice, and says what it lost."""

from __future__ import annotations

import functools
import json
from pathlib import Path

import pytest

from benchmarks.crash_table import CASES, Outcome, row, run_case

pytestmark = [pytest.mark.integration, pytest.mark.slow]
WARP = 120.0
run = functools.partial(run_case, warp=WARP)


@pytest.fixture(scope="module")
def root(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("crashes")


@pytest.fixture(scope="module")
def baseline(root: Path) -> Outcome:
    out = run(None, root)
    assert out.report is not None and not out.report.get("crashes")
    return out


def ran(outcome: Outcome, baseline: Outcome | None = None) -> dict:
    print(" | ".join(str(x) for x in row(outcome, baseline)))  # the table's row (-s)
    if outcome.skipped:
        pytest.skip(outcome.skipped)
    assert outcome.report is not None, outcome.lines[-5:]
    assert outcome.report_on_disk, "report.json was not written"
    assert all(not alive for alive in _running(outcome)), "a process outlived the mission"
    return outcome.report


def _running(outcome: Outcome) -> list[bool]:
    pids = json.loads((outcome.run_dir / "pids.json").read_text()) \
        if (outcome.run_dir / "pids.json").exists() else {}
    from leftovers import alive

    return [alive(p) for group in pids.values() for p in group]


def test_the_ground_station_is_started_again_and_the_mission_goes_on(root, baseline) -> None:
    out = run(CASES["ground station killed"], root)
    report = ran(out, baseline)
    assert [(c["name"], c["action"]) for c in report["crashes"]] == [
        ("ground_station", "restart")]
    assert report["crashes"][0]["code"] == -9 and "failure" not in report
    assert report["fleet"]["spots_cleared"] == baseline.report["fleet"]["spots_cleared"]
    assert report["fleet"]["duplicate_treatments"] == 0
    assert (out.run_dir / "mission.rrd").exists() and (out.run_dir / "mission.1.rrd").exists()
    assert any("ground_station exited with -9" in line and "started again" in line
               for line in out.lines)


def test_the_relay_is_started_again_with_the_clock_held(root, baseline) -> None:
    out = run(CASES["relay killed"], root)
    report = ran(out, baseline)
    assert [(c["name"], c["action"]) for c in report["crashes"]] == [("relay", "restart")]
    assert "failure" not in report and report["fleet"]["vehicles_home"] == 3
    assert report["clock"]["holds"] >= 1  # the clock held while the relay came back
    assert report["fleet"]["false_alarms"] == 0
    assert report["fleet"]["duplicate_treatments"] == 0


def test_a_full_disk_names_who_it_stopped_and_keeps_the_report(root, baseline) -> None:
    out = run(CASES["full disk"], root)
    report = ran(out, baseline)
    full = [c for c in report["crashes"] if "disk is full" in c["why"]]
    assert full, report["crashes"]
    assert all(c["name"].startswith("auv") and c["action"] == "vehicle" for c in full)
    saved = report["saved"]
    assert out.events_on_disk == saved["events"] == saved["events_total"] > 0
    lines = (out.run_dir / "events.jsonl").read_text().splitlines()
    assert all(json.loads(line) for line in lines)


@pytest.mark.parametrize("case", ["empty journal", "cut journal"])
def test_a_restart_on_a_damaged_journal_rejoins_before_it_acts(root, baseline, case) -> None:
    out = run(CASES[case], root)
    report = ran(out, baseline)
    assert [f["kind"] for f in report["faults"]] == ["kill", "restart"]
    log = (out.run_dir / "auv2.log").read_text()
    restarts = [line for line in log.splitlines() if line.startswith("fleet_agent ready")]
    assert len(restarts) == 2
    assert report["fleet"]["duplicate_treatments"] == 0
    auv2 = next(v for v in report["vehicles"] if v["id"] == "auv2")
    # The report says what was lost: an empty journal always; a cut one when the cut fell
    # inside a record (a cut on a record boundary reads as a shorter, whole journal: the
    # agent restarts from it, and the fleet's cleared set still keeps it from treating twice).
    if case == "empty journal" or "journal damaged" in log:
        lost = "journal_empty" if case == "empty journal" else "journal_damaged"
        assert auv2["counters"].get(lost) == 1, auv2["counters"]
    else:
        return
    events = [json.loads(line) for line in (out.run_dir / "events.jsonl").read_text()
              .splitlines() if line.strip()]
    assert any(e.get("id") == "auv2" and e.get("kind") == "rejoined" for e in events)
    assert report["fleet"]["vehicles_home"] >= 2
