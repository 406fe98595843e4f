"""What a live helm adapter holds for the agent between two `poll`s, bounded.

Navigation fixes come many a second and only the recent ones matter; the other reports
(arrived, looked, injected, sighted, refused) are few and each matters. So fixes and the
rest are kept in two bounded queues: when the agent does not poll for long, the oldest fixes
go first (counted), and an event is dropped (counted) only after ``max_events`` are waiting.
`NavStats` measures the navigation the agent was given: fixes, their lag (from the helm's
time stamp to the adapter's receipt, in mission seconds) and the age of the last one.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from typing import TypeVar

from fleet_bus.vehicle_port import NavFix, VehicleReport

R = TypeVar("R", bound=VehicleReport)


class ReportBuffer:
    """Thread-safe: the helm's thread `add`s, the agent's thread `take`s."""

    def __init__(self, max_fixes: int = 256, max_events: int = 1024) -> None:
        if max_fixes < 1 or max_events < 1:
            raise ValueError("report buffer bounds must be >= 1")
        self._fixes: deque[NavFix] = deque()
        self._events: deque[VehicleReport] = deque()
        self._max_fixes, self._max_events = max_fixes, max_events
        self._lock = threading.Lock()
        self.dropped_fixes = 0
        self.dropped_events = 0

    def add(self, report: VehicleReport) -> None:
        with self._lock:
            if isinstance(report, NavFix):
                if len(self._fixes) >= self._max_fixes:
                    self._fixes.popleft()
                    self.dropped_fixes += 1
                self._fixes.append(report)
            else:
                if len(self._events) >= self._max_events:
                    self._events.popleft()
                    self.dropped_events += 1
                self._events.append(report)

    def take(self, until_s: float) -> list[VehicleReport]:
        """Every report dated up to ``until_s``, in time order (a later one stays)."""
        with self._lock:
            out: list[VehicleReport] = [*_take(self._fixes, until_s),
                                        *_take(self._events, until_s)]
        out.sort(key=lambda r: r.t_s)  # stable: a fix and an event at one time keep order
        return out


class NavStats:
    """Fixes received, the lag of each from the helm's stamp to its receipt, the last one."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.fixes = 0
        self.lag_max_s = 0.0
        self._lag_sum_s = 0.0
        self.last_fix: NavFix | None = None
        self.first_fix_s: float | None = None

    def record(self, fix: NavFix, lag_s: float) -> None:
        with self._lock:
            self.fixes += 1
            lag = max(0.0, lag_s)
            self.lag_max_s = max(self.lag_max_s, lag)
            self._lag_sum_s += lag
            self.last_fix = fix
            if self.first_fix_s is None:
                self.first_fix_s = fix.t_s

    @property
    def lag_mean_s(self) -> float:
        with self._lock:
            return self._lag_sum_s / self.fixes if self.fixes else 0.0

    def age_s(self, now_s: float) -> float:
        """Mission seconds since the last fix was taken (inf: none yet)."""
        with self._lock:
            return math.inf if self.last_fix is None else max(0.0, now_s - self.last_fix.t_s)

    def rate_hz(self, now_s: float) -> float:
        """Fixes per mission second since the first one."""
        with self._lock:
            if self.first_fix_s is None or now_s <= self.first_fix_s:
                return 0.0
            return self.fixes / (now_s - self.first_fix_s)


def _take(queue: deque[R], until_s: float) -> list[R]:
    """The reports of ``queue`` dated up to ``until_s``, taken out (the later ones stay)."""
    out: list[R] = []
    keep: deque[R] = deque()
    for r in queue:
        (out if r.t_s <= until_s else keep).append(r)
    queue.clear()
    queue.extend(keep)
    return out
