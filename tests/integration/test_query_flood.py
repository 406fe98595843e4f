"""Queries are rationed per identity on a real mission: a listen-only login (the ground
station's identity, no signing key) and an insider (auv1's key and login) each ask the
operator's mission record as fast as they can for a few seconds. Before, the operator
answered 65,000 queries in 10 s, uncounted; now each gets its allowance, the rest is dropped
and counted under its name, and the mission is the same."""

from __future__ import annotations

import secrets
import threading
import time
from pathlib import Path

import pytest
import zenoh
from leftovers import kill_children

from cotsfleet.mission.processes import ProcessBackend, ProcessOptions
from cotsfleet.mission.runner import run_mission
from fleet_bus import keys
from fleet_bus.auth import seal_query
from fleet_bus.credentials import load_auth, write_run_credentials
from fleet_bus.query_limits import BURST, RATE_PER_S, UNSIGNED_BURST, UNSIGNED_RATE_PER_S
from fleet_bus.session import client_config
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import paper_preset_doc

pytestmark = [pytest.mark.integration, pytest.mark.slow]
FLOOD_S = 4.0


def flood(endpoint: str, creds: Path, who: str, signer: str | None) -> int:
    """Ask ``fleet/mission`` for `FLOOD_S` seconds, ten queries in flight; answers got."""
    auth = load_auth(creds / who, signer)
    got = 0
    with zenoh.open(client_config([endpoint], credentials=creds / who)) as session:
        end = time.monotonic() + FLOOD_S
        while time.monotonic() < end:
            pending = []
            for _ in range(10):
                nonce = secrets.token_hex(8)
                pending.append(session.get(f"{keys.MISSION}?n={nonce}", timeout=0.5,
                                           attachment=seal_query(auth, keys.MISSION, nonce)))
            for replies in pending:
                got += sum(1 for r in replies if r.ok is not None)
    return got


def test_a_query_flood_is_rationed_per_identity_and_counted(tmp_path: Path) -> None:
    doc = paper_preset_doc(7)
    problem = problem_from_dict(doc)
    creds = tmp_path / "credentials"
    write_run_credentials(creds, ("auv1", "auv2", "auv3"))
    backend = ProcessBackend(problem, doc, 7, ProcessOptions(
        warp=60.0, run_dir=tmp_path / "run", progress_every_s=0, credentials=creds),
        out=lambda line: None)
    result: dict = {}
    thread = threading.Thread(target=lambda: result.update(report=run_mission(
        problem, backend, (), seed=7, step_s=15.0).report), daemon=True)
    thread.start()
    got: dict[str, int] = {}
    try:
        assert backend.started.wait(300), "the mission never started"
        for who, signer in (("station", None), ("auv1", "auv1")):
            got[who] = flood(backend.endpoint, creds, who, signer)
        thread.join(400)
    finally:
        if thread.is_alive():
            kill_children(backend)
    assert not thread.is_alive()
    report = result["report"].to_dict()
    asked = report["queries"]["operator"]
    unsigned_cap = UNSIGNED_BURST + UNSIGNED_RATE_PER_S * (FLOOD_S + 1)
    assert 0 < got["station"] <= unsigned_cap and asked["limited"]["unsigned"] > 100
    signed_cap = BURST + RATE_PER_S * (FLOOD_S + 1) + 70  # + auv1's own clock exchanges
    assert asked["answered"]["auv1"] <= signed_cap and asked["limited"]["auv1"] > 100
    f = report["fleet"]
    assert f["vehicles_home"] == 3 and f["duplicate_treatments"] == 0
    print(f"answered {got}, operator's counts {asked}")
