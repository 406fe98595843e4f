"""The operator's live order to a real 3-AUV mission (`cotsfleet run` as processes, then
`cotsfleet ctl --run-dir DIR recall auv2` at mission time ~1200 s, both subprocesses).

auv2 comes home early (its battery used, against the same seed simulated without the
order), the others take over its spots, no spot is treated twice, and the report's commands
section shows the order acknowledged. The remote ground station's identity orders the same
mission without the run dir (`ctl --connect ENDPOINT --credentials .../ground recall auv2`,
not waiting for acknowledgements): taken as order #2, counted under ``ground``. Requests
the operator's key did not sign (a vehicle's key, garbage) on fleet/ctl/order are refused
and counted in the report's security section.
An insider's forged order into the water (``--ctl unsigned:recall:auv1@600``, scheduled like
a fault) is refused by the vehicles. Once the mission is over `ctl` says so, and every
process is gone."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import zenoh
from leftovers import alive

from cotsfleet.mission.run_record import read_run_record
from fleet_bus import keys
from fleet_bus.credentials import load_auth
from fleet_bus.orders import encode_request, parse_words
from fleet_bus.session import client_config

REPO = Path(__file__).resolve().parents[2]
pytestmark = [pytest.mark.integration, pytest.mark.slow]
SEED, RECALL_AT_S = 1, 1200.0
# Orders are judged in mission time (the order's own issue time is the mark), so the warp
# sets only how long the suite waits: 60 (the launcher slows it on a machine that lags).
WARP = 60
MISSION = ["--vehicles", "3", "--seed", str(SEED)]


def _cli(*argv: str, timeout: float = 200.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cotsfleet", *argv], check=False, cwd=REPO,
                          capture_output=True, text=True, timeout=timeout)


def _mission_time(log: Path) -> float:
    """The latest mission time of the launcher's progress lines."""
    times = re.findall(r"^t=\s*(-?\d+) s ", log.read_text(errors="replace"),
                       re.MULTILINE)
    return float(times[-1]) if times else -1.0


def _foreign_requests(run_dir: Path) -> None:
    """On the operator's bus login (the router lets only it put on fleet/ctl/**): a request
    signed with auv1's key, and garbage."""
    record = read_run_record(run_dir)
    auv1 = load_auth(Path(record.credentials) / "auv1", "auv1")
    conf = client_config([record.endpoint], credentials=record.operator_dir)
    with zenoh.open(conf) as session:
        session.put(keys.ORDER_REQUEST, auv1.seal(
            keys.ORDER_REQUEST, encode_request(parse_words(["recall", "all"]), "forged")))
        session.put(keys.ORDER_REQUEST, b"\x00not an envelope, not an order\xff" * 4)
        time.sleep(0.5)


@pytest.fixture(scope="module")
def mission(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("ctl")
    baseline = tmp / "baseline.json"  # the same mission, simulated, with no order
    done = _cli("sim", *MISSION, "--report", str(baseline), timeout=300)
    assert done.returncode == 0, done.stderr
    run_dir, log = tmp / "run", tmp / "launcher.log"
    with open(log, "w") as out:
        proc = subprocess.Popen(
            [sys.executable, "-m", "cotsfleet", "run", *MISSION, "--viewer", "none", "--warp",
             str(WARP), "--run-dir", str(run_dir), "--ctl", "unsigned:recall:auv1@600"],
            cwd=REPO, stdout=out,
            stderr=subprocess.STDOUT, text=True, start_new_session=True)
    pids: dict[str, list[int]] = {}
    ctl = ground = after = None
    try:
        deadline = time.monotonic() + 300
        while _mission_time(log) < RECALL_AT_S - 100 and proc.poll() is None:
            assert time.monotonic() < deadline, log.read_text()[-3000:]
            time.sleep(0.2)
        assert (run_dir / "run.json").is_file(), log.read_text()[-3000:]
        pids = json.loads((run_dir / "pids.json").read_text())
        ctl = _cli("ctl", "--run-dir", str(run_dir), "recall", "auv2", "--timeout", "120")
        record = read_run_record(run_dir)  # what a ground station elsewhere is given
        ground = _cli("ctl", "--connect", record.endpoint, "--credentials",
                      str(Path(record.credentials) / "ground"), "recall", "auv2",
                      "--timeout", "0")
        _foreign_requests(run_dir)
        proc.wait(timeout=400)
        after = _cli("ctl", "--run-dir", str(run_dir), "resume", "auv2", timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        time.sleep(1.0)
        left = [(n, p) for n, group in pids.items() for p in group if alive(p)]
        if alive(proc.pid):
            left.append(("launcher", proc.pid))
        for _, pid in left:
            os.killpg(pid, signal.SIGKILL)
    report = json.loads((run_dir / "report.json").read_text())
    return (report, json.loads(baseline.read_text()), proc.returncode, log.read_text(), ctl,
            after, left, ground)


def _vehicle(report: dict, vid: str) -> dict:
    return next(v for v in report["vehicles"] if v["id"] == vid)


def test_ctl_is_acknowledged_by_auv2(mission):
    _, _, _, out, ctl, _, _, _ = mission
    assert ctl.returncode == 0, (ctl.stdout, ctl.stderr, out[-3000:])
    lines = ctl.stdout.splitlines()
    assert re.match(r"order #1 recall auv2: sent from the topside at mission time \d+ s, "
                    r"for auv2", lines[0]), ctl.stdout
    assert re.match(r"  auv2 acknowledged \(heard by the topside at \d+ s\)", lines[1])


def test_auv2_came_home_early_and_the_others_took_over(mission):
    report, baseline, code, out, _, _, _, _ = mission
    assert code == 0, out[-3000:]
    assert "failure" not in report
    used, alone = (_vehicle(r, "auv2")["battery_used_s"] for r in (report, baseline))
    # `ctl` was started at ~1100 s; a loaded machine may start it later (at warp 60 each
    # wall second of its start-up is 60 s of mission): its order's own time is the mark
    issued = report["commands"]["sent"][0]["issued_s"]
    assert used < alone - 1000, (used, alone)  # home early, not at the battery's end
    assert used < issued + 800, (used, issued)  # acted on in a few intervals, then home
    assert all(v["home"] for v in report["vehicles"])
    assert report["fleet"]["duplicate_treatments"] == 0
    assert report["fleet"]["spots_taken_over"] > 0
    assert re.search(r"auv[13]\s+took over spots .* from auv2", out)


def test_the_report_shows_the_order_acknowledged(mission):
    report, _, _, _, _, _, _, _ = mission
    commands = report["commands"]
    sent = commands["sent"][0]
    assert (sent["seq"], sent["order"], sent["target"], sent["by"]) == (
        1, "recall auv2", "auv2", "operator")
    assert RECALL_AT_S - 150 <= sent["issued_s"] <= RECALL_AT_S + 1200
    assert sent["issued_s"] < sent["acked"]["auv2"] < sent["issued_s"] + 240
    assert set(commands["taken"]) == {"auv2"}  # and the ground station's #2, if in time
    # the insider's forgery reached the vehicles and was refused: auv1 was not recalled
    assert commands["refused"].get("unsigned", 0) >= 1, commands
    assert _vehicle(report, "auv1")["battery_used_s"] > RECALL_AT_S + 1000


def test_foreign_requests_are_refused_and_counted(mission):
    report, _, _, _, _, _, _, _ = mission
    sec = report["security"]
    assert sec["orders"] == {"not_allowed": 1, "malformed": 1}, sec
    assert sec["refused_total"] >= 2
    # the forged "recall all" sent nothing: the operator's order and the ground station's
    assert [s["by"] for s in report["commands"]["sent"]] == ["operator", "ground"]
    assert sum(not v["home"] for v in report["vehicles"]) == 0


def test_the_ground_stations_order_is_taken_and_counted_as_its_own(mission):
    report, _, _, out, _, _, _, ground = mission
    assert ground.returncode == 0, (ground.stdout, ground.stderr, out[-3000:])
    assert re.match(r"order #2 recall auv2: sent from the topside at mission time \d+ s, "
                    r"for auv2$", ground.stdout.strip()), ground.stdout
    [_, sent] = report["commands"]["sent"]
    assert (sent["seq"], sent["order"], sent["by"]) == (2, "recall auv2", "ground")
    assert report["security"]["orders_taken"] == {"operator": 1, "ground": 1}


def test_after_the_mission_ctl_says_it_is_over_and_nothing_is_left(mission):
    _, _, _, _, _, after, left, _ = mission
    assert after.returncode == 2
    assert "no mission is running in" in after.stderr, after.stderr
    assert left == []
