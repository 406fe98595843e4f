"""Failure detection: who is alive, lost (silent too long), aborted (announced) or home.

Evidence that a peer is alive comes directly (any authentic fresh frame from it) or
indirectly, SWIM-style: every frame carries, two bits per vehicle, how long ago its sender
last heard each peer (`wire.HEARD_AGES`, in heartbeat periods). Code ``c`` proves the peer
was alive at the frame's send time minus ``HEARD_AGES[c]`` periods, which is the evidence time
used: a lower bound, so relayed evidence can delay a detection but never past the moment
the peer really fell silent. A peer is
lost once ``now - evidence >= lost_after_s``. Several independent paths keep false alarms rare
under heavy loss, without slowing down the detection of a vehicle that really went silent.

A lost peer is revived by a frame of its own, or by relayed evidence newer than the moment
it was declared lost (it was heard after that, so it is alive). Aborted and home are final.
"""

from __future__ import annotations

from dataclasses import dataclass

from fleet_agent.wire import HEARD_AGES, HEARD_NEVER

ALIVE, LOST, ABORTED, HOME = "alive", "lost", "aborted", "home"


@dataclass
class Peer:
    status: str = ALIVE
    direct_s: float = float("-inf")  # last frame of its own we took
    evidence_s: float = 0.0  # latest evidence of life, direct or relayed
    since_s: float = 0.0  # when the current status began


class Membership:
    def __init__(self, n_vehicles: int, me: int, lost_after_s: float, period_s: float,
                 start_s: float = 0.0) -> None:
        self.me = me
        self.lost_after_s = lost_after_s
        self.period_s = period_s
        # Everyone starts alive at the mission start: silence is counted from there.
        self.peers = {v: Peer(ALIVE, float("-inf"), start_s, start_s)
                      for v in range(n_vehicles) if v != me}

    def status(self, v: int) -> str:
        return ALIVE if v == self.me else self.peers[v].status

    def alive(self, v: int) -> bool:
        return v == self.me or self.peers[v].status == ALIVE

    def heard(self, v: int, sent_s: float, now_s: float) -> bool:
        """A frame from ``v`` itself, sent at ``sent_s`` (its sequence number: the sender's
        clock, never later than the truth, however long the frame queued); True if this
        revives a lost peer."""
        p = self.peers[v]
        p.direct_s = max(p.direct_s, sent_s)
        return self._evidence(v, sent_s, now_s)

    def relayed(self, v: int, evidence_s: float, now_s: float) -> bool:
        """Another vehicle heard ``v`` at ``evidence_s`` or later; True if this revives it."""
        if v == self.me:
            return False
        return self._evidence(v, evidence_s, now_s)

    def _evidence(self, v: int, t_s: float, now_s: float) -> bool:
        p = self.peers[v]
        if t_s <= p.evidence_s:
            return False
        p.evidence_s = t_s
        if p.status == LOST and t_s > p.since_s:
            p.status, p.since_s = ALIVE, now_s
            return True
        return False

    def mark(self, v: int, status: str, now_s: float) -> bool:
        """Record an announced abort or arrival home; True if the status changed."""
        p = self.peers[v]
        if p.status in (ABORTED, HOME) or p.status == status:
            return False
        p.status, p.since_s = status, now_s
        return True

    def check(self, now_s: float) -> list[int]:
        """Peers that went silent too long as of ``now_s`` (newly lost)."""
        lost = []
        for v, p in self.peers.items():
            if p.status == ALIVE and now_s >= p.evidence_s + self.lost_after_s:
                p.status, p.since_s = LOST, now_s
                lost.append(v)
        return lost

    def next_deadline_s(self) -> float | None:
        """When `check` could next find a lost peer."""
        times = [p.evidence_s + self.lost_after_s for p in self.peers.values()
                 if p.status == ALIVE]
        return min(times) if times else None

    def heard_field(self, now_s: float) -> int:
        """What this vehicle tells the others: 2 bits per vehicle index, the `HEARD_AGES`
        code of its last direct hearing of each peer (`HEARD_NEVER` for itself)."""
        field = HEARD_NEVER << (2 * self.me)
        for v, p in self.peers.items():
            code = HEARD_NEVER
            for c, age in enumerate(HEARD_AGES):
                if now_s - p.direct_s <= age * self.period_s:
                    code = c
                    break
            field |= code << (2 * v)
        return field

    def take_heard(self, sender: int, field: int, sent_s: float, now_s: float) -> list[int]:
        """Relayed evidence from a frame ``sender`` sent at ``sent_s``; the peers it revived."""
        revived = []
        for v in self.peers:
            code = field >> (2 * v) & 3
            if v != sender and code != HEARD_NEVER:
                if self.relayed(v, sent_s - HEARD_AGES[code] * self.period_s, now_s):
                    revived.append(v)
        return revived

    def snapshot(self) -> dict[int, tuple[str, float]]:
        return {v: (p.status, p.since_s) for v, p in self.peers.items()}
