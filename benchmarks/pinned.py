"""Run benchmark workers as separate processes, each pinned to one core with ``taskset``.

A solver run in its own fresh interpreter on its own core measures that solver alone: no
shared caches, no other solver's threads, no leftover memory. Workers print one JSON line.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from typing import Any, Sequence


def run_pinned(commands: Sequence[Sequence[str]], parallel: int = 1) -> list[Any]:
    """Run ``python -m <command...>`` for each command, ``parallel`` at once on distinct cores;
    the parsed last stdout line of each, in order."""
    cores = sorted(os.sched_getaffinity(0))[: max(1, parallel)]
    free, running = list(cores), {}
    results: list[Any] = [None] * len(commands)
    queue = list(enumerate(commands))
    while queue or running:
        while queue and free:
            index, command = queue.pop(0)
            core = free.pop(0)
            argv = ["taskset", "-c", str(core), sys.executable, "-m", *command]
            proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            running[proc] = (index, core)
        for proc in list(running):
            if proc.poll() is None:
                continue
            index, core = running.pop(proc)
            free.append(core)
            out, err = proc.communicate()
            if proc.returncode != 0 or not out.strip():
                raise RuntimeError(f"worker {' '.join(commands[index])} failed:\n{err[-2000:]}")
            results[index] = json.loads(out.strip().splitlines()[-1])
        time.sleep(0.02)
    return results
