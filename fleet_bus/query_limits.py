"""Rationing the queryables (the operator's mission and clock, the relay's link stats): each
asker gets a token bucket, and what it asks beyond it is dropped unanswered and counted.

An asker is known by its signed query (`fleet_bus.auth.seal_query`: the signer of the ring,
the same identity as its bus certificate or login); queries without a signature (a process
that holds no signing key, such as the ground station, or an open bus) share one bucket,
``unsigned``. The claimed signer's bucket is looked at before its signature is checked, so a
flood over the allowance costs a dictionary look-up each, and a forged signature never draws
on the genuine signer's allowance (only a checked query takes a token). Zenoh 1.x itself
cannot do this: its access control allows or denies, and its downsampling interceptor
rations pushes (puts), not queries.

The token bucket: RFC 2697's committed rate and burst (``rate_per_s``, ``burst``), without
the colours. Pure logic with an injected monotonic clock; `gate_queryable` wires it to Zenoh.
"""

from __future__ import annotations

import threading
import time
from collections import Counter
from typing import Any, Callable

from fleet_bus.auth import BusAuth, Refused, Verifier, open_query, signer_of

UNSIGNED = "unsigned"
RATE_PER_S = 5.0  # an asker's sustained queries per second (the clock exchange needs 1)
BURST = 20.0  # and how many at once (a process starting: mission, clock, a few exchanges)
UNSIGNED_RATE_PER_S = 10.0  # all unsigned askers together
UNSIGNED_BURST = 40.0
NONCE_CHARS = 32


class TokenBucket:
    """``burst`` tokens, refilled at ``rate_per_s``; a query takes one."""

    def __init__(self, rate_per_s: float, burst: float, now: float) -> None:
        self.rate_per_s, self.burst = rate_per_s, burst
        self._tokens, self._at = burst, now

    def _refill(self, now: float) -> None:
        self._tokens = min(self.burst, self._tokens + max(0.0, now - self._at) * self.rate_per_s)
        self._at = max(self._at, now)

    def ready(self, now: float) -> bool:
        """A token is there (nothing taken)."""
        self._refill(now)
        return self._tokens >= 1.0

    def take(self, now: float) -> bool:
        self._refill(now)
        if self._tokens < 1.0:
            return False
        self._tokens -= 1.0
        return True


def nonce_of(parameters: str) -> str:
    """The ``n`` parameter of a query's selector (``key?n=...``), at most `NONCE_CHARS`."""
    for part in str(parameters).split(";"):
        name, _, value = part.partition("=")
        if name == "n":
            return value[:NONCE_CHARS]
    return ""


class QueryGate:
    """``admit`` says whom to answer; ``counts`` what was answered, limited and refused."""

    def __init__(self, auth: BusAuth | None, rate_per_s: float = RATE_PER_S,
                 burst: float = BURST, unsigned_rate_per_s: float = UNSIGNED_RATE_PER_S,
                 unsigned_burst: float = UNSIGNED_BURST,
                 mono: Callable[[], float] = time.monotonic) -> None:
        # Queries are checked on replay windows of their own: a second process holding a
        # signer's key (a copied key) can then spoil no one's telemetry by asking.
        self.auth = None if auth is None else BusAuth(Verifier(auth.verifier.ring,
                                                               auth.verifier.run_id))
        self._mono = mono
        self._rates = (rate_per_s, burst, unsigned_rate_per_s, unsigned_burst)
        self._buckets: dict[str, TokenBucket] = {}
        self.answered: Counter[str] = Counter()
        self.limited: Counter[str] = Counter()
        self.refused = 0  # a signature that did not check out, a signer not of the ring
        self._lock = threading.Lock()

    def _bucket(self, who: str, now: float) -> TokenBucket:
        bucket = self._buckets.get(who)
        if bucket is None:  # bounded: the ring's members and `UNSIGNED`
            rate, burst, urate, uburst = self._rates
            bucket = self._buckets[who] = (TokenBucket(urate, uburst, now) if who == UNSIGNED
                                           else TokenBucket(rate, burst, now))
        return bucket

    def admit(self, key: str, parameters: str, attachment: bytes | None) -> str | None:
        """The asker if this query of ``key`` is to be answered, else None (counted)."""
        now = self._mono()
        if self.auth is None or attachment is None:
            who = UNSIGNED
        else:
            claimed = signer_of(attachment)
            with self._lock:
                if claimed is not None and claimed in self.auth.verifier.ring and \
                        not self._bucket(claimed, now).ready(now):
                    self.limited[claimed] += 1  # over its allowance: no signature check paid
                    return None
            try:
                who = open_query(self.auth, key, nonce_of(parameters), attachment)
            except Refused:
                with self._lock:
                    self.refused += 1
                return None
        with self._lock:
            if not self._bucket(who, now).take(now):
                self.limited[who] += 1
                return None
            self.answered[who] += 1
        return who

    def counts(self) -> dict[str, Any]:
        """``answered`` and ``limited`` by asker, ``refused`` in all."""
        with self._lock:
            return {"answered": dict(self.answered), "limited": dict(self.limited),
                    "refused": self.refused}


def gate_queryable(gate: QueryGate, key: str,
                   answer: Callable[[Any], None]) -> Callable[[Any], None]:
    """A queryable's callback that calls ``answer(query)`` only for queries ``gate`` admits
    (the others are dropped: Zenoh closes them unanswered)."""
    def on_query(query: Any) -> None:
        att = query.attachment
        if gate.admit(key, str(query.parameters), None if att is None else att.to_bytes()):
            answer(query)
    return on_query
