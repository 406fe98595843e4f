"""The launcher's child processes: the router, the link emulator, the agents and the ground
station of a multi-process mission.

Each runs in its own session (a process group: a signal reaches what it spawned too, e.g.
the station's viewer), with its output copied to ``<run dir>/<name>.log`` and its last lines
kept for the error a mission ends with. Each knows the launcher's pid
(``COTSFLEET_PARENT_PID``) and ends by itself if the launcher dies (`fleet_bus.process`);
every process group ever started is listed in ``pids.json`` for whoever must clean up after
a crash. A child is stopped gently (SIGTERM), then firmly (SIGKILL) after a grace period; one
that ends without being told to is reported once (`ended_untold`), with its last lines, and
can be started again as it was (`restart`).

A full disk stops none of this: a log that can no longer be written is given up (its lines
are still kept here, and the pipe is still read, so the child never blocks on it), and so is
``pids.json``; `why` recognises a child that died of the full disk.
"""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Callable, Mapping, Sequence

from cotsfleet.mission.runner import MissionStopped

LOG_LINES = 50  # last lines of output kept per child
DRAIN_S = 1.0  # wall seconds to read an ended child's last output


class ChildExited(MissionStopped):
    """A process of the mission ended on its own: the mission cannot go on as planned."""


@dataclass
class Child:
    name: str
    popen: subprocess.Popen
    ready: threading.Event = field(default_factory=threading.Event)
    lines: list[str] = field(default_factory=list)
    expected_exit: bool = False  # we stopped or killed it
    pump: threading.Thread | None = None  # copies its output to the log
    argv: tuple[str, ...] = ()  # how it was started (`Children.restart`)
    ready_prefix: str | None = None
    echo: bool = False
    env: Mapping[str, str] = field(default_factory=dict)
    log_error: str = ""  # why its log could not be written (a full disk), if it could not

    def tail(self, n: int = 5) -> str:
        """Its last ``n`` lines of output (all of them, once it has ended: the pump is given
        a moment to read what it printed last, which says why it ended)."""
        if self.pump is not None and self.popen.poll() is not None:
            self.pump.join(DRAIN_S)
        return " | ".join(self.lines[-n:])

    def why(self) -> str:
        """How it ended, with its last lines; a full disk is named as such."""
        code = self.popen.returncode
        tail = self.tail()
        full = "No space left on device" in tail or f"Errno {errno.ENOSPC}" in tail
        cause = " (its disk is full)" if full else ""
        return f"{self.name} exited with {code}{cause}: {tail}"

    def signal_group(self, sig: int) -> None:
        """``sig`` to the child's process group, if it still exists."""
        try:
            os.killpg(self.popen.pid, sig)
        except (ProcessLookupError, PermissionError):
            pass


class Children:
    """``spawn`` by name, ``wait_ready``, ``signal``, ``stop``; ``by_name`` holds each name's
    latest process (a restarted agent replaces its predecessor)."""

    def __init__(self, run_dir: Path, out: Callable[[str], None],
                 startup_timeout_s: float) -> None:
        self.run_dir, self.out, self.startup_timeout_s = run_dir, out, startup_timeout_s
        self.by_name: dict[str, Child] = {}
        self._pids: dict[str, list[int]] = {}

    def spawn(self, name: str, argv: Sequence[str], ready_prefix: str | None = None,
              echo: bool = False, env: Mapping[str, str] | None = None) -> Child:
        """Start ``python argv`` as ``name``; its ``ready`` is set when it prints a line
        starting with ``ready_prefix``; ``echo`` also passes its output to the user; ``env``
        is added to its environment (fault injection: e.g. a wall clock that steps)."""
        log_error = ""
        try:
            log = open(self.run_dir / f"{name}.log", "ab")
        except OSError as exc:  # a full disk: the child runs all the same
            log, log_error = None, str(exc)
        popen = subprocess.Popen(
            [sys.executable, *argv], stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True,
            env={**os.environ, **(env or {}), "PYTHONUNBUFFERED": "1",
                 "COTSFLEET_PARENT_PID": str(os.getpid())})
        child = Child(name, popen, argv=tuple(argv), ready_prefix=ready_prefix, echo=echo,
                      env=dict(env or {}), log_error=log_error)

        def pump() -> None:  # copy output to the log, watch for the ready line
            nonlocal log
            assert popen.stdout is not None
            for raw in popen.stdout:
                if log is not None:
                    try:
                        log.write(raw)
                        log.flush()
                    except OSError as exc:  # keep reading the pipe: the child must not block
                        child.log_error = str(exc)
                        _close_quietly(log)
                        log = None
                line = raw.decode(errors="replace").rstrip()
                child.lines.append(line)
                del child.lines[:-LOG_LINES]
                if echo:  # e.g. the ground station's viewer address: the user needs it
                    self.out(line)
                if ready_prefix and line.startswith(ready_prefix):
                    child.ready.set()
            if log is not None:
                _close_quietly(log)

        child.pump = threading.Thread(target=pump, name=f"pump-{name}", daemon=True)
        child.pump.start()
        self.by_name[name] = child
        self._pids.setdefault(name, []).append(popen.pid)
        try:
            (self.run_dir / "pids.json").write_text(json.dumps(self._pids), encoding="utf-8")
        except OSError:  # a full disk: the pids are still in `by_name` for our own cleanup
            pass
        return child

    def restart(self, child: Child, argv: Sequence[str] | None = None) -> Child:
        """``child`` started again as it was (or with ``argv``), under the same name."""
        return self.spawn(child.name, child.argv if argv is None else argv, child.ready_prefix,
                          child.echo, child.env)

    def wait_ready(self, child: Child) -> None:
        """Until ``child`` printed its ready line; `ChildExited` or `TimeoutError` if not."""
        deadline = time.monotonic() + self.startup_timeout_s
        while not child.ready.wait(0.1):
            if child.popen.poll() is not None:
                tail = child.tail()  # drains its output: the ready line may be in it
                if child.ready.is_set():
                    return
                raise ChildExited(f"{child.name} exited with {child.popen.returncode}: "
                                  f"{tail}")
            if time.monotonic() > deadline:
                raise TimeoutError(f"{child.name} not ready within "
                                   f"{self.startup_timeout_s:g} s")

    def signal(self, child: Child, sig: int) -> None:
        """``sig`` to ``child``'s group; its end is then ours, not news."""
        child.expected_exit = True
        child.signal_group(sig)

    def stop(self, names: Sequence[str], grace_s: float = 5.0) -> None:
        """SIGTERM the running children named, SIGKILL any still running after ``grace_s``."""
        children = [self.by_name[n] for n in names if n in self.by_name
                    and self.by_name[n].popen.poll() is None]
        for c in children:
            self.signal(c, signal.SIGTERM)
        deadline = time.monotonic() + grace_s
        for c in children:
            try:
                c.popen.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                self.signal(c, signal.SIGKILL)
                c.popen.wait(5.0)

    def ended_untold(self) -> Child | None:
        """A child that ended without being told to (each reported once)."""
        for c in self.by_name.values():
            if c.popen.poll() is not None and not c.expected_exit:
                c.expected_exit = True
                return c
        return None


def _close_quietly(log: IO[bytes]) -> None:
    """Close a log file whose last flush may fail (a full disk)."""
    try:
        log.close()
    except OSError:
        pass
