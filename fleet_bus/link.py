"""The link's messages on the bus: what happened to each frame on each link
(``fleet/link/<src>/<dst>``), fault injection at run time (``fleet/ctl/link``) and the relay's
counters (``fleet/stats/link``).

A link record describes a frame's fate, not its content: the frame itself only travels on
``fleet/rx/<dst>`` to the vehicle it was delivered to.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterable, Mapping

import msgpack

from fleet_bus import values as v
from fleet_bus.orders import TOPSIDE  # the operator's own modem at the boat

BROADCAST = "*"  # dst of records that concern no particular receiver (oversize refusals)
LinkCounts = dict[tuple[str, str], dict[str, int]]


MAX_KIND_CHARS = 16


@dataclass(frozen=True)
class TxTag:
    """The attachment of an agent's put on ``fleet/tx/<id>`` (the frame itself stays raw):
    ``kind``, the relay queue's class (a newer "pose" replaces a queued one; anything else is
    "data"), and ``sent_s``, when the vehicle sent it on the mission clock: the relay's
    channel places the frame there, not when the bus happened to deliver it, so neither bus
    latency nor a host that ran late (the frame of a slot that went by is dated at the
    slot's opening) shows in the water. Encoded ``b"pose"`` or ``b"pose@1234.500"``;
    anything malformed is plain "data", sent at the relay's time."""

    kind: str = "data"
    sent_s: float | None = None

    def encode(self) -> bytes:
        kind = self.kind[:MAX_KIND_CHARS]
        return (kind if self.sent_s is None else f"{kind}@{self.sent_s:.3f}").encode("ascii")

    @classmethod
    def decode(cls, raw: bytes | None) -> "TxTag":
        if not raw:
            return cls()
        try:
            text = raw[:64].decode("ascii")
        except UnicodeDecodeError:
            return cls()
        kind, _, when = text.partition("@")
        kind = kind[:MAX_KIND_CHARS] or "data"
        if not when:
            return cls(kind)
        try:
            sent_s = float(when)
        except ValueError:
            return cls(kind)
        return cls(kind, sent_s if math.isfinite(sent_s) else None)


@dataclass(frozen=True)
class LinkRecord:
    """A delivery or a drop. ``t_sent_s``: transmission start; ``t_s``: when the outcome
    settled (end of reception at ``dst``; for a refusal, the submission time). ``reason`` is
    the channel's name for the drop (None when delivered); ``snr_db`` the received SNR when
    the channel model computes one."""

    src: str
    dst: str
    t_sent_s: float
    t_s: float
    nbytes: int
    delivered: bool
    reason: str | None = None
    snr_db: float | None = None

    def __post_init__(self) -> None:
        if self.delivered != (self.reason is None):
            raise ValueError("a delivered record has no reason, a drop has one")

    def encode(self) -> bytes:
        doc: dict[str, Any] = {"src": self.src, "dst": self.dst, "t_sent_s": self.t_sent_s,
                               "t_s": self.t_s, "nbytes": self.nbytes,
                               "delivered": self.delivered, "reason": self.reason}
        if self.snr_db is not None:
            doc["snr_db"] = self.snr_db
        return msgpack.packb(doc)

    @staticmethod
    def decode(payload: bytes) -> "LinkRecord":
        doc = v.unpack_map(payload, "link record")
        try:
            delivered = doc["delivered"]
            if not isinstance(delivered, bool):
                raise ValueError("link.delivered: expected a bool")
            reason = doc["reason"]
            snr = doc.get("snr_db")
            return LinkRecord(
                v.text(doc["src"], "link.src", 64), v.text(doc["dst"], "link.dst", 64),
                v.number(doc["t_sent_s"], "link.t_sent_s"), v.number(doc["t_s"], "link.t_s"),
                v.integer(doc["nbytes"], "link.nbytes", 0, 1 << 16), delivered,
                None if reason is None else v.text(reason, "link.reason", 32),
                None if snr is None else v.number(snr, "link.snr_db"))
        except KeyError as exc:
            raise ValueError(f"link record: missing {exc}") from None


def _group(names: Iterable[str]) -> frozenset[str]:
    if isinstance(names, (str, bytes)):
        raise ValueError("each partition group must be a list of ids")
    return frozenset(str(n) for n in names)


@dataclass(frozen=True)
class Partition:
    """Links cut during ``[start_s, end_s)``.

    Nodes listed in different ``groups`` cannot hear each other; nodes listed in no group form
    one more, implicit group. So ``groups=(("auv1",),)`` isolates auv1 from everyone, and
    ``groups=(("auv0", "auv1"), ("auv2", "auv3"))`` splits a fleet of four in two.
    """

    start_s: float
    end_s: float
    groups: tuple[frozenset[str], ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "groups", tuple(_group(g) for g in self.groups))
        if not (math.isfinite(self.start_s) and math.isfinite(self.end_s)):
            raise ValueError(f"partition times must be finite: {self.start_s}..{self.end_s}")
        if not self.end_s > self.start_s:
            raise ValueError(f"partition must end after it starts: {self.start_s}..{self.end_s}")
        if not self.groups or any(not g for g in self.groups):
            raise ValueError("partition needs at least one non-empty group")
        seen: set[str] = set()
        for g in self.groups:
            if seen & g:
                raise ValueError(f"partition groups overlap on {sorted(seen & g)}")
            seen |= g

    def _group_of(self, node: str) -> int:
        for i, g in enumerate(self.groups):
            if node in g:
                return i
        return -1  # the implicit group of unlisted nodes

    def cuts(self, a: str, b: str, start_s: float, end_s: float) -> bool:
        """Whether this partition cuts the a-b link at any time during ``[start_s, end_s)``."""
        overlaps = start_s < self.end_s and self.start_s < end_s
        return overlaps and self._group_of(a) != self._group_of(b)

    def to_dict(self) -> dict[str, Any]:
        return {"start_s": self.start_s, "end_s": self.end_s,
                "groups": [sorted(g) for g in self.groups]}

    @staticmethod
    def from_dict(doc: Mapping[str, Any], now_s: float = 0.0) -> "Partition":
        """``{"start_s"?: s, "end_s": s | "duration_s": s, "groups": [[id, ...], ...]}``;
        ``start_s`` defaults to ``now_s``. Raises ValueError when malformed."""
        try:
            start = v.number(doc.get("start_s", now_s), "partition.start_s")
            end = (v.number(doc["end_s"], "partition.end_s") if "end_s" in doc
                   else start + v.number(doc["duration_s"], "partition.duration_s"))
            groups = doc["groups"]
            if not isinstance(groups, (list, tuple)):
                raise ValueError("partition.groups: expected a list of lists of ids")
            return Partition(start, end, tuple(_group(g) for g in groups))
        except (KeyError, TypeError, AttributeError) as exc:
            raise ValueError(f"malformed partition: {exc!r}") from None


_CONTROL_KEYS = {"extra_loss", "partition", "clear_partitions", "inject", "inject_at",
                 "inject_from"}
INTRUDER = "intruder"  # the node name of a foreign modem the operator makes transmit
INJECTORS = (INTRUDER, TOPSIDE)  # the modems link control may make transmit


@dataclass(frozen=True)
class LinkControl:
    """The payload of ``fleet/ctl/link``: a msgpack map with any of these keys::

        {"extra_loss": 0.3}                                  # uniform loss from now on, 0..1
        {"partition": {"start_s": 600, "end_s": 900,         # simulation seconds; start_s
                       "groups": [["auv1"]]}}                #   defaults to now, and
        {"partition": {"duration_s": 300, "groups": [["auv0", "auv1"], ["auv2"]]}}
        {"clear_partitions": true}
        {"inject": <bytes>, "inject_at": [x, y, z]}          # a foreign modem ("intruder")
                                                             #   at x, y, z sends these bytes
        {"inject": ..., "inject_at": ..., "inject_from": "topside"}  # the operator's modem
                                                             #   (its node hears the water)

    Several keys in one command apply in the order clear, partition, extra loss, inject.
    """

    extra_loss: float | None = None
    partition: Partition | None = None
    clear_partitions: bool = False
    inject: bytes | None = None
    inject_at: tuple[float, float, float] | None = None
    inject_from: str = INTRUDER  # which modem (node) transmits them: one of `INJECTORS`

    def __post_init__(self) -> None:
        if self.inject_from not in INJECTORS:
            raise ValueError(f"inject_from is one of {', '.join(INJECTORS)}, got "
                             f"{self.inject_from!r}")
        if self.extra_loss is not None and not 0.0 <= self.extra_loss <= 1.0:
            raise ValueError(f"extra_loss must be in [0, 1], got {self.extra_loss}")
        if (self.inject is None) != (self.inject_at is None):
            raise ValueError("inject needs inject_at (where the foreign modem is), and back")
        if self.inject is not None and not 0 < len(self.inject) <= 1024:
            raise ValueError("an injected frame has 1..1024 bytes")

    def encode(self) -> bytes:
        doc: dict[str, Any] = {}
        if self.clear_partitions:
            doc["clear_partitions"] = True
        if self.partition is not None:
            doc["partition"] = self.partition.to_dict()
        if self.extra_loss is not None:
            doc["extra_loss"] = self.extra_loss
        if self.inject is not None:
            doc["inject"], doc["inject_at"] = bytes(self.inject), list(self.inject_at or ())
            if self.inject_from != INTRUDER:
                doc["inject_from"] = self.inject_from
        return msgpack.packb(doc, use_bin_type=True)

    @staticmethod
    def decode(payload: bytes, now_s: float) -> "LinkControl":
        """Raises ValueError on anything malformed; relative times are taken from ``now_s``."""
        doc = v.unpack_map(payload, "link control")
        if not doc or set(doc) - _CONTROL_KEYS:
            raise ValueError(f"link control must be a map with keys among {sorted(_CONTROL_KEYS)}")
        loss = doc.get("extra_loss")
        part = doc.get("partition")
        clear = doc.get("clear_partitions", False)
        if not isinstance(clear, bool):
            raise ValueError("link control: clear_partitions must be a bool")
        if part is not None and not isinstance(part, dict):
            raise ValueError("link control: partition must be a map")
        inject, at = doc.get("inject"), doc.get("inject_at")
        if inject is not None and not isinstance(inject, bytes):
            raise ValueError("link control: inject must be bytes")
        source = doc.get("inject_from", INTRUDER)
        if not isinstance(source, str):
            raise ValueError("link control: inject_from must be a modem's name")
        return LinkControl(
            extra_loss=None if loss is None else v.number(loss, "link control.extra_loss"),
            partition=None if part is None else Partition.from_dict(part, now_s),
            clear_partitions=clear, inject=inject,
            inject_at=None if at is None else v.point(at, "link control.inject_at"),
            inject_from=source)


def encode_stats(counts: LinkCounts, extra: Mapping[str, Any] | None = None) -> bytes:
    """The ``fleet/stats/link`` reply: ``{"links": [{"src", "dst", <counters>}...], ...extra}``."""
    links = [{"src": s, "dst": d, **row} for (s, d), row in sorted(counts.items())]
    return msgpack.packb({"links": links, **(extra or {})}, use_bin_type=True)


def decode_stats(payload: bytes) -> tuple[LinkCounts, dict[str, Any]]:
    """Inverse of `encode_stats`: the counts and the extra fields. Raises ValueError."""
    doc = v.unpack_map(payload, "link stats")
    rows = doc.get("links")
    if not isinstance(rows, list):
        raise ValueError("link stats: expected a list of links")
    counts: LinkCounts = {}
    for r in rows:
        if not isinstance(r, dict):
            raise ValueError("link stats: each link is a map")
        src = v.text(r.get("src"), "link stats.src", 64)
        dst = v.text(r.get("dst"), "link stats.dst", 64)
        counts[(src, dst)] = {k: v.integer(n, f"link stats.{k}", 0)
                              for k, n in r.items() if k not in ("src", "dst")}
    return counts, {k: x for k, x in doc.items() if k != "links"}
