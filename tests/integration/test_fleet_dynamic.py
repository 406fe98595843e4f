"""A real multi-process mission on a dynamic scenario (a hidden reef): router, relay and one
agent process per AUV on loopback, with an abort. The agents see the reef only through the
camera their driver carries; the report is the real reef's."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import numpy as np
import pytest

from cotsfleet.mission.faults import Fault
from cotsfleet.mission.processes import ProcessBackend, ProcessOptions
from cotsfleet.mission.runner import run_mission
from reef_sim.scenarios.dynamic import DynamicParams, generate_dynamic_doc
from reef_sim.scenarios.field import GeneratorParams
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.truth import reef_from_doc
from leftovers import alive, kill_children

pytestmark = pytest.mark.integration


def dynamic_scenario() -> dict:
    params = DynamicParams(base=GeneratorParams(name="small-dyn", n_tasks=30, n_vehicles=3,
                                                size_m=600.0, battery_s=1500.0,
                                                service_s=60.0), n_unmapped=5)
    doc = generate_dynamic_doc(params, np.random.default_rng(5))
    doc["truth"]["p_detect"] = 1.0  # every pass sees: finds are certain to happen
    return doc


@pytest.fixture(scope="module")
def mission(tmp_path_factory):
    run_dir: Path = tmp_path_factory.mktemp("fleet-dynamic")
    doc = dynamic_scenario()
    problem = problem_from_dict(doc)
    reef = reef_from_doc(doc, problem)
    faults = (Fault("abort", 600.0, "auv2"),)
    launcher = ProcessBackend(problem, doc, 2, ProcessOptions(warp=100.0, run_dir=run_dir,
                                                              progress_every_s=0),
                              out=lambda line: None)
    result: dict = {}
    thread = threading.Thread(target=lambda: result.update(report=run_mission(
        problem, launcher, faults, seed=2, step_s=25.0, reef=reef).report.to_dict()), daemon=True)
    thread.start()
    try:
        thread.join(timeout=240)
    finally:
        if thread.is_alive():  # last resort: never leave processes behind
            kill_children(launcher)
    assert not thread.is_alive(), "the launcher did not finish"
    return result["report"], launcher, reef


def test_every_process_ended_and_nothing_crashed(mission):
    report, launcher, _ = mission
    assert launcher.children
    for name, p in launcher.children.items():
        assert p.popen.poll() is not None and not alive(p.popen.pid), f"{name} still running"
        try:
            os.killpg(p.popen.pid, 0)
        except ProcessLookupError:
            continue  # the whole process group is gone
        pytest.fail(f"{name}'s process group is still there")
    assert all(code == 0 for code in report["exit_codes"].values()), report["exit_codes"]
    assert not report.get("failure")


def test_the_fleet_worked_the_real_reef(mission):
    report, _, reef = mission
    d, f = report["dynamic"], report["fleet"]
    spots = {t["spot"] for t in d["treated"]}
    assert spots and all(reef.spots[s] for s in spots)
    assert f["duplicate_treatments"] == 0 == len(d["treated"]) - len(spots)
    assert f["priority"] == pytest.approx(sum(reef.spots[s].priority for s in spots), abs=0.05)
    assert d["spots_discovered"] >= 1 and d["unmapped_treated"] >= 1
    assert d["empty_inspected"] >= 1
    assert d["truth_priority"] == pytest.approx(reef.total_priority(), abs=0.01)
    v = {x["id"]: x for x in report["vehicles"]}
    assert v["auv2"]["aborted"]
    for vid in ("auv1", "auv3"):
        assert v[vid]["home"] and v[vid]["t_diff_s"] >= 0, v[vid]
    assert report["messages"]["largest_frame_bytes"] <= 64
    assert report["messages"]["by_kind"].get("found", 0) >= 1
