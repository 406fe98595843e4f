"""What the agent owes the fleet, and which message goes in its next slot.

A typed outgoing buffer after Goby3's DynamicBuffer: the agent's parts `owe(kind, item)`
(claims, finds, pushes of the cleared set, news of an abort, ...) and the buffer keeps one
sub-buffer per kind, each entry with the number of times it is still to go out; the refresh
kinds (heartbeat poses, the cleared set, standing claims, known finds) come due on their own
periods. The slot's message is the first rule of `LADDER` (a working vehicle), `ABORTED` or
`HOME` that has one; the per-kind repeats and periods come from `kinds(config)`. Unlike Goby's
value-based choice the order is strict: a late claim is how two vehicles come to treat one
spot, so the claim rules must always win (docs/wire.md).

The ladder, most urgent first (a working vehicle):

1. a new claim, or an earlier claim of ours a peer contested by claiming the spot later: in
   the next slot, before a pose or news, since a vehicle works a spot it claimed late only once
   any earlier claim of it has had a cycle to arrive (`Knowledge.settled_s`). Two vehicles near
   a find once claimed it 5 s apart; the first claim waited 27 s behind a pose and a FOUND and
   both treated the find;
2. news of another vehicle's abort, passed on once;
3. a pose when the last one is ``pose_every_cycles`` slots old (the heartbeat);
4. a new find's first FOUND;
5. the first push of the cleared set owed after our own treatment: ahead of the repeats
   below, which churn can keep coming (a vehicle sent a claim, a release or a FOUND
   in every slot its pose left free, its pushes waited minutes, it aborted, and the spot it
   had treated was taken over and treated again: fault fuzz seeds 22 and 202);
6. the finds' anti-entropy when it has waited two refresh periods (claims cannot starve it);
7. a segment of the cleared set a claimant showed it lacks (it is on its way to a spot we
   know is cleared);
8. pending claims and releases, oldest first, each ``claim_repeats`` times (spots cleared
   meanwhile left out); then the rest of the pushes owed after our own treatment (on
   the hard reefs of issue 30, with finds made all the time, the finds' anti-entropy below
   took nearly every slot: one vehicle sent 5 segments in a mission, a peer missed 12 of its
   treatments, and a find both held was treated twice);
9. the repeats of new finds' FOUND (``find_repeats`` in all), after the claims: two finds in
   a row once held a claim back for 90 s, time enough for a peer to claim the same find;
10. the finds' anti-entropy: every known find once for a peer whose digest is unlike ours and
    whose count is not above ours, one soon for a peer with more (so it pushes to us), else
    one known find every ``find_refresh_cycles``;
11. the cleared set, one segment: when a peer may lack part of it, or every
    ``cleared_refresh_cycles``;
12. standing claims again every ``claim_refresh_cycles`` (late joiners, loss);
13. else the key the last frame (a pose) could not disclose (`fleet_bus.tesla`), else a pose.

An aborting vehicle sends its ABORT, a push of its cleared set, the ABORT's repeats
(``abort_repeats`` in all), then a second push (a peer takes its spots over on hearing the
ABORT); a vehicle home sends ``home_repeats`` poses. Either then keeps watch: a pose every
``watch_every_cycles`` slots (its heard codes confirm silences), or silence.
"""

from __future__ import annotations

import operator
from collections import deque
from dataclasses import dataclass
from enum import Enum
from typing import Callable, Sequence, SupportsIndex, cast

from fleet_agent.config import AgentConfig
from fleet_agent.knowledge import Knowledge
from fleet_agent.wire import (Abort, Claim, ClearedSegment, Digest, Found, Heard, Key,
                              Message, Pose, Release)


class Owed(Enum):
    """The kinds of thing an agent owes the fleet (one sub-buffer each)."""

    CLAIM = "claim"  # item: `Holding`, a new claim or release
    ANSWER = "answer"  # item: `Holding`, our earlier claim a peer contested (re-sent first)
    ABORT = "abort"  # item: `AbortNews`, another vehicle's abort, passed on once
    OWN_ABORT = "own_abort"  # item: None, our own abort (``abort_repeats`` times, two pushes)
    HOME = "home"  # item: None, our arrival home (``home_repeats`` poses)
    SEGMENT = "segment"  # item: segment index a claimant lacks
    CLEARED = "cleared"  # item: how many pushes of the cleared set are owed (it sets them)
    LACKS = "lacks"  # item: a peer that may lack part of our cleared set
    FIND = "find"  # item: the slot of a new own find (``find_repeats`` FOUNDs)
    FINDS = "finds"  # item: `FindsGap`, a peer's finds digest unlike ours


@dataclass(frozen=True)
class Holding:
    """Vehicle ``sender``'s claim (``claim``) or release of ``tasks`` made at ``t_s``."""

    claim: bool
    t_s: int
    tasks: tuple[int, ...]


@dataclass(frozen=True)
class AbortNews:
    """``subject`` aborted at ``t_s``."""

    subject: int
    t_s: int


@dataclass(frozen=True)
class FindsGap:
    """A peer's finds digest (``theirs``) unlike ours (``mine``, over the finds ``known``,
    the newest first: the order they are pushed in)."""

    theirs: Digest
    mine: Digest
    known: tuple[int, ...]


@dataclass(frozen=True)
class KindSpec:
    """One row of the buffer's configuration: how many times an entry goes out, and how
    many slots a refresh of the kind waits (0: the kind is not refreshed)."""

    repeats: int = 1
    refresh_slots: int = 0


def kinds(config: AgentConfig) -> dict[str, KindSpec]:
    """The per-kind table, from the agent's configuration."""
    return {
        "claim": KindSpec(config.claim_repeats, config.claim_refresh_cycles),
        "find": KindSpec(config.find_repeats, config.find_refresh_cycles),
        "cleared": KindSpec(1, config.cleared_refresh_cycles),
        "pose": KindSpec(1, config.pose_every_cycles),
        "watch": KindSpec(1, config.watch_every_cycles),
        "own_abort": KindSpec(config.abort_repeats),
        "home": KindSpec(config.home_repeats),
    }


@dataclass
class _Pending:
    """An owed claim or release with the sends still due; ``fresh``: not on the air yet (a
    new claim, or an answer), so it goes first."""

    holding: Holding
    left: int
    fresh: bool = False


@dataclass(frozen=True)
class Slot:
    """What a rule needs to build the slot's message."""

    now: float
    me: int
    heard: Heard
    know: Knowledge
    seq: Callable[[], int]  # the next sequence number (taken only for a message sent)
    number: int  # the slot after the one taken: rotation and refresh clocks


Rule = Callable[["Outbox", Slot], "Message | None"]


def _whole(kind: Owed, item: object) -> int:
    """The index or count a kind of `Owed` takes (a numpy integer too); anything else is the
    caller's bug, said at once rather than queued."""
    try:  # not isinstance(item, SupportsIndex): a runtime protocol check costs ten times more
        return operator.index(cast(SupportsIndex, item))
    except TypeError:
        raise TypeError(f"{kind.name} owes an index or a count, got {item!r}") from None


class Outbox:
    """The sub-buffers and the choice of one message per slot (module docstring)."""

    def __init__(self, config: AgentConfig, max_ids: int) -> None:
        self.spec = kinds(config)
        self.max_ids = max_ids  # spots one claim frame carries (the codec's budget)
        self.since_pose = 10**6  # own slots since the last pose
        self.holdings: deque[_Pending] = deque()
        self._aborts: deque[AbortNews] = deque()
        self._own_abort_left = 0
        self._home_left = 0
        self._cleared_pushes = 0
        self._cleared_fresh = False  # the first of the owed pushes has not gone out yet
        self._lacking: set[int] = set()  # peers that may lack part of our cleared set
        self.segments: deque[int] = deque()  # segments a claimant showed it lacks
        self._segment_turn = 0  # rotation over the cleared set's segments, one per push
        self._finds_new: deque[int] = deque()  # slots of new own finds, one entry per send
        self._finds_owed: deque[int] = deque()  # finds a peer may lack, to push once each
        self._finds_asked = False  # a peer with more finds: send one so that it pushes
        self._found_rr = 0
        self._last_cleared_slot = 0
        self._last_claims_slot = 0
        self._last_found_slot = 0
        # The last frame disclosed no key (a pose has no room for one): the next slot with
        # nothing else to say sends one, or the pose's sender stays unproven (`tesla`).
        self.undisclosed = False

    @property
    def idle(self) -> bool:
        """Nothing announced is still owed (an aborted or home vehicle may fall silent)."""
        return self._own_abort_left == 0 and self._home_left == 0 and self._cleared_pushes == 0

    def owe(self, kind: Owed, item: object = None) -> None:
        """Owe the fleet ``item`` of ``kind`` (see `Owed` for what each kind takes)."""
        if kind in (Owed.CLAIM, Owed.ANSWER):
            assert isinstance(item, Holding)
            (self._queue if kind is Owed.CLAIM else self._answer)(item)
        elif kind is Owed.ABORT:
            assert isinstance(item, AbortNews)
            self._aborts.append(item)
        elif kind is Owed.OWN_ABORT:
            # Its last words: the ABORT, and its cleared set before and after it (`ABORTED`).
            self._own_abort_left = self.spec["own_abort"].repeats
            self.owe(Owed.CLEARED, 2)
        elif kind is Owed.HOME:
            self._home_left = self.spec["home"].repeats
        elif kind is Owed.SEGMENT:
            if item not in self.segments:
                self.segments.append(_whole(kind, item))
        elif kind is Owed.CLEARED:
            # Never fewer than already owed: an abort owing one push once took back the two
            # owed for the treatment just before it.
            self._cleared_pushes = max(self._cleared_pushes, _whole(kind, item))
            self._cleared_fresh = True
        elif kind is Owed.LACKS:
            self._lacking.add(_whole(kind, item))
        elif kind is Owed.FIND:
            self._finds_new.extend([_whole(kind, item)] * self.spec["find"].repeats)
        elif kind is Owed.FINDS:
            assert isinstance(item, FindsGap)
            self._owe_finds(item)

    def choose(self, rules: Sequence[Rule], slot: Slot) -> Message | None:
        """The slot's message: the first of ``rules`` that has one."""
        for rule in rules:
            msg = rule(self, slot)
            if msg is not None:
                self.undisclosed = isinstance(msg, Pose)
                return msg
        return None

    # -- claims and releases ---------------------------------------------------------------

    def _queue(self, h: Holding, fresh: bool = True) -> None:
        """In frames of at most ``max_ids`` spots; a new claim goes out in the next slot."""
        repeats = self.spec["claim"].repeats
        for i in range(0, len(h.tasks), self.max_ids):
            part = Holding(h.claim, h.t_s, h.tasks[i:i + self.max_ids])
            self.holdings.append(_Pending(part, repeats, fresh and h.claim))

    def _answer(self, h: Holding) -> None:
        """Our claim of ``h.tasks`` (made at ``h.t_s``) goes out next: a peer claimed them
        later, so it missed ours and is on its way. Pending sends of it move to the front
        (older entries can hold it back for minutes); if none is left, it is owed again."""
        wanted = set(h.tasks)
        front = [e for e in self.holdings if e.holding.claim and e.holding.t_s == h.t_s
                 and wanted & set(e.holding.tasks)]
        for e in front:
            self.holdings.remove(e)
            e.fresh = True
        covered = {t for e in front for t in e.holding.tasks}
        rest = tuple(t for t in h.tasks if t not in covered)
        repeats = self.spec["claim"].repeats
        for i in range(0, len(rest), self.max_ids):
            front.append(_Pending(Holding(True, h.t_s, rest[i:i + self.max_ids]), repeats, True))
        self.holdings.extendleft(reversed(front))

    def _send_holding(self, entry: _Pending, s: Slot) -> Message | None:
        """One send of ``entry``, spots cleared meanwhile left out; None if none is left."""
        tasks = tuple(t for t in entry.holding.tasks if t not in s.know.cleared)
        entry.left -= 1
        if entry.left <= 0 or not tasks:
            self.holdings.remove(entry)
        if not tasks:
            return None
        cls = Claim if entry.holding.claim else Release
        return cls(s.me, s.seq(), entry.holding.t_s, tasks, s.heard)

    def claim_first(self, s: Slot) -> Message | None:
        for entry in list(self.holdings):
            if entry.fresh:
                entry.fresh = False
                msg = self._send_holding(entry, s)
                if msg is not None:
                    return msg
        return None

    def claim_repeat(self, s: Slot) -> Message | None:
        return self._send_holding(self.holdings[0], s) if self.holdings else None

    def claims_due(self, s: Slot) -> Message | None:
        """Standing claims again (late joiners, loss), grouped by claim time."""
        if s.number - self._last_claims_slot < self.spec["claim"].refresh_slots:
            return None
        self._last_claims_slot = s.number
        standing = s.know.standing_claims()
        if not standing:
            return None
        by_time: dict[int, list[int]] = {}
        for t, c in sorted(standing.items()):
            by_time.setdefault(c, []).append(t)
        for c, tasks in by_time.items():
            self._queue(Holding(True, c, tuple(tasks)), fresh=False)
        h = self.holdings.popleft().holding
        return (Claim if h.claim else Release)(s.me, s.seq(), h.t_s, h.tasks, s.heard)

    # -- aborts and announcements ----------------------------------------------------------

    def abort_news(self, s: Slot) -> Message | None:
        if not self._aborts:
            return None
        news = self._aborts.popleft()
        return Abort(s.me, s.seq(), news.t_s, s.heard, news.subject)

    def own_abort_first(self, s: Slot) -> Message | None:
        """An aborting vehicle's first ABORT, before anything it owes (`ABORTED`)."""
        return self.own_abort(s) if self._own_abort_left == self.spec["own_abort"].repeats \
            else None

    def own_abort(self, s: Slot) -> Message | None:
        if self._own_abort_left <= 0:
            return None
        self._own_abort_left -= 1
        return Abort(s.me, s.seq(), int(s.now), s.heard)

    def home(self, s: Slot) -> Message | None:
        if self._home_left <= 0:
            return None
        self._home_left -= 1
        return self.pose(s)

    # -- poses -------------------------------------------------------------------------------

    def pose(self, s: Slot) -> Pose:
        self.since_pose = 0
        own = s.know.own
        return Pose(s.me, s.seq(), own.pos, int(round(own.yaw_deg)), own.state(),
                    s.know.cleared.digest(), s.heard)

    def pose_due(self, s: Slot) -> Message | None:
        return self.pose(s) if self.since_pose >= self.spec["pose"].refresh_slots else None

    def key_or_pose(self, s: Slot) -> Message:
        """Nothing else to say: the key the last pose could not disclose, else a pose."""
        return Key(s.me, s.seq(), s.heard) if self.undisclosed else self.pose(s)

    def watch(self, s: Slot) -> Message | None:
        """Out of the mission, announcements done: a pose now and then, if keeping watch,
        and the key it could not disclose (its heard codes confirm silences only once its
        sender is proven)."""
        every = self.spec["watch"].refresh_slots
        self.since_pose += 1
        if self.undisclosed:
            return Key(s.me, s.seq(), s.heard)
        return self.pose(s) if every and self.since_pose >= every else None

    def count_slot(self, s: Slot) -> None:
        """Not a message: a working vehicle's slot went by (the heartbeat's clock)."""
        self.since_pose += 1
        return None

    # -- the cleared set ---------------------------------------------------------------------

    def segment_owed(self, s: Slot) -> Message | None:
        return self._cleared(s, self.segments.popleft()) if self.segments else None

    def cleared_due(self, s: Slot) -> Message | None:
        if not (self._cleared_pushes > 0 or self._lacking
                or s.number - self._last_cleared_slot >= self.spec["cleared"].refresh_slots):
            return None
        self._cleared_pushes = max(0, self._cleared_pushes - 1)
        self._lacking.clear()
        self._last_cleared_slot = s.number
        return self._cleared(s) if len(s.know.cleared) else None

    def cleared_first(self, s: Slot) -> Message | None:
        """The first of the pushes owed (after a treatment, an abort): before the repeats of
        claims and releases. Why: a vehicle whose route churned sent a claim, a release or a
        FOUND in every slot a pose left free, and its pushes waited behind them for minutes;
        it treated a spot, aborted 92 s later, and the peer that took its spots over treated
        that one again (fault fuzz seed 22 with climbs for a fix; seed 202 without)."""
        if not self._cleared_fresh:
            return None
        self._cleared_fresh = False
        return self.cleared_pushed(s)

    def cleared_pushed(self, s: Slot) -> Message | None:
        """What this vehicle owes of its cleared set: after its own treatment (before the
        finds' anti-entropy and repeats: on a reef of many finds their digests rarely agree,
        and a treatment heard late is a spot treated twice, issue 30), or aborting."""
        if self._cleared_pushes <= 0:
            return None
        msg = self._cleared(s)  # while still owed: the segment of our latest treatment
        self._cleared_pushes -= 1
        return msg

    def _cleared(self, s: Slot, seg: int | None = None) -> ClearedSegment:
        # Rotate over segments; the one holding our latest clear goes first. The rotation
        # counts pushes, not slots: poses take every other slot, so a slot-number rotation
        # over two segments would push the same one forever.
        cleared = s.know.cleared
        if seg is None and s.know.treated and self._cleared_pushes:
            seg = cleared.segment_of(s.know.treated[-1][0])
        elif seg is None:
            seg = self._segment_turn % cleared.n_segments
            self._segment_turn += 1
        return ClearedSegment(s.me, s.seq(), cleared.digest(), seg, cleared.segment(seg),
                              s.heard)

    # -- finds -------------------------------------------------------------------------------

    def _owe_finds(self, gap: FindsGap) -> None:
        """A peer's finds digest differs from ours. If it may lack some of ours (a smaller or
        equal count), owe it every find we know, once each; if it has more, send one soon so
        that our digest makes it push to us."""
        behind = (gap.mine.count - gap.theirs.count) % 128
        if behind == 0 or behind < 64:
            # The newest first: a peer that lacks finds lacks the newest most likely, and they
            # lie where the fleet works now (hard seed 9 at 30 % loss: a find treated at
            # 3181 s reached a peer at 3251 s, after eight older ones, and it was treated
            # again under the peer's name).
            queued = set(self._finds_owed)
            self._finds_owed.extend(s for s in gap.known if s not in queued)
        else:
            self._finds_asked = True

    def find_first(self, s: Slot) -> Message | None:
        return self._new_find(s, repeats=False)

    def find_repeat(self, s: Slot) -> Message | None:
        return self._new_find(s, repeats=True)

    def _new_find(self, s: Slot, repeats: bool) -> Message | None:
        """The next FOUND owed for a new own find: only a first announcement (a slot still
        queued all ``find_repeats`` times) unless ``repeats`` (they come after claims)."""
        finds = s.know.beliefs.finds
        for slot_no in list(self._finds_new):
            if slot_no not in finds:
                self._finds_new.remove(slot_no)
            elif repeats or self._finds_new.count(slot_no) == self.spec["find"].repeats:
                self._finds_new.remove(slot_no)
                return self._found(s, slot_no)
        return None

    def finds_starved(self, s: Slot) -> Message | None:
        every = self.spec["find"].refresh_slots
        if not s.know.beliefs.finds or s.number - self._last_found_slot < 2 * every:
            return None
        return self._found_refresh(s)

    def finds_due(self, s: Slot) -> Message | None:
        every = self.spec["find"].refresh_slots
        if not s.know.beliefs.finds or not (self._finds_owed or self._finds_asked
                                            or s.number - self._last_found_slot >= every):
            return None
        return self._found_refresh(s)

    def _found_refresh(self, s: Slot) -> Found:
        """A find a peer may lack, else one known find, round robin (anti-entropy: every
        FOUND carries our digest)."""
        finds = s.know.beliefs.finds
        self._finds_asked = False
        self._last_found_slot = s.number
        while self._finds_owed:
            slot = self._finds_owed.popleft()
            if slot in finds:
                return self._found(s, slot)
        known = sorted(finds)
        self._found_rr += 1
        return self._found(s, known[self._found_rr % len(known)])

    def _found(self, s: Slot, slot: int) -> Found:
        b = s.know.beliefs
        f = b.finds[slot]
        return Found(s.me, s.seq(), b.digest(), slot, f.pos, f.priority, f.service_s, s.heard,
                     f.sigma_m)


# The ladders (module docstring), as tables of rules.
LADDER: tuple[Rule, ...] = (
    Outbox.count_slot, Outbox.claim_first, Outbox.abort_news, Outbox.pose_due, Outbox.find_first,
    Outbox.cleared_first, Outbox.finds_starved, Outbox.segment_owed, Outbox.claim_repeat,
    Outbox.cleared_pushed, Outbox.find_repeat, Outbox.finds_due, Outbox.cleared_due,
    Outbox.claims_due, Outbox.key_or_pose,
)
# The further frames of a transmission that carries several: what is owed, no heartbeat.
MORE: tuple[Rule, ...] = LADDER[1:-1]
# An aborting vehicle's first push goes right after its first ABORT, not after all of them:
# a peer takes its spots over on hearing the ABORT, and one it treated last, its clear unheard,
# would be treated again; the taker is still on its way when the push comes a slot later.
ABORTED: tuple[Rule, ...] = (Outbox.own_abort_first, Outbox.cleared_first, Outbox.own_abort,
                             Outbox.cleared_pushed, Outbox.watch)
HOME: tuple[Rule, ...] = (Outbox.home, Outbox.watch)
