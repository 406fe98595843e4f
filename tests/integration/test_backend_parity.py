"""One mission, two backends: the same seed run in-process (discrete-event loop) and as OS
processes over Zenoh (warp clock) makes the same decisions.

Both backends drive the same agents through the same driver, feed the water the same
positions (published truths) and draw the channel from the same stream, so on a small reef
without extra loss every vehicle treats the same spots in the same order, and the spots an
abort frees go to the same survivors.
"""

from __future__ import annotations

import numpy as np
import pytest

from cotsfleet.mission.faults import Fault
from cotsfleet.mission.inprocess import simulate
from cotsfleet.mission.processes import ProcessBackend, ProcessOptions
from cotsfleet.mission.runner import run_mission
from fleet_agent.config import AgentConfig
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import GeneratorParams, generate_doc

pytestmark = pytest.mark.integration
SEED = 4
KEY_HEX = "8f" * 16


def decisions(events) -> dict[str, object]:
    """What the fleet decided: who treated what, in order, and who took over what."""
    treated: dict[str, list[int]] = {}
    taken: dict[str, set[int]] = {}
    for e in events:
        if e.kind == "cleared":
            treated.setdefault(e.id, []).extend(e.tasks)
        elif e.kind == "takeover":
            taken.setdefault(e.id, set()).update(e.tasks)
    return {"treated": treated, "takeover": taken}


def test_the_same_seed_makes_the_same_decisions_in_both_backends(tmp_path) -> None:
    doc = generate_doc(GeneratorParams(name="parity", n_tasks=24, n_vehicles=3, size_m=300.0,
                                       battery_s=1200.0, service_s=40.0),
                       np.random.default_rng(SEED))
    problem = problem_from_dict(doc)
    config = AgentConfig(fleet_key_hex=KEY_HEX)
    faults = (Fault("abort", 400.0, "auv2"),)
    sim = simulate(problem, config, seed=SEED, faults=faults)
    backend = ProcessBackend(problem, doc, SEED, ProcessOptions(
        warp=40.0, run_dir=tmp_path, agent_config=config, progress_every_s=0),
        out=lambda line: None)
    run = run_mission(problem, backend, faults, seed=SEED, step_s=10.0)
    assert all(c.popen.poll() is not None for c in backend.children.values())
    in_process, processes = decisions(sim.events), decisions(backend.ledger.events)
    assert in_process["treated"], "the in-process fleet treated nothing"
    assert processes == in_process
    for key in ("spots_cleared", "duplicate_treatments", "vehicles_home", "spots_taken_over"):
        assert getattr(run.report.fleet, key) == getattr(sim.report.fleet, key), key
