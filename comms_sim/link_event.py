"""What happened to one frame on one link: the record the ground station draws.

Published by the relay on ``fleet/link/<src>/<dst>`` (`comms_sim.bus.link_event_key`) and
handed to listeners of the in-process network.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import msgpack

# Why a frame did not arrive, in the order they are attributed when several apply (see
# `comms_sim.channel`): "sinr" is a frame too weak over the noise to decode even alone,
# "collision" one that would have decoded alone but not among the frames overlapping it.
DROP_REASONS = ("oversize", "partition", "range", "sinr", "half_duplex", "collision",
                "random")
BROADCAST = "*"  # dst of events that concern no particular receiver (oversize refusals)


@dataclass(frozen=True)
class LinkEvent:
    """A delivery or a drop. ``t_sent_s`` is when transmission started; ``t_s`` when the
    outcome settled (end of reception at ``dst``; for a refusal, the submission time).
    ``snr_db``: the frame's mean in-band SNR at ``dst`` (no fading, no interference);
    ``sinr_db``: its mean SINR against the strongest overlap. None when the model has no
    such figure (empirical model, unheard frames, refusals)."""

    src: str
    dst: str
    t_sent_s: float
    t_s: float
    nbytes: int
    delivered: bool
    reason: str | None
    frame: bytes
    snr_db: float | None = None
    sinr_db: float | None = None
    # The submitter's own annotation of the frame (`Channel.submit` ``tag``), handed back
    # untouched and never encoded: e.g. the Micro-Modem face's packet header.
    tag: Any = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.delivered != (self.reason is None):
            raise ValueError("a delivered event has no reason, a drop has one")
        if self.reason is not None and self.reason not in DROP_REASONS:
            raise ValueError(f"unknown drop reason {self.reason!r}")

    def encode(self) -> bytes:
        return msgpack.packb(
            {"src": self.src, "dst": self.dst, "t_sent_s": self.t_sent_s, "t_s": self.t_s,
             "nbytes": self.nbytes, "delivered": self.delivered, "reason": self.reason,
             "frame": self.frame, "snr_db": self.snr_db, "sinr_db": self.sinr_db},
            use_bin_type=True)

    @staticmethod
    def decode(payload: bytes) -> "LinkEvent":
        """Raises ValueError on anything that is not a well-formed link event."""
        try:
            doc: Any = msgpack.unpackb(payload, raw=False)
            reason, frame = doc["reason"], doc["frame"]
            if not isinstance(frame, bytes):  # bytes(5) would make five zero bytes
                raise TypeError(f"frame must be bytes, got {type(frame).__name__}")
            snr, sinr = doc.get("snr_db"), doc.get("sinr_db")  # absent from older senders
            return LinkEvent(
                str(doc["src"]), str(doc["dst"]), float(doc["t_sent_s"]), float(doc["t_s"]),
                int(doc["nbytes"]), bool(doc["delivered"]),
                None if reason is None else str(reason), frame,
                None if snr is None else float(snr), None if sinr is None else float(sinr))
        except Exception as exc:  # msgpack raises several unrelated types on garbage
            raise ValueError(f"malformed link event: {exc!r}") from None
