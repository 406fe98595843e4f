"""The cleared spots: a grow-only set (G-Set CRDT) kept as a bitmap.

Merging is bitwise OR, so loss, duplication and reordering of gossip can never un-clear a
spot, and any two vehicles that have exchanged their states hold the same set. The digest
(size mod 128 and a 16-bit sum of per-spot hashes, both order-free and updated in O(1)) rides
on every pose; a vehicle that hears a digest unlike its own pushes its full state, one
segment of the codec's ``segment_bits`` per frame, and so does the other side: that is the
anti-entropy.
"""

from __future__ import annotations

import hashlib
import math
from typing import Iterable, Iterator

from fleet_agent.wire import SEGMENT_BITS, Digest


def _spot_hash(i: int) -> int:
    # A fixed function of the index (Python's hash() is salted per process).
    return int.from_bytes(hashlib.blake2b(i.to_bytes(4, "little"), digest_size=2).digest(),
                          "little")


class ClearedSet:
    def __init__(self, n_tasks: int, segment_bits: int = SEGMENT_BITS) -> None:
        self.n_tasks = n_tasks
        self.segment_bits = segment_bits  # spots per segment, from the frame budget
        self._bits = 0  # the bitmap the wire carries (segments, news)
        # One byte per spot beside it, for membership: ``bits >> task`` copies the whole
        # bitmap, O(spots) per look-up, and the fleet asks millions of times per mission.
        self._flags = bytearray(n_tasks)
        self._added: list[int] = []  # in the order they were added (`added_since`)
        self._hash = 0
        self._table = [_spot_hash(i) for i in range(n_tasks)]

    def __contains__(self, task: int) -> bool:
        return 0 <= task < self.n_tasks and self._flags[task] == 1

    def __len__(self) -> int:
        return len(self._added)

    def __iter__(self) -> Iterator[int]:
        flags = self._flags
        return (i for i in range(self.n_tasks) if flags[i])

    def add(self, task: int) -> bool:
        """Add one spot; True if it was new."""
        if not 0 <= task < self.n_tasks:
            raise ValueError(f"task index {task} outside the scenario")
        if task in self:
            return False
        self._bits |= 1 << task
        self._flags[task] = 1
        self._added.append(task)
        self._hash = (self._hash + self._table[task]) & 0xFFFF
        return True

    def update(self, tasks: Iterable[int]) -> list[int]:
        return [t for t in tasks if self.add(t)]

    def added_since(self, n: int) -> list[int]:
        """The spots added after the first ``n`` (in order): what a reader that had seen
        ``n`` of them must catch up on (`Knowledge.held_map`)."""
        return self._added[n:]

    def digest(self) -> Digest:
        return Digest(len(self._added) & 0x7F, self._hash)

    @property
    def n_segments(self) -> int:
        return max(1, math.ceil(self.n_tasks / self.segment_bits))

    def segment_of(self, task: int) -> int:
        return task // self.segment_bits

    def segment(self, segment: int) -> bytes:
        """The bitmap bytes of one segment (little-endian bit order)."""
        lo = segment * self.segment_bits
        bits = min(self.segment_bits, self.n_tasks - lo)
        width = max(1, math.ceil(bits / 8))
        return ((self._bits >> lo) & ((1 << bits) - 1)).to_bytes(width, "little")

    def news_in(self, segment: int, data: bytes) -> list[int]:
        """The spots a received segment holds that this set lacks (ascending; nothing
        changes here). Bitwise: a frame's cost follows its news, not the segment's size."""
        lo = segment * self.segment_bits
        width = max(0, min(self.segment_bits, self.n_tasks - lo))
        new = ((int.from_bytes(data, "little") & ((1 << width) - 1)) << lo) & ~self._bits
        out: list[int] = []
        while new:
            low = new & -new
            out.append(low.bit_length() - 1)
            new ^= low
        return out

    def merge_segment(self, segment: int, data: bytes) -> list[int]:
        """OR a received segment in; returns the spots that were new here."""
        return self.update(self.news_in(segment, data))

    def missing_from(self, segment: int, data: bytes) -> bool:
        """Whether a peer's segment lacks a spot this set has (so a push would help it)."""
        lo = segment * self.segment_bits
        theirs = int.from_bytes(data, "little") << lo
        mask = ((1 << min(self.segment_bits, self.n_tasks - lo)) - 1) << lo
        return bool(self._bits & mask & ~theirs)
