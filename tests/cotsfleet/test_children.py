"""The launcher's child processes (`cotsfleet.mission.children`): real processes, each
proven gone at the end of its test."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

import pytest

from cotsfleet.mission.children import ChildExited, Children

READY_THEN_WAIT = "import time; print('ready', flush=True); time.sleep(60)"
IGNORES_TERM = ("import signal, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); "
                "print('ready', flush=True); time.sleep(60)")


@pytest.fixture
def procs(tmp_path: Path):
    children = Children(tmp_path, out=lambda line: None, startup_timeout_s=20.0)
    yield children
    for c in children.by_name.values():  # nothing outlives the test
        if c.popen.poll() is None:
            c.signal_group(signal.SIGKILL)
            c.popen.wait(5.0)
        assert gone(c.popen.pid)


def gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


def test_a_child_is_ready_logged_listed_and_stopped(procs: Children, tmp_path: Path) -> None:
    child = procs.spawn("auv1", ["-c", READY_THEN_WAIT], ready_prefix="ready")
    procs.wait_ready(child)
    assert json.loads((tmp_path / "pids.json").read_text()) == {"auv1": [child.popen.pid]}
    procs.stop(["auv1"], grace_s=5.0)
    assert child.popen.returncode == -signal.SIGTERM and gone(child.popen.pid)
    assert procs.ended_untold() is None  # we stopped it: not news
    assert (tmp_path / "auv1.log").read_text() == "ready\n"


def test_a_child_deaf_to_sigterm_is_killed_after_the_grace(procs: Children) -> None:
    child = procs.spawn("relay", ["-c", IGNORES_TERM], ready_prefix="ready")
    procs.wait_ready(child)
    procs.stop(["relay"], grace_s=0.5)
    assert child.popen.returncode == -signal.SIGKILL


def test_a_child_that_ends_untold_is_reported_once(procs: Children) -> None:
    child = procs.spawn("auv2", ["-c", "print('ready', flush=True)"], ready_prefix="ready")
    procs.wait_ready(child)
    child.popen.wait(10.0)
    assert procs.ended_untold() is child and procs.ended_untold() is None


def test_a_child_that_dies_before_it_is_ready_says_why(procs: Children) -> None:
    child = procs.spawn("router", ["-c", "import sys; print('no port'); sys.exit(3)"],
                        ready_prefix="ready")
    with pytest.raises(ChildExited, match="router exited with 3: no port"):
        procs.wait_ready(child)


def test_a_child_whose_log_cannot_be_written_runs_on_and_is_named(procs: Children,
                                                                  tmp_path: Path) -> None:
    """A full disk, as the child's log sees it: /dev/full fails every write with ENOSPC. The
    pipe is still read (the child never blocks on it), its lines are still kept, and its
    own end on the full disk is named as such."""
    (tmp_path / "auv1.log").symlink_to("/dev/full")
    script = ("import sys\nfor i in range(20000): print('x' * 100)\n"
              "print('OSError: [Errno 28] No space left on device: journal', flush=True)\n"
              "sys.exit(1)")
    child = procs.spawn("auv1", ["-c", script])
    child.popen.wait(30)
    assert procs.ended_untold() is child
    assert "No space left" in child.log_error
    assert child.why().startswith("auv1 exited with 1 (its disk is full): ")


def test_a_child_is_restarted_as_it_was(procs: Children, tmp_path: Path) -> None:
    first = procs.spawn("relay", ["-c", "import os; print('ready', os.environ['X'])"],
                        ready_prefix="ready", env={"X": "one"})
    first.popen.wait(30)
    again = procs.restart(procs.ended_untold())
    procs.wait_ready(again)
    assert again is procs.by_name["relay"] and again.popen.pid != first.popen.pid
    again.popen.wait(30)
    assert again.tail() == "ready one"
    assert len(json.loads((tmp_path / "pids.json").read_text())["relay"]) == 2
