"""No process outlives its mission: SIGTERM, SIGINT, SIGHUP or SIGKILL of `cotsfleet run`
ends every child within 10 s; a router that crashes ends the mission cleanly with a report
that names it; a busy router port is a one-line error (exit 2); the router listens on
loopback unless told otherwise. Real `cotsfleet run` processes on loopback."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from reef_sim.scenarios.field import GeneratorParams, generate_doc
from leftovers import alive

REPO = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.integration
CHILDREN = {"router", "relay", "auv1", "auv2", "auv3"}
GONE_WITHIN_S = 10.0


@pytest.fixture(scope="module")
def scenario(tmp_path_factory) -> Path:
    doc = generate_doc(GeneratorParams(name="lifecycle", n_tasks=15, n_vehicles=3, size_m=500.0,
                                       battery_s=1800.0, service_s=60.0),
                       np.random.default_rng(4))
    path = tmp_path_factory.mktemp("lifecycle") / "scenario.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


class Launcher:
    """`cotsfleet run` in its own process, read until the mission runs."""

    def __init__(self, scenario: Path, run_dir: Path, *extra: str) -> None:
        self.run_dir = run_dir
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "cotsfleet", "run", "--scenario", str(scenario),
             "--viewer", "none", "--warp", "10", "--run-dir", str(run_dir), *extra],
            cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.pids: dict[str, list[int]] = {}

    def wait_running(self) -> None:
        assert self.proc.stdout is not None
        deadline = time.monotonic() + 180
        for line in self.proc.stdout:
            if line.startswith("t=") or time.monotonic() > deadline:
                break
        self.pids = json.loads((self.run_dir / "pids.json").read_text())
        assert set(self.pids) >= CHILDREN, self.pids

    def leftovers(self) -> list[tuple[str, int]]:
        return [(n, p) for n, group in self.pids.items() for p in group if alive(p)]

    def wait_children_gone(self, timeout_s: float) -> float:
        t0 = time.monotonic()
        while self.leftovers() and time.monotonic() - t0 < timeout_s:
            time.sleep(0.1)
        return time.monotonic() - t0

    def cleanup(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        for _, pid in self.leftovers():  # whatever happened, leave nothing behind
            os.killpg(pid, signal.SIGKILL)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT, signal.SIGHUP, signal.SIGKILL],
                         ids=lambda s: signal.Signals(s).name)
def test_every_child_ends_with_the_launcher(scenario: Path, tmp_path: Path, sig: int) -> None:
    launcher = Launcher(scenario, tmp_path / "run")
    try:
        launcher.wait_running()
        launcher.proc.send_signal(sig)
        launcher.proc.communicate(timeout=60)
        took = launcher.wait_children_gone(GONE_WITHIN_S + 5)
        assert launcher.leftovers() == [], f"left after {took:.1f} s"
        assert took <= GONE_WITHIN_S
        if sig == signal.SIGKILL:  # nothing could run in the launcher: the children saw it go
            assert launcher.proc.returncode == -signal.SIGKILL
        else:  # a clean end: the report is written and says it was interrupted
            assert launcher.proc.returncode == 130
            report = json.loads((launcher.run_dir / "report.json").read_text())
            assert report["interrupted"] is True
    finally:
        launcher.cleanup()


def test_a_crashing_router_ends_the_mission_with_a_report_naming_it(scenario: Path,
                                                                    tmp_path: Path) -> None:
    """The router carries everything: its crash ends the mission (the relay, the ground
    station and the agents are survived: tests/integration/test_crashes.py)."""
    launcher = Launcher(scenario, tmp_path / "run")
    try:
        launcher.wait_running()
        os.killpg(launcher.pids["router"][0], signal.SIGKILL)  # the router dies on its own
        out, _ = launcher.proc.communicate(timeout=90)
        assert launcher.proc.returncode == 1, out[-2000:]
        assert "the mission ended early: router exited with -9" in out
        assert "Traceback" not in out
        report = json.loads((launcher.run_dir / "report.json").read_text())
        assert report["failure"].startswith("router exited with -9")
        assert report["exit_codes"]["router"] == -9
        assert report["crashes"][0]["name"] == "router"
        assert launcher.wait_children_gone(GONE_WITHIN_S) <= GONE_WITHIN_S
        assert launcher.leftovers() == []
    finally:
        launcher.cleanup()


def test_a_busy_router_port_is_a_clear_error(scenario: Path, tmp_path: Path) -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        done = subprocess.run(
            [sys.executable, "-m", "cotsfleet", "run", "--scenario", str(scenario),
             "--viewer", "none", "--run-dir", str(tmp_path / "run"),
             "--listen", f"tcp/127.0.0.1:{port}"],
            cwd=REPO, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        f"cotsfleet run: error: --listen tcp/127.0.0.1:{port}: Address already in use"]
    assert not (tmp_path / "run" / "pids.json").exists()  # nothing was started


@pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="reads Linux's /proc/net/tcp")
def test_the_router_listens_on_loopback_only(tmp_path: Path) -> None:
    from fleet_bus.credentials import write_run_credentials
    from fleet_bus.process import ROUTER_READY
    from fleet_bus.session import free_tcp_endpoint

    write_run_credentials(tmp_path / "c", ("auv1",))
    endpoint = free_tcp_endpoint()
    port = int(endpoint.rsplit(":", 1)[1])
    proc = subprocess.Popen([sys.executable, "-m", "comms_sim.router", "--listen", endpoint,
                             "--credentials", str(tmp_path / "c" / "router")],
                            cwd=REPO, stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None and proc.stdout.readline().startswith(ROUTER_READY)
        found = set()
        for line in Path("/proc/net/tcp").read_text().splitlines()[1:]:
            local, state = line.split()[1], line.split()[3]
            addr, hex_port = local.split(":")
            if state == "0A" and int(hex_port, 16) == port:
                found.add(socket.inet_ntoa(bytes.fromhex(addr)[::-1]))
        assert found == {"127.0.0.1"}
    finally:
        proc.terminate()
        proc.wait(10)
