"""What the lifecycle checks of the integration tests share: is a process still there."""

from __future__ import annotations

import os
from typing import Any


def alive(pid: int) -> bool:
    """Whether ``pid`` is a running process (a zombie is gone for our purposes)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


def kill_children(launcher: Any) -> None:
    """Last resort after a launcher that did not finish: SIGKILL the process group of each
    child still running, so a failing test leaves nothing behind."""
    for p in launcher.children.values():
        if p.popen.poll() is None:
            os.killpg(p.popen.pid, 9)
