"""The clock never outruns the fleet: a real multi-process mission in which one agent's
process is starved for a few seconds (frozen with SIGSTOP half of the time, as on a
machine too busy to schedule it). It reports status after status how far behind the mission
clock it runs, the operator slows the shared clock down, every process follows the new clock
record, and the mission is the same mission: no false alarm, no duplicate, everyone home; the
report and the launcher say what the clock did."""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from cotsfleet.commands.run import run_warnings
from cotsfleet.mission.report_model import MissionReport
from cotsfleet.mission.processes import ProcessBackend, ProcessOptions
from cotsfleet.mission.runner import run_mission
from reef_sim.scenarios.field import GeneratorParams, generate_doc
from hfc_core.formats.scenario import problem_from_dict
from leftovers import kill_children

pytestmark = pytest.mark.integration
WARP = 100.0


@pytest.fixture(scope="module")
def paced(tmp_path_factory):
    run_dir: Path = tmp_path_factory.mktemp("paced")
    doc = generate_doc(GeneratorParams(name="paced", n_tasks=30, n_vehicles=3, size_m=600.0,
                                       battery_s=1500.0, service_s=60.0),
                       np.random.default_rng(5))
    problem = problem_from_dict(doc)
    launcher = ProcessBackend(problem, doc, 5, ProcessOptions(warp=WARP, run_dir=run_dir,
                                                              progress_every_s=0),
                              out=lambda line: None)
    result: dict = {}
    thread = threading.Thread(target=lambda: result.update(report=run_mission(
        problem, launcher, (), seed=5, step_s=25.0).report.to_dict()), daemon=True)
    thread.start()
    try:
        assert launcher.started.wait(120), "mission never started"
        while launcher.now() < 300.0:
            time.sleep(0.05)
        pid = launcher.children["auv1"].popen.pid
        starve_until = time.monotonic() + 3.0
        while time.monotonic() < starve_until:  # half of its time taken, 3 s long
            os.kill(pid, signal.SIGSTOP)  # 40 ms of wall: 4 mission seconds at warp 100
            time.sleep(0.04)
            os.kill(pid, signal.SIGCONT)
            time.sleep(0.04)
        thread.join(timeout=180)
    finally:
        if thread.is_alive():
            kill_children(launcher)
    assert not thread.is_alive(), "the launcher did not finish"
    for name, p in launcher.children.items():
        assert p.popen.poll() is not None, f"{name} still running"
    return result["report"], launcher


def test_the_lagging_process_slowed_the_clock(paced):
    paced, _ = paced
    clock = paced["clock"]
    assert clock["warp"] == WARP
    assert clock["max_lag_s"] > 2.0  # the starved agent said how far behind it ran
    assert clock["slowdowns"] and min(s["warp"] for s in clock["slowdowns"]) < WARP
    assert clock["effective_warp"] < WARP
    assert any("slowed" in line for line in run_warnings(MissionReport.from_dict(paced)))


def test_every_process_followed_the_slower_clock(paced):
    # Final statuses are stamped with each agent's own clock when the operator stops it: an
    # agent still on the old warp would be tens of mission seconds ahead of the operator.
    report, launcher = paced
    assert report["fleet"]["vehicles_home"] == 3
    stopped_at = launcher.now()
    for vid, status in launcher.ledger.statuses.items():
        assert status.t_s <= stopped_at + 5.0, (vid, status.t_s, stopped_at)


def test_the_same_mission_no_false_alarm_no_duplicate(paced):
    # Before the first slowdown the starved agent may wake after its slot went by: it sends
    # at once, dated at the slot, and the relay places the frame there (whether a slot falls
    # in a frozen half is luck here; tests/cotsfleet/test_stall.py makes it certain).
    paced, _ = paced
    assert paced["clock"]["max_frame_late_s"] > 0.0  # frames placed at their send time
    f = paced["fleet"]
    assert f["duplicate_treatments"] == 0
    assert f["false_alarms"] == 0
    assert all(code == 0 for code in paced["exit_codes"].values()), paced["exit_codes"]
