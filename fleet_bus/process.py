"""Process plumbing every fleet process shares: stop on signals, die with the parent, and the
one-line ready messages the launcher waits for."""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading
import time

# Ready lines: each process prints exactly one, starting with its prefix, when it serves.
ROUTER_READY = "comms_sim router listening on"
RELAY_READY = "comms_sim relay ready"
AGENT_READY = "fleet_agent ready"
STATION_READY = "ground_station: mission"

PARENT_ENV = "COTSFLEET_PARENT_PID"  # set by the launcher for every process it starts
_PR_SET_PDEATHSIG = 1
PARENT_POLL_S = 0.5
ORPHAN_GRACE_S = 4.0  # an orphan still running this long after its parent died is ended


def stop_on_signals() -> threading.Event:
    """An event set by SIGTERM, SIGINT or SIGHUP (call from the main thread)."""
    stop = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
        signal.signal(sig, lambda *_: stop.set())
    return stop


def die_with_parent(stop: threading.Event) -> None:
    """If a launcher started this process (``COTSFLEET_PARENT_PID``), end it with the launcher
    however the launcher ends, SIGKILL included: the kernel sends SIGTERM when the parent dies
    (``PR_SET_PDEATHSIG``, Linux), and a watcher thread sets ``stop`` once the parent's pid
    is no longer this process's parent (every platform; also covers a parent that died before
    the first call), and ends the process outright if it is still there `ORPHAN_GRACE_S`
    later. A process started by hand is left alone."""
    expected = os.environ.get(PARENT_ENV)
    if not expected or not expected.isdigit():
        return
    parent = int(expected)
    try:
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):  # not Linux: the watcher below does the job
        pass

    def watch() -> None:
        # Polls even once ``stop`` is set (the kernel's SIGTERM sets it first): an orphan
        # that has not ended within `ORPHAN_GRACE_S` is stuck (e.g. in a call that does not
        # look at ``stop``) and leaves at once. Its journal is flushed at every record.
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        stop.set()
        time.sleep(ORPHAN_GRACE_S)
        try:  # the launcher's end of the pipe may be gone with it
            print(f"{os.path.basename(sys.argv[0])}: parent gone and not ended after "
                  f"{ORPHAN_GRACE_S:g} s; exiting now", file=sys.stderr, flush=True)
        except (OSError, ValueError):
            pass
        os._exit(1)

    if os.getppid() != parent:
        stop.set()
    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def ready(prefix: str, detail: str = "") -> None:
    """Print the ready line (flushed: the launcher reads it through a pipe)."""
    print(f"{prefix} {detail}".rstrip(), flush=True)


def process_stop() -> threading.Event:
    """The stop event of a fleet process's main: set by a signal or the parent's end."""
    stop = stop_on_signals()
    die_with_parent(stop)
    return stop
