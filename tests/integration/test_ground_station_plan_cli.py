"""`cotsfleet plan --rrd` as a real process: the recording read back against the plan's JSON."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ground_station.recording_reader import read_recording

REPO = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.integration


def cotsfleet(*args: str) -> None:
    proc = subprocess.run([sys.executable, "-m", "cotsfleet", *args], cwd=REPO,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]


def test_plan_recording_matches_the_plan_json(tmp_path):
    scenario, plan_json, rrd = tmp_path / "s.json", tmp_path / "plan.json", tmp_path / "plan.rrd"
    cotsfleet("scenario", "--paper", "--seed", "5", "-o", str(scenario))
    cotsfleet("plan", str(scenario), "--mode", "hfc-cm", "--iterations", "20", "--seed", "1",
              "--json", str(plan_json), "--rrd", str(rrd))
    plan = json.loads(plan_json.read_text())
    doc = json.loads(scenario.read_text())
    ents = read_recording(rrd, timeline="iteration")
    pos = {t["id"]: t["pos"][:2] for t in doc["tasks"]}
    for v, vehicle in enumerate(plan["vehicles"]):
        spec = doc["vehicles"][v]
        (strip,) = ents[f"/map/routes/{vehicle['id']}"].static["LineStrips2D:strips"]
        np.testing.assert_allclose(
            strip, [spec["start"][:2], *(pos[t] for t in vehicle["route"]), spec["rendezvous"][:2]])
        got = ents[f"/convergence/t_diff_s/{vehicle['id']}"].series("Scalars:scalars")
        assert [(t, x[0]) for t, x in got] == [(float(h["iteration"]), h["t_diff_s"][v])
                                              for h in plan["history"]]
    total = ents["/convergence/cost/total"].series("Scalars:scalars")
    np.testing.assert_allclose([x[0] for _, x in total], [sum(h["cost"]) for h in plan["history"]])
    assert f"{plan['tasks_completed']}/{plan['tasks_total']} spots" in \
        ents["/summary"].static["TextDocument:text"][0]
