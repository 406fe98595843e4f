"""Ctrl-C on `cotsfleet run` stops every process it started and still writes a report (on a
TLS bus, asked for with --tls on loopback: its sessions end as promptly)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from leftovers import alive

REPO = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.integration


def test_ctrl_c_stops_the_whole_fleet(tmp_path: Path) -> None:
    run_dir = tmp_path / "run"
    proc = subprocess.Popen(
        [sys.executable, "-m", "cotsfleet", "run", "--viewer", "none", "--warp", "20",
         "--run-dir", str(run_dir), "--seed", "1", "--tls"],
        cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    pids: dict[str, list[int]] = {}
    try:
        assert proc.stdout is not None
        deadline = time.monotonic() + 120
        for line in proc.stdout:  # wait until the mission runs and reports progress
            if line.startswith("t=") or time.monotonic() > deadline:
                break
        pids = json.loads((run_dir / "pids.json").read_text())
        assert set(pids) >= {"router", "relay", "auv1", "auv2", "auv3"}
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
        assert proc.returncode == 130, out[-2000:]
    finally:
        if proc.poll() is None:
            proc.kill()
        for group in pids.values():  # whatever happens, leave nothing behind
            for pid in group:
                if alive(pid):
                    os.killpg(pid, signal.SIGKILL)
    leftovers = [(name, pid) for name, group in pids.items() for pid in group if alive(pid)]
    assert leftovers == []
    report = json.loads((run_dir / "report.json").read_text())
    assert report["interrupted"] is True
    assert {v["id"] for v in report["vehicles"]} == {"auv1", "auv2", "auv3"}
    assert (run_dir / "credentials" / "auv1" / "tls.pem").exists()  # it was TLS
