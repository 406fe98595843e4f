"""Failure detection: who is alive, suspected, lost, aborted (announced) or home.

Evidence that a peer is alive comes directly (any authentic fresh frame from it) or
indirectly, SWIM-style: every frame carries, two bits per vehicle, how long ago its sender
last heard each peer (`wire.HEARD_AGES`, in heartbeat periods). Code ``c`` proves the peer
was alive at the frame's send time minus ``HEARD_AGES[c]`` periods, which is the evidence time
used: a lower bound, so relayed evidence can delay a detection but never past the moment
the peer really fell silent.

Silence is not death. A peer with no evidence for ``lost_after_s`` is only *suspected*: it
keeps its spots and claims, and nothing is replanned. It is declared *lost* (and its work
taken over) only when a second observer confirms the silence: a frame from another vehicle,
sent after the suspicion began, whose heard code says that vehicle has not heard the suspect
either (`HEARD_NEVER`). Under total silence nobody can confirm anything, so the fleet flies
its own plans, which is what the no-communication baseline collects; in a two-vehicle fleet
only a watcher (a vehicle home or aborted that keeps sending poses) can confirm.

Any newer evidence clears a suspicion; a lost peer is revived by evidence newer than the
moment it was declared lost (it was heard after that, so it is alive), and its claims live
again. Aborted and home are final.
"""

from __future__ import annotations

from dataclasses import dataclass

from fleet_agent.wire import HEARD_AGES, HEARD_NEVER, Heard, heard_offset, heard_window

ALIVE, SUSPECT, LOST, ABORTED, HOME = "alive", "suspect", "lost", "aborted", "home"
# Statuses under which a peer keeps its work (its claims count, it is planned for).
WORKING = (ALIVE, SUSPECT)


@dataclass
class Peer:
    status: str = ALIVE
    direct_s: float = float("-inf")  # last frame of its own we took
    evidence_s: float = 0.0  # latest evidence of life, direct or relayed
    since_s: float = 0.0  # when the current status began
    frames: int = 0  # frames of its own taken (for the link's reception estimate)


class Membership:
    def __init__(self, n_vehicles: int, me: int, lost_after_s: float, period_s: float,
                 start_s: float = 0.0) -> None:
        self.me = me
        self.lost_after_s = lost_after_s
        self.period_s = period_s
        self.start_s = start_s
        # Everyone starts alive at the mission start: silence is counted from there.
        self.peers = {v: Peer(ALIVE, float("-inf"), start_s, start_s)
                      for v in range(n_vehicles) if v != me}

    def status(self, v: int) -> str:
        return ALIVE if v == self.me else self.peers[v].status

    def alive(self, v: int) -> bool:
        """Still holds its spots: alive, or only suspected (silence alone takes nothing)."""
        return v == self.me or self.peers[v].status in WORKING

    def heard(self, v: int, sent_s: float, now_s: float) -> bool:
        """A frame from ``v`` itself, sent at ``sent_s`` (its sequence number: the sender's
        clock, never later than the truth, however long the frame queued); True if this
        revives a lost peer."""
        p = self.peers[v]
        p.direct_s = max(p.direct_s, sent_s)
        p.frames += 1
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
        if p.status == SUSPECT and now_s < t_s + self.lost_after_s:
            p.status, p.since_s = ALIVE, now_s  # only suspected: nobody acted on it
        elif p.status == LOST and t_s > p.since_s:
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
        """Peers that went silent too long as of ``now_s`` (newly suspected)."""
        suspected = []
        for v, p in self.peers.items():
            if p.status == ALIVE and now_s >= p.evidence_s + self.lost_after_s:
                p.status, p.since_s = SUSPECT, now_s
                suspected.append(v)
        return suspected

    def confirm(self, sender: int, field: Heard, sent_s: float, now_s: float) -> list[int]:
        """Suspects whose silence ``sender``'s frame (sent at ``sent_s``) confirms: it was
        sent after the suspicion began, its heard window covers them, and it says its sender
        has not heard them either. They are now lost."""
        n = len(self.peers) + 1
        never = set()
        for i in range(heard_window(n)):  # trailing "never" codes are left off the wire
            if i >= len(field.codes) or field.codes[i] == HEARD_NEVER:
                never.add((field.offset + i) % n)
        lost = []
        for v, p in self.peers.items():
            if v != sender and v in never and p.status == SUSPECT and sent_s >= p.since_s:
                p.status, p.since_s = LOST, now_s
                lost.append(v)
        return lost

    def reception(self, now_s: float) -> float:
        """How much of what the peers send reaches this vehicle: frames taken per heartbeat
        period, averaged over peers (each counted until its last frame, so a silence being
        judged does not count against the link). A vehicle sends at least one frame per
        period while working, so this is a lower bound on the link's delivery rate."""
        rates = []
        for p in self.peers.values():
            until = now_s if p.status in WORKING else p.direct_s
            periods = (until - self.start_s) / self.period_s
            if periods >= 4:  # too early to say anything
                rates.append(min(1.0, p.frames / periods))
        return sum(rates) / len(rates) if rates else 0.0

    def doubt(self, now_s: float) -> float:
        """Chance that a peer whose silence was just confirmed is alive and merely unheard:
        two observers (this vehicle and the confirmer) each missing ``lost_after_s`` worth of
        its frames, at the reception rate this vehicle measures (`reception`). Small on a
        good link, near 1 on a bad one. The silence is counted as the detection window, not
        as however long it has lasted: losses at sea come in bursts (range, a reef between,
        a partition), and a long silence on a link that drops frames is no proof of death."""
        return (1.0 - self.reception(now_s)) ** (2.0 * self.lost_after_s / self.period_s)

    def suspects(self) -> list[int]:
        return [v for v, p in self.peers.items() if p.status == SUSPECT]

    def next_deadline_s(self) -> float | None:
        """When `check` could next find a lost peer."""
        times = [p.evidence_s + self.lost_after_s for p in self.peers.values()
                 if p.status == ALIVE]
        return min(times) if times else None

    def heard_field(self, now_s: float) -> Heard:
        """What this vehicle tells the others: the `HEARD_AGES` code of its last direct
        hearing of each peer in this cycle's window of the roster (`wire.heard_offset`: it
        rotates, so every peer is covered every few cycles); `HEARD_NEVER` for itself."""
        n = len(self.peers) + 1
        offset = heard_offset(self.me, int(now_s // self.period_s), n)
        codes = []
        for i in range(heard_window(n)):
            p = self.peers.get((offset + i) % n)
            code = HEARD_NEVER
            for c, age in enumerate(HEARD_AGES):
                if p is not None and now_s - p.direct_s <= age * self.period_s:
                    code = c
                    break
            codes.append(code)
        return Heard(offset, tuple(codes))

    def take_heard(self, sender: int, field: Heard, sent_s: float, now_s: float) -> list[int]:
        """Relayed evidence from a frame ``sender`` sent at ``sent_s``; the peers it revived."""
        revived = []
        for v, code in field.items(len(self.peers) + 1):
            if v != sender and v in self.peers:
                if self.relayed(v, sent_s - HEARD_AGES[code] * self.period_s, now_s):
                    revived.append(v)
        return revived

    def snapshot(self) -> dict[int, tuple[str, float]]:
        return {v: (p.status, p.since_s) for v, p in self.peers.items()}
