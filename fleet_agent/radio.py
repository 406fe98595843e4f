"""What the agent sends, and when: its TDMA slot and a typed outgoing buffer.

Slots: vehicle ``i`` owns slot ``i`` of every cycle of ``n_vehicles * slot_s`` seconds
(`fleet_bus.tdma`, the same arithmetic and order as the water's TDMA MAC), one frame per slot;
a cycle is the heartbeat period.

The buffer holds what is owed to the fleet, after Goby3's DynamicBuffer: typed entries, each
with the number of times it is still to be sent (its time to live in slots), in priority
order. `Radio.choose` picks one message per slot, most urgent first:

1. aborting: its own ABORT (``abort_repeats`` times), then one push of its cleared set;
2. home: a POSE saying so (``home_repeats`` times); then, aborted or home, a POSE every
   ``watch_every_cycles`` slots (keeping watch: its heard codes confirm silences) or silence;
3. the first send of a new CLAIM (or of one a peer contested, `Agent._contest`): in the next
   slot, before a pose or news, since a vehicle works a spot it claimed late only once any
   earlier claim of it has had a cycle to arrive (`Knowledge.settled_s`). Two vehicles near
   a find once claimed it 5 s apart; the first claim waited 27 s behind a pose and a FOUND
   and both treated the find;
3a. an ABORT it passes on (news of another vehicle's abort, once);
4. a POSE if the last one is ``pose_every_cycles`` slots old (the heartbeat);
5. a new find of this vehicle (dynamic missions): its first FOUND;
6. a segment of the cleared set owed to a peer that claimed a spot in it we know is cleared,
   then pending CLAIM/RELEASE entries, oldest first, each ``claim_repeats`` times (spots
   cleared meanwhile are left out; an entry with nothing left is dropped); a claim a peer
   contests by claiming the spot later is queued again (`Agent._contest`);
6a. the repeats of new finds' FOUND (``find_repeats`` in all). After the first, a find's
   repeats wait for the claims: two finds in a row once held a claim back for 90 s, time
   enough for a peer to claim the same find and treat it too;
6b. the finds' anti-entropy (dynamic missions; ahead of 6 when it has waited two refresh
   periods, so claims cannot starve it): every known find once when a peer's FOUND shows a
   digest unlike ours and a count not above ours (it may lack some), one find when its count
   is above ours (so it pushes to us), else one known find (round robin) every
   ``find_refresh_cycles``: finds are a grow-only map, so loss, duplication and reordering
   can only delay one;
7. the cleared set, one segment: after a local clear, when a peer's digest or segment shows
   it lacks something, or every ``cleared_refresh_cycles``;
8. standing claims again every ``claim_refresh_cycles`` (late joiners, loss);
9. else a POSE.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from fleet_agent.config import AgentConfig
from fleet_agent.knowledge import Knowledge
from fleet_agent.motion import OwnVehicle
from fleet_agent.wire import (Abort, Claim, ClearedSegment, Digest, Found, Heard, Message,
                              Pose, Release)
from fleet_bus.tdma import TdmaSchedule

SLOT_OFFSET = 0.05  # start this far into the slot (share of it): room for clock skew
# A host later than this share of a slot after its slot opened dates its frame back (a frame
# started now would spill into the next vehicle's slot); the operator paces on it too.
LATE_SHARE = 0.5


@dataclass(frozen=True)
class Slots:
    """This vehicle's slots in the fleet's TDMA schedule."""

    index: int
    n_vehicles: int
    slot_s: float

    @property
    def schedule(self) -> TdmaSchedule:
        return TdmaSchedule(self.n_vehicles, self.slot_s)

    @property
    def cycle_s(self) -> float:
        return self.schedule.cycle_s

    def time(self, n: int) -> float:
        """Start of this vehicle's slot in cycle ``n``."""
        return self.schedule.opens(self.index, n, SLOT_OFFSET)

    def first_from(self, t_s: float) -> int:
        """The first cycle whose slot starts at or after ``t_s``."""
        return self.schedule.first_cycle(self.index, t_s, SLOT_OFFSET)

    def missed(self, n: int, now_s: float) -> bool:
        """Too late to start slot ``n``'s frame now (a slow host): sent now it would spill into
        the next vehicle's slot, so it is dated at the slot's opening instead."""
        return now_s - self.time(n) > LATE_SHARE * self.slot_s


@dataclass
class PendingHolding:
    """A claim or release still to be sent ``repeats`` more times; ``fresh``: a claim not on
    the air yet that may be contested (new, or an answer), sent before anything else."""

    cls: type[Claim] | type[Release]
    t_s: int
    tasks: tuple[int, ...]
    repeats: int
    fresh: bool = False


@dataclass(frozen=True)
class PendingAbort:
    """News of ``subject``'s abort at ``t_s``, to pass on once."""

    subject: int
    t_s: int


class Radio:
    """The slot clock, the outgoing buffer and the choice of one message per slot."""

    def __init__(self, slots: Slots, config: AgentConfig, max_ids: int, now: float) -> None:
        self.slots, self.config, self.max_ids = slots, config, max_ids
        self.slot_no = slots.first_from(now)
        self.last_seq = -1
        self.since_pose = 10**6
        self.holdings: deque[PendingHolding] = deque()
        self.aborts: deque[PendingAbort] = deque()
        self.own_abort_left = 0
        self.home_left = 0
        self.push_cleared = 0  # full-state pushes of the cleared set still owed
        self.mismatch: set[int] = set()  # peers that may lack part of our cleared set
        self._last_refresh_slot = 0
        self._last_claim_refresh_slot = 0
        self._segment_turn = 0  # rotation over the cleared set's segments, one per push
        self.segments_owed: deque[int] = deque()  # segments a claimant showed it lacks
        self.finds_new: deque[int] = deque()  # slots of new own finds, one entry per send
        self.finds_owed: deque[int] = deque()  # finds a peer may lack, to push once each
        self.finds_mismatch = False  # a peer's finds digest differs from ours
        self._last_found_refresh_slot = 0
        self._found_rr = 0

    @property
    def idle(self) -> bool:
        """Nothing announced is still owed (an aborted or home vehicle may fall silent)."""
        return self.own_abort_left == 0 and self.home_left == 0 and self.push_cleared == 0

    def next_slot_s(self) -> float:
        return self.slots.time(self.slot_no)

    def queue_holding(self, claim: bool, t_s: int, tasks: list[int],
                      fresh: bool = True) -> None:
        """Owe the fleet a claim (or release) of ``tasks``, in frames of at most
        ``max_ids`` spots; a new claim (``fresh``) goes out in the next slot."""
        cls = Claim if claim else Release
        for i in range(0, len(tasks), self.max_ids):
            self.holdings.append(PendingHolding(cls, t_s, tuple(tasks[i:i + self.max_ids]),
                                                self.config.claim_repeats, fresh and claim))

    def answer_claim(self, t_s: int, tasks: list[int]) -> None:
        """Our claim of ``tasks`` (made at ``t_s``) goes out next: a peer claimed them later,
        so it missed ours and is on its way. Pending sends of it move to the front of the
        buffer (older entries can hold it back for minutes); if none is left, it is owed
        again."""
        wanted = set(tasks)
        front = [e for e in self.holdings if e.cls is Claim and e.t_s == t_s
                 and wanted & set(e.tasks)]
        for e in front:
            self.holdings.remove(e)
            e.fresh = True
        covered = {t for e in front for t in e.tasks}
        rest = [t for t in tasks if t not in covered]
        for i in range(0, len(rest), self.max_ids):
            front.append(PendingHolding(Claim, t_s, tuple(rest[i:i + self.max_ids]),
                                        self.config.claim_repeats, True))
        self.holdings.extendleft(reversed(front))

    def answer_cleared(self, segments: set[int]) -> None:
        """Owe the fleet these segments of the cleared set (a peer claimed a cleared spot)."""
        self.segments_owed.extend(s for s in sorted(segments) if s not in self.segments_owed)

    def take_slot(self, now: float) -> tuple[float, int]:
        """Take the latest of this vehicle's slots opened by ``now`` (call once ``now`` has
        reached `next_slot_s`). Returns the frame's send time and how many older slots went
        by unused. The send time is ``now`` in time; a host that ran late (frozen, starved of
        CPU) sends at once but dates the frame at the slot's opening, and the emulated channel
        puts it there (`fleet_bus.link.TxTag`): the water never sees the host's lag, and a
        late host is not heard as a silent vehicle (docs/fleet_agent.md)."""
        latest = self.slots.first_from(now + 1e-9) - 1  # its opening is at or before now
        skipped = max(0, latest - self.slot_no)
        self.slot_no = latest + 1
        late = self.slots.missed(latest, now)
        return (self.slots.time(latest) if late else now), skipped

    def next_seq(self, now: float) -> int:
        """Sequence numbers are send times in whole seconds, strictly increasing."""
        self.last_seq = max(self.last_seq + 1, int(now))
        return self.last_seq

    def choose(self, now: float, own: OwnVehicle, know: Knowledge) -> Message | None:
        """One frame for the slot just taken, most urgent first (see the module docstring)."""
        cfg = self.config
        heard = know.members.heard_field(now)
        me = know.index
        if own.aborted:
            if self.own_abort_left > 0:
                self.own_abort_left -= 1
                return Abort(me, self.next_seq(now), int(now), heard)
            if self.push_cleared > 0:
                self.push_cleared -= 1
                return self._cleared(now, know, heard)
            return self._watch(now, own, know, heard)
        if own.done:
            if self.home_left > 0:
                self.home_left -= 1
                return self._pose(now, own, know, heard)
            return self._watch(now, own, know, heard)
        self.since_pose += 1
        fresh = self._fresh_claim(now, know, heard)
        if fresh is not None:
            return fresh
        if self.aborts:
            news = self.aborts.popleft()
            return Abort(me, self.next_seq(now), news.t_s, heard, news.subject)
        if self.since_pose >= cfg.pose_every_cycles:
            return self._pose(now, own, know, heard)
        beliefs = know.beliefs
        first = self._new_find(now, know, heard, repeats=False)
        if first is not None:
            return first
        # Claims first (a late claim is how two vehicles come to treat one spot), unless the
        # finds' anti-entropy has waited two refresh periods: it must not starve either.
        starving = self.slot_no - self._last_found_refresh_slot >= 2 * cfg.find_refresh_cycles
        if beliefs is not None and beliefs.finds and starving:
            return self._found_refresh(now, know, heard)
        if self.segments_owed:  # as urgent as a claim: the claimant is on its way
            return self._cleared(now, know, heard, self.segments_owed.popleft())
        if self.holdings:
            entry = self.holdings[0]
            tasks = tuple(t for t in entry.tasks if t not in know.cleared)
            entry.repeats -= 1
            if entry.repeats <= 0 or not tasks:
                self.holdings.popleft()
            if tasks:
                return entry.cls(me, self.next_seq(now), entry.t_s, tasks, heard)
        repeat = self._new_find(now, know, heard, repeats=True)
        if repeat is not None:
            return repeat
        slot = self.slot_no  # the slot after the one taken: rotation and refresh clocks
        if beliefs is not None and beliefs.finds and (
                self.finds_owed or self.finds_mismatch
                or slot - self._last_found_refresh_slot >= cfg.find_refresh_cycles):
            return self._found_refresh(now, know, heard)
        if self.push_cleared > 0 or self.mismatch or \
                slot - self._last_refresh_slot >= cfg.cleared_refresh_cycles:
            self.push_cleared = max(0, self.push_cleared - 1)
            self.mismatch.clear()
            self._last_refresh_slot = slot
            if len(know.cleared):
                return self._cleared(now, know, heard)
        if slot - self._last_claim_refresh_slot >= cfg.claim_refresh_cycles:
            self._last_claim_refresh_slot = slot
            standing = know.standing_claims()
            if standing:
                by_time: dict[int, list[int]] = {}
                for t, c in sorted(standing.items()):
                    by_time.setdefault(c, []).append(t)
                for c, tasks in by_time.items():
                    self.queue_holding(True, c, tasks, fresh=False)
                entry = self.holdings.popleft()
                return entry.cls(me, self.next_seq(now), entry.t_s, entry.tasks, heard)
        return self._pose(now, own, know, heard)

    def _fresh_claim(self, now: float, know: Knowledge, heard: Heard) -> Claim | None:
        """A claim not on the air yet, before a pose, a find or news: a vehicle that claimed
        a spot waits only `Knowledge.settled_s` before working it, which counts on every
        claim going out in its claimer's next slot."""
        for entry in list(self.holdings):
            if not entry.fresh:
                continue
            entry.fresh = False
            tasks = tuple(t for t in entry.tasks if t not in know.cleared)
            entry.repeats -= 1
            if entry.repeats <= 0 or not tasks:
                self.holdings.remove(entry)
            if tasks:
                return Claim(know.index, self.next_seq(now), entry.t_s, tasks, heard)
        return None

    def queue_find(self, slot: int) -> None:
        """Announce a new own find ``find_repeats`` times."""
        self.finds_new.extend([slot] * self.config.find_repeats)

    def _new_find(self, now: float, know: Knowledge, heard: Heard, repeats: bool
                  ) -> Found | None:
        """The next FOUND owed for a new own find: only a first announcement (a slot still
        queued all ``find_repeats`` times) unless ``repeats`` (they come after claims)."""
        beliefs = know.beliefs
        if beliefs is None:
            return None
        for slot_no in list(self.finds_new):
            if slot_no not in beliefs.finds:
                self.finds_new.remove(slot_no)
            elif repeats or self.finds_new.count(slot_no) == self.config.find_repeats:
                self.finds_new.remove(slot_no)
                return self._found(now, know, heard, slot_no)
        return None

    def _watch(self, now: float, own: OwnVehicle, know: Knowledge, heard: Heard) -> Pose | None:
        """Out of the mission, announcements done: a pose now and then, if keeping watch."""
        every = self.config.watch_every_cycles
        self.since_pose += 1
        if every and self.since_pose >= every:
            return self._pose(now, own, know, heard)
        return None

    def _pose(self, now: float, own: OwnVehicle, know: Knowledge, heard: Heard) -> Pose:
        self.since_pose = 0
        return Pose(know.index, self.next_seq(now), own.pos, int(round(own.yaw_deg)),
                    own.state(), know.cleared.digest(), heard)

    def owe_finds(self, know: Knowledge, peer_digest: Digest) -> None:
        """A peer's finds digest differs from ours. If it may lack some of ours (a smaller or
        equal count), owe it every find we know, once each; if it has more, send one soon so
        that our digest makes it push to us."""
        b = know.beliefs
        if b is None:
            return
        behind = (b.digest().count - peer_digest.count) % 128
        if behind == 0 or behind < 64:
            queued = set(self.finds_owed)
            self.finds_owed.extend(s for s in sorted(b.finds) if s not in queued)
        else:
            self.finds_mismatch = True

    def _found_refresh(self, now: float, know: Knowledge, heard: Heard) -> Found:
        """A find a peer may lack, else one known find, round robin (anti-entropy: every
        FOUND carries our digest)."""
        assert know.beliefs is not None
        self.finds_mismatch = False
        self._last_found_refresh_slot = self.slot_no
        while self.finds_owed:
            slot = self.finds_owed.popleft()
            if slot in know.beliefs.finds:
                return self._found(now, know, heard, slot)
        known = sorted(know.beliefs.finds)
        self._found_rr += 1
        return self._found(now, know, heard, known[self._found_rr % len(known)])

    def _found(self, now: float, know: Knowledge, heard: Heard, slot: int) -> Found:
        assert know.beliefs is not None
        f = know.beliefs.finds[slot]
        return Found(know.index, self.next_seq(now), know.beliefs.digest(), slot, f.pos,
                     f.priority, f.service_s, heard)

    def _cleared(self, now: float, know: Knowledge, heard: Heard,
                 seg: int | None = None) -> ClearedSegment:
        # Rotate over segments; the one holding our latest clear goes first. The rotation
        # counts pushes, not slots: poses take every other slot, so a slot-number rotation
        # over two segments would push the same one forever.
        cleared = know.cleared
        if seg is None and know.treated and self.push_cleared:
            seg = cleared.segment_of(know.treated[-1][0])
        elif seg is None:
            seg = self._segment_turn % cleared.n_segments
            self._segment_turn += 1
        return ClearedSegment(know.index, self.next_seq(now), cleared.digest(), seg,
                              cleared.segment(seg), heard)
