"""Zenoh side: the mission record (with retries) and the four telemetry subscriptions.

Zenoh calls the callbacks from its own threads; they only enqueue ``(key, payload)`` so all
decoding, folding and logging happens on one thread, in arrival order, without locks.
"""

from __future__ import annotations

import queue
import threading
import time
from contextlib import ExitStack, contextmanager
from typing import Iterator

import zenoh

from comms_sim import bus

TOPICS = (bus.TRUTH_ALL, bus.STATUS_ALL, bus.EVENT_ALL, bus.LINK_ALL)


class Inbox:
    """A bounded FIFO of samples: a stalled logger drops (and counts) the newest samples
    instead of growing without bound."""

    def __init__(self, maxsize: int = 200_000) -> None:
        self._q: queue.Queue[tuple[str, bytes]] = queue.Queue(maxsize)
        self.overflow = 0

    def put(self, key: str, payload: bytes) -> None:
        try:
            self._q.put_nowait((key, payload))
        except queue.Full:
            self.overflow += 1

    def on_sample(self, sample: zenoh.Sample) -> None:
        self.put(str(sample.key_expr), sample.payload.to_bytes())

    def get(self, timeout_s: float) -> tuple[str, bytes] | None:
        try:
            return self._q.get(timeout=timeout_s)
        except queue.Empty:
            return None


def fetch_mission(session: zenoh.Session, stop: threading.Event, timeout_s: float = 60.0,
                  query_timeout_s: float = 2.0, retry_s: float = 0.5) -> bus.Mission | None:
    """Ask ``fleet/mission`` until a well-formed answer comes (the launcher may not be up yet);
    None if ``stop`` is set or ``timeout_s`` passes first."""
    deadline = time.monotonic() + timeout_s
    while not stop.is_set() and time.monotonic() < deadline:
        for reply in session.get(bus.MISSION, timeout=query_timeout_s):
            if reply.ok is None:
                continue
            try:
                return bus.Mission.decode(reply.ok.payload.to_bytes())
            except ValueError:
                continue  # a garbled answer: ask again
        stop.wait(retry_s)
    return None


@contextmanager
def subscribed(session: zenoh.Session, inbox: Inbox) -> Iterator[list[zenoh.Subscriber]]:
    """All telemetry topics feeding ``inbox`` for the duration of the block."""
    with ExitStack() as stack:
        yield [stack.enter_context(session.declare_subscriber(topic, inbox.on_sample))
               for topic in TOPICS]
