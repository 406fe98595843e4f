"""Preloaded into each worker of the local Dask cluster a sweep starts (``dask_setup``).

Ctrl-C at a terminal reaches every process of the foreground group: the sweep's own and its
local cluster's workers. The sweep handles it (cancels, closes the cluster, writes what
finished); a worker hit by it too would die first, printing a traceback per worker.
"""

from __future__ import annotations

import signal
import threading
from typing import Any


def dask_setup(worker: Any) -> None:
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
