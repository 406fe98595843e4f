"""A child of a launcher ends when the launcher dies, even if it is stuck and never looks at
its stop event (fleet_bus.process.die_with_parent): real processes."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import textwrap
import time
from typing import Iterator

from fleet_bus.process import ORPHAN_GRACE_S, PARENT_ENV

STUCK_CHILD = textwrap.dedent("""
    import time
    from fleet_bus.process import process_stop
    stop = process_stop()
    print("ready", flush=True)
    while True:  # stuck: never looks at stop
        time.sleep(0.05)
""")

PARENT = textwrap.dedent("""
    import os, subprocess, sys, time
    child = subprocess.Popen([sys.executable, "-c", sys.argv[1]], stdout=subprocess.PIPE,
                             env={**os.environ, %r: str(os.getpid())}, text=True)
    assert child.stdout.readline() == "ready\\n"
    print(child.pid, flush=True)
    time.sleep(60)
""" % PARENT_ENV)


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as fh:
        return fh.read().split(")")[-1].split()[0] != "Z"


@contextlib.contextmanager
def family(child_src: str) -> Iterator[tuple[subprocess.Popen, int]]:
    """A parent running ``child_src`` as its child; yields both, kills both at the end."""
    parent = subprocess.Popen([sys.executable, "-c", PARENT, child_src],
                              stdout=subprocess.PIPE, text=True)
    child = 0
    try:
        assert parent.stdout is not None
        child = int(parent.stdout.readline())
        yield parent, child
    finally:
        if parent.poll() is None:
            parent.kill()
        parent.wait()
        if child and alive(child):
            os.kill(child, signal.SIGKILL)


def orphan(parent: subprocess.Popen, child: int, limit_s: float) -> float:
    """SIGKILL ``parent``; wall seconds until ``child`` is gone (or ``limit_s``)."""
    parent.send_signal(signal.SIGKILL)
    parent.wait()
    t0 = time.monotonic()
    while alive(child) and time.monotonic() - t0 < limit_s:
        time.sleep(0.1)
    return time.monotonic() - t0


def test_a_stuck_orphan_is_ended_after_the_grace() -> None:
    with family(STUCK_CHILD) as (parent, child):
        time.sleep(1.0)
        assert alive(child)  # a living parent: the child stays
        waited = orphan(parent, child, ORPHAN_GRACE_S + 5)
        assert not alive(child)
        assert waited >= ORPHAN_GRACE_S - 1  # it was given its grace first


# Stuck the way a native teardown deadlock is: its clean end begins (stop is set by the
# kernel's SIGTERM) and then holds the GIL for good, so no Python thread runs again.
GIL_HELD_CHILD = textwrap.dedent("""
    import itertools
    from fleet_bus.process import process_stop
    stop = process_stop()
    print("ready", flush=True)
    stop.wait()
    sum(itertools.repeat(1, 10**15))  # one C call that never releases the GIL
""")


def test_an_orphan_whose_clean_end_holds_the_gil_is_still_ended() -> None:
    """The deadline after the parent's death is kept by a watchdog that needs no GIL (the
    watcher thread alone would wait forever for it)."""
    with family(GIL_HELD_CHILD) as (parent, child):
        orphan(parent, child, ORPHAN_GRACE_S + 10)
        assert not alive(child)
