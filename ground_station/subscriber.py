"""Zenoh side: the four telemetry subscriptions.

Zenoh calls the callbacks from its own threads; they only open the signed envelope (with the
run's credentials) and enqueue ``(key, payload)`` so all decoding, folding and logging
happens on one thread, in arrival order, without locks. A forgery never takes a queue slot.
"""

from __future__ import annotations

import queue
from collections import Counter
from contextlib import ExitStack, contextmanager
from typing import Iterator

import zenoh

from fleet_bus import topics
from fleet_bus.auth import BusAuth

TOPICS = tuple(t.key for t in (topics.TRUTH.all, topics.STATUS.all, topics.EVENT.all,
                                topics.LINK.all))


class Inbox:
    """A bounded FIFO of samples: a stalled logger drops (and counts) the newest samples
    instead of growing without bound."""

    def __init__(self, maxsize: int = 200_000, auth: BusAuth | None = None) -> None:
        self._q: queue.Queue[tuple[str, bytes]] = queue.Queue(maxsize)
        self.overflow = 0
        self.auth = auth

    def put(self, key: str, payload: bytes) -> None:
        try:
            self._q.put_nowait((key, payload))
        except queue.Full:
            self.overflow += 1

    def on_sample(self, sample: zenoh.Sample) -> None:
        self.offer(str(sample.key_expr), sample.payload.to_bytes())

    def offer(self, key: str, payload: bytes) -> None:
        """Queue ``payload`` if its key's rightful sender signed it (always on an open bus)."""
        if self.auth is not None:
            opened = self.auth.open_payload(key, payload)
            if opened is None:
                return
            payload = opened
        self.put(key, payload)

    def take_refused(self) -> Counter[str]:
        """Envelopes refused since the last call, by reason."""
        return self.auth.verifier.take_refused() if self.auth is not None else Counter()

    def get(self, timeout_s: float) -> tuple[str, bytes] | None:
        try:
            return self._q.get(timeout=timeout_s)
        except queue.Empty:
            return None


@contextmanager
def subscribed(session: zenoh.Session, inbox: Inbox) -> Iterator[list[zenoh.Subscriber]]:
    """All telemetry topics feeding ``inbox`` for the duration of the block."""
    with ExitStack() as stack:
        yield [stack.enter_context(session.declare_subscriber(topic, inbox.on_sample))
               for topic in TOPICS]
