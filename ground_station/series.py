"""Which time-series samples are worth a row (pure).

Telemetry repeats itself: every status carries the battery, which falls at one second per
second; every frame bumps the message counter. Drawing each sample costs the viewer a row
and tells the operator nothing a line between fewer points does not. A sample is drawn when
its value jumps (by more than the series' tolerance), when the line would otherwise stop short
of the present (a heartbeat), and, once the mission is over, the newest of each series, so a
recording always ends on the values the mission report states.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from ground_station.drawing import Scalar


@dataclass(frozen=True)
class Policy:
    """How a series is thinned.

    ``tolerance``: a change larger than this is drawn at once; with ``corners`` the sample
    before the jump is drawn too, so a linearly drawn line steps where it stepped instead of
    sloping from the last drawn point. ``heartbeat_s``: a value is drawn at least this often
    while samples keep coming. ``min_interval_s``: never more often than this (counters that
    change with every frame); a held-back change is drawn when its interval is over."""

    tolerance: float = 0.0
    heartbeat_s: float = 30.0
    min_interval_s: float = 0.0
    corners: bool = False


@dataclass
class _Series:
    t_s: float
    value: float
    pending: tuple[float, float] | None = None  # newest sample not drawn yet


@dataclass
class SeriesThinner:
    """Decides, sample by sample, which ones to draw; ``policy_of(path)`` names the policy."""

    policy_of: Callable[[str], Policy]
    _series: dict[str, _Series] = field(default_factory=dict)
    _held: set[str] = field(default_factory=set)  # paths with a change held by min_interval

    def offer(self, path: str, t_s: float, value: float) -> list[Scalar]:
        s = self._series.get(path)
        if s is None:
            self._series[path] = _Series(t_s, value)
            return [Scalar(t_s, path, value)]
        if t_s < s.t_s or (s.pending is not None and t_s < s.pending[0]):
            return []  # older than what is drawn or waiting: a late sample changes nothing
        policy = self.policy_of(path)
        jumped = abs(value - s.value) > policy.tolerance
        if not (jumped or t_s - s.t_s >= policy.heartbeat_s):
            s.pending = (t_s, value)
            return []
        if t_s - s.t_s < policy.min_interval_s:
            s.pending = (t_s, value)
            self._held.add(path)
            return []
        out = []
        if jumped and policy.corners and s.pending is not None and s.pending[0] < t_s:
            out.append(Scalar(s.pending[0], path, s.pending[1]))
        out.append(Scalar(t_s, path, value))
        self._drawn(path, s, t_s, value)
        return out

    def due(self, now_s: float) -> list[Scalar]:
        """Changes held back by a minimum interval that has now passed."""
        out = []
        for path in sorted(self._held):
            s = self._series[path]
            if s.pending is None:
                self._held.discard(path)
            elif now_s - s.t_s >= self.policy_of(path).min_interval_s:
                t, value = s.pending
                out.append(Scalar(t, path, value))
                self._drawn(path, s, t, value)
        return out

    def flush(self) -> list[Scalar]:
        """The newest sample of every series not drawn yet (the mission is over)."""
        out = []
        for path, s in sorted(self._series.items()):
            if s.pending is not None:
                t, value = s.pending
                out.append(Scalar(t, path, value))
                self._drawn(path, s, t, value)
        return out

    def last(self, path: str) -> float | None:
        """The newest value offered for ``path`` (drawn or not)."""
        s = self._series.get(path)
        if s is None:
            return None
        return s.pending[1] if s.pending is not None else s.value

    def _drawn(self, path: str, s: _Series, t_s: float, value: float) -> None:
        s.t_s, s.value, s.pending = t_s, value, None
        self._held.discard(path)
