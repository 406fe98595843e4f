"""Whatever ends a sweep, no worker process outlives it: Ctrl-C at the terminal (SIGINT to the
whole process group), SIGTERM, SIGKILL of the sweep alone; the finished runs are written
when the sweep could still write (not after SIGKILL).

Each sweep runs as `python -m cotsfleet sim` in a session of its own, so every process it
started, at any depth, is found by its session id.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
RUNS = 40
pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")


def session_processes(sid: int) -> list[str]:
    """Running (not zombie) processes of session ``sid``: "pid cmdline"."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as fh:
                fields = fh.read().rsplit(")", 1)[1].split()
            if int(fields[3]) != sid or fields[0] == "Z":
                continue
            with open(f"/proc/{entry}/cmdline", "rb") as fh:
                cmdline = fh.read().replace(b"\0", b" ").decode(errors="replace")
            found.append(f"{entry} {cmdline[:120]}")
        except (OSError, IndexError, ValueError):
            continue  # it ended while we looked
    return found


def wait_gone(sid: int, timeout_s: float = 15.0) -> list[str]:
    deadline = time.monotonic() + timeout_s
    while (left := session_processes(sid)) and time.monotonic() < deadline:
        time.sleep(0.2)
    return left


def start_sweep(scenario: Path, out: Path, *extra: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "cotsfleet", "sim", "--scenario", str(scenario), "--runs",
         str(RUNS), "--jobs", "2", "--out", str(out), *extra],
        cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        start_new_session=True)


def wait_for_runs(proc: subprocess.Popen, n: int, timeout_s: float = 120.0) -> list[str]:
    """Read the progress lines until ``n`` runs finished; the sweep's workers are running."""
    assert proc.stderr is not None
    deadline, lines = time.monotonic() + timeout_s, []
    for line in proc.stderr:
        lines.append(line)
        if line.startswith(f"sim: {n}/{RUNS}") or time.monotonic() > deadline:
            break
    assert lines and lines[-1].startswith(f"sim: {n}/{RUNS}"), "".join(lines)
    return lines


@pytest.fixture(scope="module")
def scenario(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from cotsfleet.cli import main

    path = tmp_path_factory.mktemp("proc") / "small.json"
    assert main(["scenario", "--tasks", "12", "--vehicles", "2", "--size", "400",
                 "--battery-s", "900", "-o", str(path)]) == 0
    return path


def interrupt(proc: subprocess.Popen, how: str) -> None:
    if how == "ctrl-c":  # the terminal signals the whole foreground group
        os.killpg(proc.pid, signal.SIGINT)
    else:
        proc.send_signal(signal.SIGTERM)


def run_and_stop(scenario: Path, out: Path, how: str, *extra: str) -> None:
    proc = start_sweep(scenario, out, *extra)
    try:
        wait_for_runs(proc, 2)
        workers = len(session_processes(proc.pid)) - 1
        assert workers >= 2  # the sweep really runs in other processes
        interrupt(proc, how)
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        left = wait_gone(proc.pid)
        for line in left:  # never leave anything to the other tests
            os.kill(int(line.split()[0]), signal.SIGKILL)
    assert left == []
    assert proc.returncode == 130, stderr[-3000:]
    assert "Traceback" not in stderr, stderr[-3000:]
    assert "(interrupted)" in stdout
    runs = json.loads((out / "sweep.json").read_text())
    assert 2 <= len(runs) < RUNS and [r["seed"] for r in runs] == sorted(r["seed"] for r in runs)
    assert (out / "sweep.md").is_file()


@pytest.mark.parametrize("how", ["ctrl-c", "sigterm"])
def test_local_workers_stop_with_the_sweep_and_finished_runs_are_kept(
        scenario: Path, tmp_path: Path, how: str) -> None:
    run_and_stop(scenario, tmp_path / "out", how)


def test_local_workers_die_with_a_killed_sweep(scenario: Path, tmp_path: Path) -> None:
    proc = start_sweep(scenario, tmp_path / "out")
    try:
        wait_for_runs(proc, 1)
        proc.kill()  # SIGKILL: nothing of the sweep runs any more; the kernel ends the workers
        proc.wait()
    finally:
        left = wait_gone(proc.pid)
        for line in left:
            os.kill(int(line.split()[0]), signal.SIGKILL)
    assert left == []
