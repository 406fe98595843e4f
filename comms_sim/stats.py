"""Counters per link: frames sent, delivered, bytes delivered, and drops per reason.

Keys are ``(src, dst)``; sender-side outcomes that concern no receiver (an oversize refusal, a
pose superseded in the queue, a frame refused by a full queue) are counted under
``(src, "*")``. For every real link,
``sent == delivered + sum of its drop reasons``.
"""

from __future__ import annotations

from typing import Any, Mapping

import msgpack

from comms_sim.link_event import BROADCAST, DROP_REASONS, LinkEvent

COUNTERS = ("sent", "delivered", "bytes", *DROP_REASONS, "superseded", "queue_full")
LinkCounts = dict[tuple[str, str], dict[str, int]]


class LinkStats:
    def __init__(self) -> None:
        self._counts: LinkCounts = {}

    def add(self, src: str, dst: str, counter: str, n: int = 1) -> None:
        row = self._counts.get((src, dst))
        if row is None:
            row = self._counts[(src, dst)] = dict.fromkeys(COUNTERS, 0)
        row[counter] += n

    def record(self, event: LinkEvent) -> None:
        if event.dst != BROADCAST:
            self.add(event.src, event.dst, "sent")
        if event.delivered:
            self.add(event.src, event.dst, "delivered")
            self.add(event.src, event.dst, "bytes", event.nbytes)
        else:
            self.add(event.src, event.dst, str(event.reason))

    def snapshot(self) -> LinkCounts:
        return {link: dict(row) for link, row in self._counts.items()}


def totals(counts: LinkCounts) -> dict[str, int]:
    """Sum of every counter over all links."""
    out = dict.fromkeys(COUNTERS, 0)
    for row in counts.values():
        for k, v in row.items():
            out[k] = out.get(k, 0) + v
    return out


def totals_by_sender(counts: LinkCounts) -> dict[str, dict[str, int]]:
    """`totals` per transmitting node: which vehicle's traffic gets through, and why not."""
    senders = sorted({src for src, _ in counts})
    return {s: totals({k: row for k, row in counts.items() if k[0] == s}) for s in senders}


def encode_stats(counts: LinkCounts, extra: Mapping[str, Any] | None = None) -> bytes:
    """The ``fleet/stats/link`` reply: ``{"links": [{"src", "dst", <counters>}...], ...extra}``."""
    links = [{"src": s, "dst": d, **row} for (s, d), row in sorted(counts.items())]
    return msgpack.packb({"links": links, **(extra or {})}, use_bin_type=True)


def decode_stats(payload: bytes) -> tuple[LinkCounts, dict[str, Any]]:
    """Inverse of `encode_stats`: the counts and the extra fields. Raises ValueError."""
    try:
        doc = msgpack.unpackb(payload, raw=False)
        counts = {(str(r["src"]), str(r["dst"])):
                  {k: int(v) for k, v in r.items() if k not in ("src", "dst")}
                  for r in doc["links"]}
        return counts, {k: v for k, v in doc.items() if k != "links"}
    except Exception as exc:  # msgpack raises several unrelated types on garbage
        raise ValueError(f"malformed link stats: {exc!r}") from None
