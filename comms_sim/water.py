"""The emulated water as a running thing: the channel behind one lock, settled on a clock.

Every face of the water (the Zenoh relay, `comms_sim.relay`; the emulated Micro-Modems,
`comms_sim.micromodem`) stands on one `Water`: inputs come from the face's threads (bus
callbacks, modem sockets) through `act`, one scheduler thread (`run`) settles receptions and
fires timers at their mission times, and every `LinkEvent` goes to the listeners outside the
lock, so that a listener may publish, write to a socket or call `act` again.

Timers (`call_at`) are the faces' own deadlines on the mission clock (a modem's end of
transmission, a data request that timed out); they run on the scheduler thread, outside the
lock, in time order.
"""

from __future__ import annotations

import heapq
import itertools
import threading
from typing import Callable, Protocol, TypeVar

from comms_sim.channel import Channel
from comms_sim.link_event import LinkEvent

T = TypeVar("T")
Listener = Callable[[list[LinkEvent]], None]
MAX_TIMERS = 1 << 16  # a face schedules a few per modem; more is a bug or a flood


class SimClock(Protocol):
    def now(self) -> float: ...
    def wall_delay(self, sim_dt_s: float) -> float: ...


class Timer:
    """A scheduled call; `cancel` keeps it from running."""

    __slots__ = ("t_s", "fn", "cancelled")

    def __init__(self, t_s: float, fn: Callable[[], None]) -> None:
        self.t_s = t_s
        self.fn = fn
        self.cancelled = False

    def cancel(self) -> None:
        self.cancelled = True


class Water:
    """See the module docstring. ``lock`` guards the channel and may guard a face's own
    bookkeeping too (held briefly, never while a listener runs)."""

    def __init__(self, channel: Channel, clock: SimClock) -> None:
        self.channel = channel
        self.clock = clock
        self.lock = threading.Lock()
        self._wakeup = threading.Condition(self.lock)
        self._dirty = False
        self._listeners: list[Listener] = []
        self._timers: list[tuple[float, int, Timer]] = []
        self._seq = itertools.count()

    def add_listener(self, listener: Listener) -> None:
        """Call ``listener(events)`` with every batch of settled events (outside the lock)."""
        self._listeners.append(listener)

    # -- inputs (any thread) ---------------------------------------------------------------

    def act(self, fn: Callable[[Channel, float], list[LinkEvent] | None]) -> None:
        """Run ``fn(channel, now)`` under the lock; the events it returns (refusals) go to the
        listeners, and the scheduler looks at the channel again."""
        with self.lock:
            events = fn(self.channel, self.clock.now())
            self._dirty = True
            self._wakeup.notify()
        if events:
            self.emit(events)

    def call_at(self, t_s: float, fn: Callable[[], None]) -> Timer:
        """Run ``fn()`` on the scheduler thread once the clock reaches ``t_s`` (at once if it
        has). Raises RuntimeError past `MAX_TIMERS` pending."""
        timer = Timer(t_s, fn)
        with self.lock:
            if len(self._timers) >= MAX_TIMERS:
                self._timers = [e for e in self._timers if not e[2].cancelled]
                heapq.heapify(self._timers)
                if len(self._timers) >= MAX_TIMERS:
                    raise RuntimeError(f"more than {MAX_TIMERS} timers pending")
            heapq.heappush(self._timers, (t_s, next(self._seq), timer))
            self._dirty = True
            self._wakeup.notify()
        return timer

    def wake(self) -> None:
        """Make `run` look at the channel (and at its stop event) now."""
        with self.lock:
            self._dirty = True
            self._wakeup.notify()

    # -- scheduler (one thread) ------------------------------------------------------------

    def step(self) -> float | None:
        """Settle everything due now, fire due timers; return the next due mission time."""
        with self.lock:
            now = self.clock.now()
            events = self.channel.advance(now)
            due_timers = []
            while self._timers and self._timers[0][0] <= now:
                timer = heapq.heappop(self._timers)[2]
                if not timer.cancelled:
                    due_timers.append(timer)
        if events:
            self.emit(events)
        for timer in due_timers:
            timer.fn()
        with self.lock:
            due = self.channel.next_due_s()
            while self._timers and self._timers[0][2].cancelled:
                heapq.heappop(self._timers)
            if self._timers and (due is None or self._timers[0][0] < due):
                due = self._timers[0][0]
        return due

    def run(self, stop: threading.Event, max_wait_s: float = 0.5) -> None:
        """Step at each due time until ``stop`` is set (bounded waits keep stop prompt)."""
        while not stop.is_set():
            due = self.step()
            with self.lock:
                if self._dirty:
                    self._dirty = False
                    continue
                wait = max_wait_s if due is None else min(
                    max_wait_s, self.clock.wall_delay(due - self.clock.now()))
                if wait > 0:
                    self._wakeup.wait(wait)
                self._dirty = False

    def emit(self, events: list[LinkEvent]) -> None:
        for listener in self._listeners:
            listener(events)
