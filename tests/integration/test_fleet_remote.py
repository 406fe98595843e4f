"""A mission spanning two Zenoh routers, as across two machines: the launcher's router and a
second one linked to it, with one vehicle's agent started by hand against the second router.
Every frame of that vehicle still crosses the relay on the first."""

from __future__ import annotations

import json
import selectors
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from cotsfleet.mission.faults import Fault, FaultError
from cotsfleet.mission.processes import ProcessBackend, ProcessOptions
from cotsfleet.mission.runner import run_mission
from fleet_agent.config import AgentConfig, dump_config
from fleet_bus.credentials import write_run_credentials
from fleet_bus.process import ROUTER_READY as READY
from fleet_bus.session import free_tcp_endpoint, local_endpoint
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import GeneratorParams, generate_doc

pytestmark = pytest.mark.integration
KEY_HEX = "00112233445566778899aabbccddeeff"


def _wait_line(proc: subprocess.Popen, prefix: str, timeout_s: float = 30.0) -> None:
    assert proc.stdout is not None
    sel = selectors.DefaultSelector()
    sel.register(proc.stdout, selectors.EVENT_READ)
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if sel.select(timeout=0.5):
            line = proc.stdout.readline()
            if line.startswith(prefix):
                return
            if not line and proc.poll() is not None:
                break
    raise AssertionError(f"no {prefix!r} line from {proc.args}")


def test_agent_behind_a_second_router_joins_the_mission(tmp_path: Path) -> None:
    doc = generate_doc(GeneratorParams(name="two-hosts", n_tasks=24, n_vehicles=3, size_m=500.0,
                                       battery_s=1200.0, service_s=60.0),
                       np.random.default_rng(5))
    config = AgentConfig(fleet_key_hex=KEY_HEX)
    (tmp_path / "agent.toml").write_text(dump_config(config), encoding="utf-8")
    (tmp_path / "scenario.json").write_text(json.dumps(doc), encoding="utf-8")
    creds = tmp_path / "credentials"  # made beforehand; each host gets its own directory
    write_run_credentials(creds, ("auv1", "auv2", "auv3"))
    host_a, host_b = free_tcp_endpoint(), free_tcp_endpoint()
    procs: list[subprocess.Popen] = []
    try:
        # "Machine B": its own router, linked to the launcher's, and auv3's agent on it. The
        # link is dialled from B and retried until A's router is up.
        router_b = subprocess.Popen(
            [sys.executable, "-m", "comms_sim.router", "--listen", host_b, "--connect", host_a,
             "--credentials", str(creds / "router")],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        procs.append(router_b)
        _wait_line(router_b, READY)
        agent = subprocess.Popen(
            [sys.executable, "-m", "fleet_agent", "--id", "auv3",
             "--config", str(tmp_path / "agent.toml"),
             "--connect", host_b, "--journal", str(tmp_path / "auv3.journal"),
             "--credentials", str(creds / "auv3")],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        procs.append(agent)
        opts = ProcessOptions(warp=100.0, run_dir=tmp_path / "run", listen=host_a,
                              remote=("auv3",), agent_config=config, progress_every_s=0,
                              startup_timeout_s=60, credentials=creds)
        problem = problem_from_dict(doc)
        backend = ProcessBackend(problem, doc, 2, opts, out=lambda line: None)
        report = run_mission(problem, backend, (), seed=2, step_s=25.0).report.to_dict()
        assert agent.wait(timeout=30) == 0, "the launcher's stop command ends the remote agent"
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()
    vehicles = {v["id"]: v for v in report["vehicles"]}
    assert set(vehicles) == {"auv1", "auv2", "auv3"}
    assert vehicles["auv3"]["tasks_treated"] > 0 and vehicles["auv3"]["home"]
    assert all(v["home"] and v["t_diff_s"] >= 0 for v in vehicles.values())
    assert report["fleet"]["duplicate_treatments"] == 0
    # auv3's frames went through the relay like everyone's: the relay counted them.
    by_sender = report["messages"]["link_by_sender"]
    assert by_sender["auv3"]["delivered"] > 0 and by_sender["auv1"]["delivered"] > 0


def test_local_endpoint_of_a_wildcard_listen() -> None:
    assert local_endpoint("tcp/0.0.0.0:7447") == "tcp/127.0.0.1:7447"
    assert local_endpoint("tcp/10.0.0.5:7447") == "tcp/10.0.0.5:7447"


def test_remote_vehicles_need_a_shared_key_and_cannot_be_killed(tmp_path: Path) -> None:
    doc = generate_doc(GeneratorParams(name="x", n_tasks=6, n_vehicles=2, size_m=200.0,
                                       battery_s=600.0, service_s=30.0),
                       np.random.default_rng(0))
    problem = problem_from_dict(doc)
    with pytest.raises(ValueError, match="fleet key"):
        ProcessBackend(problem, doc, 0, ProcessOptions(remote=("auv2",)))
    keyed = AgentConfig(fleet_key_hex=KEY_HEX)
    with pytest.raises(ValueError, match="credentials before the mission"):
        ProcessBackend(problem, doc, 0, ProcessOptions(remote=("auv2",), agent_config=keyed))
    write_run_credentials(tmp_path / "c3", ("auv1", "auv2", "auv3"))
    with pytest.raises(ValueError, match="is for vehicles"):
        ProcessBackend(problem, doc, 0, ProcessOptions(remote=("auv2",), agent_config=keyed,
                                                       credentials=tmp_path / "c3"))
    write_run_credentials(tmp_path / "c", ("auv1", "auv2"))
    backend = ProcessBackend(problem, doc, 0, ProcessOptions(remote=("auv2",),
                                                             agent_config=keyed,
                                                             credentials=tmp_path / "c"))
    with pytest.raises(FaultError, match="not for --remote"):
        run_mission(problem, backend, (Fault("kill", 10.0, "auv2"),), seed=0, step_s=1.0)
    assert not backend.children  # refused before anything started
    with pytest.raises(ValueError, match="unknown remote vehicle"):
        ProcessBackend(problem, doc, 0, ProcessOptions(remote=("auv9",), agent_config=keyed))
