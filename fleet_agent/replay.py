"""Replay protection: a sliding window of sequence numbers per sender (IPsec/DTLS style).

A frame is fresh if its sequence number is above everything seen from that sender, or within
the last `WINDOW` numbers and not seen yet. Older or repeated numbers are replays. The
high-water marks go into the journal, so a restarted agent does not accept frames it had
already taken before the restart.
"""

from __future__ import annotations

WINDOW = 64


class ReplayWindow:
    def __init__(self) -> None:
        self._high: dict[int, int] = {}
        self._seen: dict[int, int] = {}  # bit i: seq high - i was seen

    def accept(self, sender: int, seq: int) -> bool:
        """True (and remembered) if ``seq`` is fresh for ``sender``; False for a replay."""
        high = self._high.get(sender)
        if high is None or seq > high:
            shift = WINDOW if high is None else min(WINDOW, seq - high)
            self._seen[sender] = ((self._seen.get(sender, 0) << shift) | 1) & ((1 << WINDOW) - 1)
            self._high[sender] = seq
            return True
        age = high - seq
        if age >= WINDOW:
            return False
        bit = 1 << age
        if self._seen[sender] & bit:
            return False
        self._seen[sender] |= bit
        return True

    def high_water(self) -> dict[int, int]:
        return dict(self._high)

    def restore(self, high: dict[int, int]) -> None:
        """After a restart: everything up to each recorded mark counts as seen."""
        for sender, seq in high.items():
            if seq > self._high.get(sender, -1):
                self._high[sender] = int(seq)
                self._seen[sender] = (1 << WINDOW) - 1
