"""Preloaded into each worker of the local Dask cluster a sweep starts (``dask_setup``).

Ctrl-C at a terminal reaches every process of the foreground group: the sweep's own and its
local cluster's workers. The sweep handles it (cancels, closes the cluster, writes what
finished); a worker hit by it too would die first, printing a traceback per worker.

The sweep then closes the cluster: workers first, then the scheduler, which lives in the
sweep's own process. A worker's heartbeat already in flight when its connection closes is
logged by `distributed` as an error with a traceback. For a local worker that only ever means
the sweep is ending (if the sweep died, the worker dies with it), so that record is dropped.
"""

from __future__ import annotations

import logging
import signal
import threading
from typing import Any

HEARTBEAT_LOST = "Failed to communicate with scheduler during heartbeat"


def closing_noise(record: logging.LogRecord) -> bool:
    """A `logging` filter: False for the heartbeat lost to the sweep closing its cluster."""
    return not record.getMessage().startswith(HEARTBEAT_LOST)


def dask_setup(worker: Any) -> None:
    logging.getLogger("distributed.worker").addFilter(closing_noise)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
