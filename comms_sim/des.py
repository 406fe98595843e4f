"""In-process deterministic transport: the channel model on a discrete-event loop.

`EventLoop` runs callbacks at simulation times on a `ManualClock` (Trio's MockClock idea):
nothing sleeps, time jumps from one event to the next, and simultaneous events run in the
order they were scheduled, so a seeded run is exactly reproducible. `InProcessNetwork` puts a
`Channel` on that loop: agents `send` frames and get deliveries through their ``on_frame``
callback at the end of reception, exactly as the Zenoh relay would deliver them.
"""

from __future__ import annotations

import heapq
import itertools
from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

from comms_sim.channel import Channel
from fleet_bus.clock import ManualClock
from comms_sim.link_event import LinkEvent

FrameHandler = Callable[[bytes, float], None]  # (frame, t_s of delivery)
LinkListener = Callable[[LinkEvent], None]
Positions = Callable[[float], Mapping[str, Sequence[float]]]  # t_s -> {node: (x, y, z)}


@dataclass(order=True)
class Handle:
    """A scheduled call; `cancel` keeps it from running."""

    t_s: float
    seq: int
    fn: Callable[[], None] = field(compare=False)
    cancelled: bool = field(default=False, compare=False)

    def cancel(self) -> None:
        self.cancelled = True


class EventLoop:
    """Calls functions at simulation times, in (time, scheduling order)."""

    def __init__(self, clock: ManualClock | None = None) -> None:
        self.clock = clock if clock is not None else ManualClock()
        self._heap: list[Handle] = []
        self._seq = itertools.count()

    def now(self) -> float:
        return self.clock.now()

    def call_at(self, t_s: float, fn: Callable[[], None]) -> Handle:
        """Run ``fn`` at ``t_s`` (at once, in order, if ``t_s`` is already past)."""
        handle = Handle(max(t_s, self.now()), next(self._seq), fn)
        heapq.heappush(self._heap, handle)
        return handle

    def call_later(self, delay_s: float, fn: Callable[[], None]) -> Handle:
        return self.call_at(self.now() + delay_s, fn)

    def next_s(self) -> float | None:
        while self._heap and self._heap[0].cancelled:
            heapq.heappop(self._heap)
        return self._heap[0].t_s if self._heap else None

    def run_until(self, t_s: float) -> None:
        """Run every call due by ``t_s`` (including those they schedule), then set the clock
        to ``t_s``."""
        while True:
            due = self.next_s()
            if due is None or due > t_s:
                break
            handle = heapq.heappop(self._heap)
            self.clock.advance_to(handle.t_s)
            handle.fn()
        if t_s > self.now():
            self.clock.advance_to(t_s)

    def run(self, max_t_s: float = float("inf")) -> None:
        """Run until nothing is scheduled (or ``max_t_s``)."""
        while (due := self.next_s()) is not None and due <= max_t_s:
            self.run_until(due)


class InProcessNetwork:
    """Agents attached here talk through ``channel``, with time kept by ``loop``.

    Positions come from `set_position` calls or, if given, from ``positions(t_s)``, asked
    each time the channel is about to act (so transmissions use where vehicles are then).
    """

    def __init__(self, channel: Channel, loop: EventLoop,
                 positions: Positions | None = None) -> None:
        self.channel = channel
        self.loop = loop
        self._positions = positions
        self._handlers: dict[str, FrameHandler] = {}
        self._listeners: list[LinkListener] = []
        self._wake: Handle | None = None

    def attach(self, node_id: str, on_frame: FrameHandler) -> None:
        """Deliver frames for ``node_id`` to ``on_frame(frame, t_s)``."""
        self._handlers[node_id] = on_frame
        self.channel.add_node(node_id)

    def detach(self, node_id: str) -> None:
        """Stop delivering to ``node_id`` (it stays in the water as a silent node)."""
        self._handlers.pop(node_id, None)

    def add_listener(self, listener: LinkListener) -> None:
        """Observe every `LinkEvent` (deliveries, drops, refusals)."""
        self._listeners.append(listener)

    def set_position(self, node_id: str, pos_xyz: Sequence[float]) -> None:
        self.channel.set_position(node_id, pos_xyz, self.loop.now())

    def send(self, src: str, frame: bytes, kind: str = "data",
             sent_s: float | None = None) -> list[LinkEvent]:
        """Transmit ``frame`` from ``src`` now, or at the earlier ``sent_s`` its sender dated
        it (`Channel.submit` ``keep_time``). Returns an immediate refusal, if any."""
        self._refresh_positions()
        now = self.loop.now()
        refused = self.channel.submit(src, frame, now if sent_s is None else min(sent_s, now),
                                      kind, keep_time=True)
        self._publish(refused)
        self._reschedule()
        return refused

    def _refresh_positions(self) -> None:
        if self._positions is not None:
            now = self.loop.now()
            for node, pos in self._positions(now).items():
                self.channel.set_position(node, pos, now)

    def _reschedule(self) -> None:
        due = self.channel.next_due_s()
        if due is None:
            return
        if self._wake is not None and not self._wake.cancelled:
            if self._wake.t_s <= due:
                return  # the pending wake-up comes first and will reschedule
            self._wake.cancel()
        self._wake = self.loop.call_at(due, self._on_wake)

    def _on_wake(self) -> None:
        self._wake = None
        self._refresh_positions()
        self._publish(self.channel.advance(self.loop.now()))
        self._reschedule()

    def _publish(self, events: list[LinkEvent]) -> None:
        for event in events:
            for listener in self._listeners:
                listener(event)
            if event.delivered:
                handler = self._handlers.get(event.dst)
                if handler is not None:
                    handler(event.frame, event.t_s)
