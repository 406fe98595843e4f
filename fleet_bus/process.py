"""Process plumbing every fleet process shares: stop on signals, die with the parent, and the
one-line ready messages the launcher waits for."""

from __future__ import annotations

import ctypes
import faulthandler
import os
import signal
import sys
import threading
import time
from types import FrameType

# Ready lines: each process prints exactly one, starting with its prefix, when it serves.
ROUTER_READY = "comms_sim router listening on"
RELAY_READY = "comms_sim relay ready"
WATER_READY = "comms_sim water ready"  # `cotsfleet water`: every emulated modem listens
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
    the first call). Either way an orphan gets `ORPHAN_GRACE_S` to end cleanly, then a
    watchdog ends it (`_orphan_deadline`). A process started by hand is left alone.
    Call from the main thread (it wraps the SIGTERM handler)."""
    expected = os.environ.get(PARENT_ENV)
    if not expected or not expected.isdigit():
        return
    parent = int(expected)
    try:
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):  # not Linux: the watcher below does the job
        pass
    # The kernel's SIGTERM arms the deadline at once, in the handler: the clean end it
    # starts may hang before the watcher's next poll (a teardown that never gives the GIL
    # back would stop the watcher thread too).
    chained = signal.getsignal(signal.SIGTERM)

    def on_term(signum: int, frame: FrameType | None) -> None:
        if os.getppid() != parent:
            _orphan_deadline()
        if callable(chained):
            chained(signum, frame)

    signal.signal(signal.SIGTERM, on_term)

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        _orphan_deadline()
        stop.set()

    if os.getppid() != parent:
        _orphan_deadline()
        stop.set()
    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


_deadline_armed = threading.Lock()


def _orphan_deadline() -> None:
    """End this process `ORPHAN_GRACE_S` from now, whatever it is doing then: faulthandler's
    watchdog is a C thread that needs no GIL, so it fires even through a deadlock in native
    code (it prints every thread's stack first: where the clean end was stuck). Armed once."""
    if not _deadline_armed.acquire(blocking=False):
        return
    try:
        if sys.__stderr__ is not None:
            faulthandler.dump_traceback_later(ORPHAN_GRACE_S, exit=True, file=sys.__stderr__)
        else:  # what file=None does: sys.stderr
            faulthandler.dump_traceback_later(ORPHAN_GRACE_S, exit=True)
    except (OSError, ValueError, AttributeError, RuntimeError):
        # No usable stderr for the watchdog: a plain timer thread ends the process instead
        # (it needs the GIL; the best left).
        threading.Timer(ORPHAN_GRACE_S, os._exit, args=(1,)).start()
    try:  # the launcher's end of the pipe may be gone with it
        print(f"{os.path.basename(sys.argv[0])}: parent gone; ending within "
              f"{ORPHAN_GRACE_S:g} s", file=sys.__stderr__, flush=True)
    except (OSError, ValueError, AttributeError, RuntimeError):
        pass


def ready(prefix: str, detail: str = "") -> None:
    """Print the ready line (flushed: the launcher reads it through a pipe)."""
    print(f"{prefix} {detail}".rstrip(), flush=True)


def process_stop() -> threading.Event:
    """The stop event of a fleet process's main: set by a signal or the parent's end."""
    stop = stop_on_signals()
    die_with_parent(stop)
    return stop
