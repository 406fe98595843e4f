"""One host's wall clock steps, +2 s then -2 s, during a real 3-AUV mission at warp 60 (the
issue's case: on the wall-clock form 804 frames were refused as from the future, a live
vehicle was declared lost and a spot treated twice; the step back made 61 false alarms).

The step is made in one child only: the test puts a ``sitecustomize`` on that child's
``PYTHONPATH`` (`ProcessOptions.child_env`) that offsets ``time.time`` by the steps given in
``COTSFLEET_TEST_WALL_STEPS`` at the wall seconds given, as ``date -s`` would; the machine's
clock is never touched. Mission time runs on the monotonic clock: the same mission as
without the steps (the same spots treated, no duplicate, no false alarm, no frame refused
as from the future), and the stepped host named in the report."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest
from leftovers import kill_children

from cotsfleet.mission.processes import ProcessBackend, ProcessOptions
from cotsfleet.mission.runner import run_mission
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import paper_preset_doc

pytestmark = [pytest.mark.integration, pytest.mark.slow]
WARP, SEED = 60.0, 7
# +2 s 30 wall seconds after the process starts, -2 s 20 s later: both after the agent is
# watching its clock even on a slow host under the whole suite's load (at 15 s one host
# was still starting, and the agent saw only the step back), both before the mission's end
# (about 62 s of wall time at warp 60, after the start).
STEPS = "30:+2,50:-2"

HOOK = '''
import os, time

def _install(spec):
    t0, real, steps = time.monotonic(), time.time, []
    for part in spec.split(","):
        at, step = part.split(":")
        steps.append((float(at), float(step)))

    def stepped():
        since = time.monotonic() - t0
        return real() + sum(step for at, step in steps if since >= at)
    time.time = stepped

if os.environ.get("COTSFLEET_TEST_WALL_STEPS"):
    _install(os.environ["COTSFLEET_TEST_WALL_STEPS"])
'''


def mission(run_dir: Path, child_env: dict) -> dict:
    doc = paper_preset_doc(SEED)
    problem = problem_from_dict(doc)
    backend = ProcessBackend(problem, doc, SEED, ProcessOptions(
        warp=WARP, run_dir=run_dir, progress_every_s=0, child_env=child_env),
        out=lambda line: None)
    result: dict = {}
    thread = threading.Thread(target=lambda: result.update(report=run_mission(
        problem, backend, (), seed=SEED, step_s=WARP * 0.25).report), daemon=True)
    thread.start()
    thread.join(400)
    if thread.is_alive():
        kill_children(backend)
    assert not thread.is_alive(), "the launcher did not finish"
    assert all(c.popen.poll() is not None for c in backend.children.values())
    report = result["report"].to_dict()
    report["_statuses"] = {vid: s.counters for vid, s in backend.ledger.statuses.items()}
    report["_treated"] = {vid: list(s.treated) for vid, s in backend.ledger.statuses.items()}
    return report


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, dict]:
    root = tmp_path_factory.mktemp("steps")
    hook = root / "hook"
    hook.mkdir()
    (hook / "sitecustomize.py").write_text(HOOK, encoding="utf-8")
    path = os.pathsep.join(p for p in (str(hook), os.environ.get("PYTHONPATH", "")) if p)
    stepped = {"auv2": {"PYTHONPATH": path, "COTSFLEET_TEST_WALL_STEPS": STEPS}}
    return {"steady": mission(root / "steady", {}), "stepped": mission(root / "stepped", stepped)}


def test_the_stepped_host_is_named(runs) -> None:
    assert runs["stepped"]["clock"]["wall_steps"] == {"auv2": 2}
    assert runs["stepped"]["_statuses"]["auv2"].get("clock_wall_steps") == 2
    assert runs["steady"]["clock"]["wall_steps"] == {}


def test_no_duplicate_no_false_alarm_nothing_from_the_future(runs) -> None:
    for name, report in runs.items():
        f = report["fleet"]
        assert f["duplicate_treatments"] == 0 and f["false_alarms"] == 0, name
        assert f["vehicles_home"] == 3, name
        assert all(not c.get("drop_future") for c in report["_statuses"].values()), name
        assert all(code == 0 for code in report["exit_codes"].values()), name


def test_the_same_mission_as_without_the_steps(runs) -> None:
    steady, stepped = runs["steady"], runs["stepped"]
    assert stepped["_treated"] == steady["_treated"]
    assert stepped["fleet"]["priority"] == pytest.approx(steady["fleet"]["priority"])
