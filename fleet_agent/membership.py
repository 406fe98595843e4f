"""Failure detection: who is alive, suspected, lost, aborted (announced) or home.

Evidence that a peer is alive comes directly (any authentic fresh frame from it) or
indirectly, SWIM-style (Das, Gupta and Motivala, "SWIM: Scalable Weakly-consistent
Infection-style Process Group Membership Protocol", DSN 2002): every frame carries, two bits
per vehicle of a window of the roster, how long ago its sender last heard each peer
(`wire.HEARD_AGES`, in heartbeat periods). Code ``c`` proves the peer was alive at the
frame's send time minus ``HEARD_AGES[c]`` periods, which is the evidence time used: a lower
bound, so relayed evidence can delay a detection but never past the moment the peer really
fell silent.

Silence is not death, and in a large fleet silence is the rule: most pairs are beyond
acoustic range of each other. So silence counts only where a frame was to be expected
(`Reach`: the acoustic range on the positions last known, docs/membership.md):

- a peer with no evidence for ``lost_after_cycles`` of its own turns (`Timing.turn_s`: the
  slot schedule says how often it speaks) is only *suspected*: it keeps its spots and claims,
  and nothing is replanned;
- it is declared *lost* (and its work taken over) only when two observers that should have
  heard it have not: this vehicle, within whose reach it is and which heard it itself about
  as late as anyone did (`RECENT_TURNS`), and a *witness*, the sender of
  a frame sent after the suspicion began whose heard code says it has not heard the suspect
  for 4 periods either (`HEARD_NEVER`) although it was within its reach too. A witness out
  of the suspect's reach proves nothing, however silent; a vehicle out of its reach never
  declares it lost (it stays suspected there, its claims standing: its neighbours take its
  work over, and their clears reach everyone).

Under total silence nobody can confirm anything, so the fleet flies its own plans, which is
what the no-communication baseline collects; in a two-vehicle fleet only a watcher (a
vehicle home or aborted that keeps sending poses) can confirm. To make witnesses speak of
the silences that matter, a vehicle's heard window covers first the peers within its reach
that it suspects or has just declared lost (`heard_field`), else it rotates over the roster.

Any newer evidence clears a suspicion; a lost peer is revived by evidence newer than the
moment it was declared lost (it was heard after that, so it is alive), and its claims live
again. Aborted and home are final.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass, field
from typing import Protocol

from fleet_agent.wire import HEARD_AGES, HEARD_NEVER, Heard, heard_offset, heard_window

ALIVE, SUSPECT, LOST, ABORTED, HOME = "alive", "suspect", "lost", "aborted", "home"
# Statuses under which a peer keeps its work (its claims count, it is planned for).
WORKING = (ALIVE, SUSPECT)
OBSERVERS = 2  # silent observers within reach needed to declare a silence a loss
# A vehicle judges a peer's silence only if it heard the peer itself within this many turns
# of the latest evidence of it from anyone (the peer was near in fact: a belief of where it
# is, dead reckoned on old news, once made a vehicle "expect" a peer that had long left).
RECENT_TURNS = 2


class Timing(Protocol):
    """The slot schedule as membership needs it (`fleet_agent.radio.Slots`)."""

    def cycle_s(self, t_s: float) -> float:
        """The heartbeat period at ``t_s`` (the heard codes' unit)."""

    def turn_s(self, v: int, t_s: float) -> float:
        """How often vehicle ``v`` has a slot at ``t_s``."""


def detection_bound_s(timing: Timing, lost_after_cycles: int, slot_s: float,
                      silent_s: float) -> float:
    """docs/membership.md's bound on how long after ``silent_s`` a vehicle that fell silent
    then is declared lost by the neighbours that should hear it: ``lost_after_cycles`` of
    silence, a witness's next slot, and up to two cycles that prove the witness's frame its
    sender's (`fleet_bus.tesla`: a pose discloses no key), each of the longest cycle in force
    from 300 s before to 1800 s after (epochs change), plus a slot."""
    longest = max(timing.cycle_s(t) for t in range(int(silent_s) - 300, int(silent_s) + 1800))
    return (lost_after_cycles + 3) * longest + slot_s


class Reach(Protocol):
    """Who should hear whom (`fleet_agent.knowledge.Knowledge.expects`)."""

    def expects(self, listener: int, speaker: int, t_s: float, slack_s: float = 0.0) -> bool:
        """Should ``listener`` have heard ``speaker``'s frames around ``t_s``, were the
        speaker alive? ``slack_s``: the speaker's believed position may be off by as far
        as it travels in that long (a reckoning over that span)."""


@dataclass(frozen=True)
class FixedTiming:
    """One slot per vehicle per period of ``period_s`` (the plain TDMA cycle)."""

    period_s: float

    def cycle_s(self, t_s: float) -> float:
        return self.period_s

    def turn_s(self, v: int, t_s: float) -> float:
        return self.period_s


class Everyone:
    """Everyone within reach of everyone (a small fleet in one patch of water)."""

    def expects(self, listener: int, speaker: int, t_s: float, slack_s: float = 0.0) -> bool:
        return True


@dataclass
class Peer:
    status: str = ALIVE
    direct_s: float = float("-inf")  # last frame of its own we took
    evidence_s: float = 0.0  # latest evidence of life, direct or relayed
    since_s: float = 0.0  # when the current status began
    frames: int = 0  # frames of its own taken (for the link's reception estimate)
    first_s: float | None = None  # when its first frame was taken
    witnesses: set[int] = field(default_factory=set)  # confirmed its current suspicion
    queued: bool = False  # has an entry in the deadline queue


class Membership:
    def __init__(self, n_vehicles: int, me: int, lost_after_s: float, period_s: float,
                 start_s: float = 0.0, timing: Timing | None = None,
                 reach: Reach | None = None) -> None:
        self.me = me
        self.n = n_vehicles
        # Silence thresholds are counted in the peer's own turns (`lost_after_s` at the
        # reference period ``period_s``): a peer whose slot comes twice as seldom may be
        # silent twice as long.
        self.lost_after_cycles = lost_after_s / period_s
        self.timing: Timing = timing or FixedTiming(period_s)
        self.reach: Reach = reach or Everyone()
        self.start_s = start_s
        self._checked_s = start_s  # the latest `check`
        self.version = 0  # bumped by every change of a peer's status
        self.alive_version = 0  # bumped by every change of who holds spots (`alive`)
        # Everyone starts alive at the mission start: silence is counted from there.
        self.peers = {v: Peer(ALIVE, float("-inf"), start_s, start_s)
                      for v in range(n_vehicles) if v != me}
        # When each alive peer may next be found silent: a lower bound (evidence only moves
        # a deadline later), corrected when it comes due, so a step costs O(log n), not O(n).
        self._due: list[tuple[float, int]] = []
        for v in self.peers:
            self._queue(v)
        # Peers suspected or lost: those `heard_field` may lead its window with (a frame of a
        # 100-vehicle fleet scanned all 99 peers for the few it doubts).
        self._doubted: set[int] = set()

    @property
    def period_s(self) -> float:
        """The heartbeat period at the mission start (a reference for tests and reports)."""
        return self.timing.cycle_s(self.start_s)

    def _deadline(self, v: int, at_s: float) -> float:
        """When alive peer ``v``'s silence becomes a suspicion, as the schedule stands at
        ``at_s`` (or later)."""
        p = self.peers[v]
        return p.evidence_s + self.lost_after_s(v, max(at_s, p.evidence_s), p.evidence_s)

    def _queue(self, v: int) -> None:
        p = self.peers[v]
        if p.status == ALIVE and not p.queued:
            p.queued = True
            heapq.heappush(self._due, (self._deadline(v, self._checked_s), v))

    def _set(self, v: int, status: str, now_s: float) -> None:
        p = self.peers[v]
        if (p.status in WORKING) != (status in WORKING):
            self.alive_version += 1
        p.status, p.since_s = status, now_s
        p.witnesses.clear()
        if status in (SUSPECT, LOST):
            self._doubted.add(v)
        else:
            self._doubted.discard(v)
        self.version += 1

    def lost_after_s(self, v: int, t_s: float, since_s: float | None = None) -> float:
        """How long peer ``v`` may be silent at ``t_s`` before it is suspected (its slot's
        period at the start of the silence and now, the longer)."""
        turn = self.timing.turn_s(v, t_s)
        if since_s is not None:
            turn = max(turn, self.timing.turn_s(v, since_s))
        return self.lost_after_cycles * turn

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
        if p.first_s is None:
            p.first_s = now_s
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
        if p.status == SUSPECT and now_s < t_s + self.lost_after_s(v, now_s, t_s):
            self._set(v, ALIVE, now_s)  # only suspected: nobody acted on it
            self._queue(v)
        elif p.status == LOST and t_s > p.since_s:
            self._set(v, ALIVE, now_s)
            self._queue(v)
            return True
        return False

    def mark(self, v: int, status: str, now_s: float) -> bool:
        """Record an announced abort or arrival home; True if the status changed."""
        p = self.peers[v]
        if p.status in (ABORTED, HOME) or p.status == status:
            return False
        self._set(v, status, now_s)
        return True

    def check(self, now_s: float) -> list[int]:
        """Peers that went silent too long as of ``now_s`` (newly suspected)."""
        self._checked_s = max(self._checked_s, now_s)
        suspected = []
        while self._due and self._due[0][0] <= now_s:
            _, v = heapq.heappop(self._due)
            p = self.peers[v]
            p.queued = False
            if p.status != ALIVE:
                continue
            if now_s < self._deadline(v, now_s):  # heard since, or its turns grew longer
                self._queue(v)
                continue
            self._set(v, SUSPECT, now_s)
            suspected.append(v)
        return sorted(suspected)

    def confirm(self, sender: int, field: Heard, sent_s: float, now_s: float) -> list[int]:
        """Suspects whose silence ``sender``'s frame (sent at ``sent_s``) confirms: it was
        sent after the suspicion began, its heard window covers them, it says its sender has
        not heard them either, and both its sender and this vehicle should have (`Reach`).
        They are now lost. A suspect out of this vehicle's own reach stays suspected: its
        neighbours judge it, and take its work over (`policies.takeover`)."""
        never = set()
        for i in range(heard_window(self.n)):  # trailing "never" codes are left off the wire
            if i >= len(field.codes) or field.codes[i] == HEARD_NEVER:
                never.add((field.offset + i) % self.n)
        lost = []
        for v in sorted(never):
            p = self.peers.get(v)
            if (v == sender or p is None or p.status != SUSPECT or sent_s < p.since_s
                    or not self._judges(v, now_s)
                    or not self.reach.expects(sender, v, min(sent_s, self._fell_silent(v)))):
                continue
            p.witnesses.add(sender)
            if len(p.witnesses) + 1 >= OBSERVERS:
                self._set(v, LOST, now_s)
                lost.append(v)
        return lost

    def _judges(self, v: int, now_s: float) -> bool:
        """May this vehicle judge ``v``'s silence? Only if it heard ``v`` itself about as
        late as anyone did (within `RECENT_TURNS` turns of the latest evidence of it: ``v``
        was near in fact, not only believed near on old news while others heard it
        elsewhere), and ``v`` is within its reach as it believes (give or take a turn's
        travel when it took ``v``'s last frame itself)."""
        p = self.peers[v]
        recent = RECENT_TURNS * self.timing.turn_s(v, p.evidence_s)
        if p.direct_s < p.evidence_s - recent:
            return False
        # Where the suspect was when its silence began is its last pose reckoned for a turn
        # along a route believed from claims: at 100 vehicles (95 s turns) that put a
        # neighbour 763 m away at 1021 m, and it never judged. If this vehicle took the
        # suspect's last frame itself, it was near in fact a turn before: the reckoning may
        # be off by as far as the suspect travels in that turn.
        slack = self.timing.turn_s(v, p.evidence_s) if p.direct_s >= p.evidence_s else 0.0
        return self.reach.expects(self.me, v, min(now_s, self._fell_silent(v)), slack)

    def _fell_silent(self, v: int) -> float:
        """When ``v``'s first unheard frame was due: a turn after its latest evidence. Where
        it was then is what says who should have heard it (were it alive, it would not have
        gone far by its next slot; reckoned on to now, over the silence a large fleet's
        long cycles make, the guess drifts a kilometre from where it fell silent)."""
        p = self.peers[v]
        return p.evidence_s + self.timing.turn_s(v, p.evidence_s)

    def reception(self, now_s: float) -> float:
        """How much of what the peers send reaches this vehicle: frames taken per turn of
        theirs, averaged over the peers it has heard at all (one out of range sends nothing
        this vehicle could take), each counted until its last frame, so a silence being
        judged does not count against the link. A vehicle sends at least one frame per turn
        while working, so this is a lower bound on the link's delivery rate."""
        rates = []
        for v, p in self.peers.items():
            if p.first_s is None:
                continue
            until = now_s if p.status in WORKING else p.direct_s
            turns = (until - self.start_s) / self.timing.turn_s(v, until)
            if turns >= 4:  # too early to say anything
                rates.append(min(1.0, p.frames / turns))
        return sum(rates) / len(rates) if rates else 0.0

    def doubt(self, now_s: float) -> float:
        """Chance that a peer whose silence was just confirmed is alive and merely unheard:
        two observers (this vehicle and the confirmer) each missing ``lost_after_cycles``
        of its frames, at the reception rate this vehicle measures (`reception`). Small on a
        good link, near 1 on a bad one. The silence is counted as the detection window, not
        as however long it has lasted: losses at sea come in bursts (range, a reef between,
        a partition), and a long silence on a link that drops frames is no proof of death."""
        return (1.0 - self.reception(now_s)) ** (2.0 * self.lost_after_cycles)

    def suspects(self) -> list[int]:
        return [v for v in sorted(self._doubted) if self.peers[v].status == SUSPECT]

    def next_deadline_s(self) -> float | None:
        """When `check` could next find a silent peer (the silence thresholds as they stand
        now; `check` takes the schedule at the time it runs)."""
        while self._due:
            due, v = self._due[0]
            p = self.peers[v]
            if p.status != ALIVE:
                heapq.heappop(self._due)
                p.queued = False
                continue
            true = self._deadline(v, self._checked_s)
            if true <= due:
                return due
            heapq.heapreplace(self._due, (true, v))
        return None

    def heard_field(self, now_s: float) -> Heard:
        """What this vehicle tells the others: the `HEARD_AGES` code of its last direct
        hearing of each peer in a window of the roster; `HEARD_NEVER` for itself. The window
        starts at a peer within this vehicle's reach that it suspects or declared lost within
        a silence threshold (in turn, one per cycle), so that its silence reaches the others
        while they judge it; else it rotates (`wire.heard_offset`: every peer is covered
        every few cycles)."""
        n = self.n
        period = self.timing.cycle_s(now_s)
        cycle = int(now_s // period)
        offset = heard_offset(self.me, cycle, n)
        if n > heard_window(n):
            urgent = [v for v in sorted(self._doubted)  # suspected, or lost within a threshold
                      if (self.peers[v].status == SUSPECT
                          or now_s - self.peers[v].since_s <= self.lost_after_s(v, now_s))
                      and self._judges(v, now_s)]
            if urgent:
                offset = urgent[cycle % len(urgent)]
        codes = []
        for i in range(heard_window(n)):
            p = self.peers.get((offset + i) % n)
            code = HEARD_NEVER
            for c, age in enumerate(HEARD_AGES):
                if p is not None and now_s - p.direct_s <= age * period:
                    code = c
                    break
            codes.append(code)
        return Heard(offset, tuple(codes))

    def take_heard(self, sender: int, field: Heard, sent_s: float, now_s: float) -> list[int]:
        """Relayed evidence from a frame ``sender`` sent at ``sent_s``; the peers it revived."""
        revived = []
        period = self.timing.cycle_s(sent_s)
        for v, code in field.items(self.n):
            if v != sender and v in self.peers:
                if self.relayed(v, sent_s - HEARD_AGES[code] * period, now_s):
                    revived.append(v)
        return revived

    def snapshot(self) -> dict[int, tuple[str, float]]:
        return {v: (p.status, p.since_s) for v, p in self.peers.items()}
