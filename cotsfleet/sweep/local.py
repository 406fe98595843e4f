"""``--jobs K``: K worker processes of our own on this machine, one seed at a time each.

Why not `concurrent.futures.ProcessPoolExecutor`: when one of its workers dies (the OOM
killer, a crash in C) it fails every pending run with `BrokenProcessPool` and cannot say which
run killed it, and before Python 3.14 it has no public way to stop workers that are running.
Here each worker is handed one seed over its own pipe, so a dead worker costs exactly its seed
(reported with the signal that ended it) and a fresh worker takes its place; and the workers
are ours to stop, whatever ends the sweep.

How the workers never outlive the sweep:
- a normal end: each is told to stop, then joined;
- an exception or Ctrl-C in the sweep: each is terminated (SIGTERM), then killed if it lingers;
  workers ignore SIGINT, so a Ctrl-C at the terminal (sent to the whole process group) reaches
  the sweep alone and stops them in order rather than in a shower of tracebacks;
- the sweep killed outright (SIGKILL, or SIGTERM with no handler): on Linux the kernel sends
  each worker SIGKILL (``PR_SET_PDEATHSIG``); elsewhere a worker ends when its pipe closes.
"""

from __future__ import annotations

import ctypes
import multiprocessing as mp
import multiprocessing.connection as mpc
import os
import signal
import sys
from collections import deque
from dataclasses import dataclass, field
from typing import Any, Iterator, Sequence

from cotsfleet.mission.report_model import FailedRun, RunResult
from cotsfleet.sweep.spec import SweepSpec

STOP_GRACE_S = 5.0  # a told-to-stop worker finishes within this, else it is terminated
_PR_SET_PDEATHSIG = 1


def _context() -> Any:
    # fork: a worker starts in milliseconds with everything the sweep already imported (the
    # sim's modules), which matters for sweeps of short runs; Linux only, where fork is
    # sound for us (no thread of ours is running when the workers start). Elsewhere spawn.
    return mp.get_context("fork" if sys.platform.startswith("linux") else "spawn")


def _die_with(parent: int) -> None:
    """End this process if ``parent`` ends, even by SIGKILL (Linux; elsewhere the pipe's
    EOF does it)."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):
        return
    if os.getppid() != parent:  # the parent died before the line above
        os._exit(1)


def _worker_main(conn: mpc.Connection, parent: int) -> None:
    """A worker's life: ("spec", spec) once per sweep, then ("seed", s) -> the result of s,
    until None or the pipe's end."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the sweep's: it stops us
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the sweep's handler, if forked
    _die_with(parent)
    from cotsfleet.sweep.task import run_seed

    spec: SweepSpec | None = None
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            return
        if message is None:
            return
        kind, value = message
        if kind == "spec":
            spec = value
        elif spec is None:  # the pool hands the spec before any seed
            raise RuntimeError("sweep worker: a seed came before the sweep's spec")
        else:
            conn.send(run_seed(spec, value))


def describe_exit(code: int | None) -> str:
    if code is None:
        return "still running"
    if code < 0:
        name = signal.Signals(-code).name if -code in signal.Signals._value2member_map_ else ""
        hint = " (the kernel's OOM killer sends this when memory runs out)" if code == -9 else ""
        return f"killed by signal {-code} {name}{hint}".replace("  ", " ")
    return f"exit code {code}"


@dataclass(eq=False)
class _Worker:
    process: Any
    conn: mpc.Connection
    seed: int | None = None  # the seed it is running

    def run(self, seed: int) -> None:
        self.conn.send(("seed", seed))
        self.seed = seed


@dataclass
class LocalPool:
    """``with LocalPool(4) as pool: for r in pool.results(spec, seeds): ...`` (any order).

    The workers start on entering (before the caller starts any thread, e.g. a progress
    bar's: forking a process with threads is best avoided) and end on leaving."""

    jobs: int
    pids: list[int] = field(default_factory=list)  # every worker ever started (for tests)
    _workers: list[_Worker] = field(default_factory=list)

    def __post_init__(self) -> None:
        if self.jobs < 1:
            raise ValueError(f"jobs must be >= 1, got {self.jobs}")

    @property
    def workers(self) -> int:
        return self.jobs

    @property
    def where(self) -> str:
        return f"{self.jobs} local worker process{'es' if self.jobs > 1 else ''}"

    def results(self, spec: SweepSpec, seeds: Sequence[int]) -> Iterator[RunResult]:
        todo = deque(seeds)
        for i, w in enumerate(self._workers):
            self._workers[i] = self._hand(w, spec)
        while True:
            for i, w in enumerate(self._workers):
                if w.seed is None and todo:
                    try:
                        w.run(todo[0])
                    except OSError:  # it died idle: a fresh worker takes the seed
                        self._bury(w)
                        w = self._workers[i] = self._hand(self._start(), spec)
                        w.run(todo[0])
                    todo.popleft()
            busy = [w for w in self._workers if w.seed is not None]
            if not busy:
                return
            ready = set(mpc.wait([w.conn for w in busy] + [w.process.sentinel for w in busy]))
            for w in busy:
                if w.conn not in ready and w.process.sentinel not in ready:
                    continue
                seed, result = w.seed, self._receive(w)
                w.seed = None
                if result is None:  # the worker died with this seed: the seed's row says so
                    assert seed is not None
                    result = FailedRun(seed=seed, error="the worker process running this "
                                       f"seed died: {describe_exit(self._bury(w))}")
                    i = self._workers.index(w)
                    if todo:
                        self._workers[i] = self._hand(self._start(), spec)
                    else:
                        del self._workers[i]
                yield result

    @staticmethod
    def _receive(w: _Worker) -> RunResult | None:
        try:
            if w.conn.poll():
                return w.conn.recv()
        except (EOFError, OSError):
            pass
        return None

    @staticmethod
    def _bury(w: _Worker) -> int | None:
        """Reap a dead (or dying) worker; its exit code."""
        w.process.join(STOP_GRACE_S)
        if w.process.is_alive():
            w.process.kill()
            w.process.join()
        w.conn.close()
        return w.process.exitcode

    def _hand(self, w: _Worker, spec: SweepSpec) -> _Worker:
        """Give ``w`` the sweep's spec (once: seeds follow alone); a worker found dead is
        replaced."""
        try:
            w.conn.send(("spec", spec))
            return w
        except OSError:
            self._bury(w)
            return self._hand(self._start(), spec)

    def _start(self) -> _Worker:
        ctx = _context()
        ours, theirs = ctx.Pipe()
        process = ctx.Process(target=_worker_main, args=(theirs, os.getpid()),
                              name=f"cotsfleet-sweep-{len(self.pids)}", daemon=True)
        process.start()
        theirs.close()
        self.pids.append(process.pid)
        return _Worker(process, ours)

    def close(self, graceful: bool = True) -> None:
        """Stop every worker and wait for it (told to stop if ``graceful``, else terminated)."""
        workers, self._workers = self._workers, []
        for w in workers:
            if graceful and w.seed is None:
                try:
                    w.conn.send(None)
                except OSError:
                    pass
            else:
                w.process.terminate()
        for w in workers:
            w.process.join(STOP_GRACE_S)
            if w.process.is_alive():
                w.process.kill()
                w.process.join()
            w.conn.close()

    def __enter__(self) -> "LocalPool":
        try:
            for _ in range(self.jobs):
                self._workers.append(self._start())
        except BaseException:
            self.close(graceful=False)
            raise
        return self

    def __exit__(self, exc_type: object, *exc: object) -> None:
        self.close(graceful=exc_type is None)
