"""Link fault injection at run time: the payload of ``fleet/ctl/link``.

A msgpack map with any of these keys (anything else makes the whole command malformed)::

    {"extra_loss": 0.3}                                  # uniform loss from now on, 0..1
    {"partition": {"start_s": 600, "end_s": 900,         # simulation seconds; start_s
                   "groups": [["auv1"]]}}                #   defaults to now, and
    {"partition": {"duration_s": 300, "groups": [["auv0", "auv1"], ["auv2"]]}}  # duration_s
    {"clear_partitions": true}                           #   may replace end_s

`Partition` explains groups. Several keys in one command apply in the order clear, partition,
extra loss.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import msgpack

from comms_sim.channel import Channel
from comms_sim.config import Partition

_KEYS = {"extra_loss", "partition", "clear_partitions"}


@dataclass(frozen=True)
class LinkControl:
    extra_loss: float | None = None
    partition: Partition | None = None
    clear_partitions: bool = False

    def __post_init__(self) -> None:
        if self.extra_loss is not None and not 0.0 <= self.extra_loss <= 1.0:
            raise ValueError(f"extra_loss must be in [0, 1], got {self.extra_loss}")

    def encode(self) -> bytes:
        doc: dict[str, Any] = {}
        if self.clear_partitions:
            doc["clear_partitions"] = True
        if self.partition is not None:
            doc["partition"] = self.partition.to_dict()
        if self.extra_loss is not None:
            doc["extra_loss"] = self.extra_loss
        return msgpack.packb(doc)

    @staticmethod
    def decode(payload: bytes, now_s: float) -> "LinkControl":
        """Raises ValueError on anything malformed; relative times are taken from ``now_s``."""
        try:
            doc: Any = msgpack.unpackb(payload, raw=False)
        except Exception as exc:  # msgpack raises several unrelated types on garbage
            raise ValueError(f"link control is not msgpack: {exc!r}") from None
        if not isinstance(doc, dict) or not doc or set(doc) - _KEYS:
            raise ValueError(f"link control must be a map with keys among {sorted(_KEYS)}")
        try:
            loss = doc.get("extra_loss")
            part = doc.get("partition")
            return LinkControl(
                extra_loss=None if loss is None else float(loss),
                partition=None if part is None else Partition.from_dict(part, now_s),
                clear_partitions=bool(doc.get("clear_partitions", False)))
        except (TypeError, AttributeError) as exc:
            raise ValueError(f"malformed link control: {exc!r}") from None

    def apply(self, channel: Channel, t_s: float | None = None) -> None:
        """Change ``channel`` for frames transmitted from ``t_s`` (default: its time) on."""
        if self.clear_partitions:
            channel.clear_partitions(t_s)
        if self.partition is not None:
            channel.add_partition(self.partition, t_s)
        if self.extra_loss is not None:
            channel.set_extra_loss(self.extra_loss, t_s)
