"""What the agent sends, and when: its TDMA slot and a typed outgoing buffer.

Slots: vehicle ``i`` owns slot ``i`` of every cycle of ``n_vehicles * slot_s`` seconds
(`fleet_bus.tdma`, the same arithmetic and order as the water's TDMA MAC), one frame per slot;
a cycle is the heartbeat period.

The buffer holds what is owed to the fleet, after Goby3's DynamicBuffer: typed entries, each
with the number of times it is still to be sent (its time to live in slots), in priority
order. `Radio.choose` picks one message per slot, most urgent first:

1. aborting: its own ABORT (``abort_repeats`` times), then one push of its cleared set;
2. home: a POSE saying so (``home_repeats`` times), then silence;
3. an ABORT it passes on (news of another vehicle's abort, once);
4. a POSE if the last one is ``pose_every_cycles`` slots old (the heartbeat);
5. pending CLAIM/RELEASE entries, oldest first, each ``claim_repeats`` times (spots cleared
   meanwhile are left out; an entry with nothing left is dropped);
6. the cleared set, one segment: after a local clear, when a peer's digest or segment shows
   it lacks something, or every ``cleared_refresh_cycles``;
7. standing claims again every ``claim_refresh_cycles`` (late joiners, loss);
8. else a POSE.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from fleet_agent.config import AgentConfig
from fleet_agent.knowledge import Knowledge
from fleet_agent.vehicle import Vehicle
from fleet_agent.wire import Abort, Claim, ClearedSegment, Message, Pose, Release
from fleet_bus.tdma import TdmaSchedule

SLOT_OFFSET = 0.05  # start this far into the slot (share of it): room for clock skew


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
        """Too late to start slot ``n``'s frame (a slow host): it would spill into the next
        vehicle's slot."""
        return now_s - self.time(n) > 0.5 * self.slot_s


@dataclass
class PendingHolding:
    """A claim or release still to be sent ``repeats`` more times."""

    cls: type[Claim] | type[Release]
    t_s: int
    tasks: tuple[int, ...]
    repeats: int


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

    @property
    def idle(self) -> bool:
        """Nothing announced is still owed (an aborted or home vehicle may fall silent)."""
        return self.own_abort_left == 0 and self.home_left == 0 and self.push_cleared == 0

    def next_slot_s(self) -> float:
        return self.slots.time(self.slot_no)

    def queue_holding(self, claim: bool, t_s: int, tasks: list[int]) -> None:
        """Owe the fleet a claim (or release) of ``tasks``, in frames of at most
        ``max_ids`` spots."""
        cls = Claim if claim else Release
        for i in range(0, len(tasks), self.max_ids):
            self.holdings.append(PendingHolding(cls, t_s, tuple(tasks[i:i + self.max_ids]),
                                                self.config.claim_repeats))

    def take_slot(self, now: float) -> bool:
        """True if ``now`` is in this vehicle's slot and not too late to use it; moves on to
        the next slot either way once the current one has begun."""
        if now < self.slots.time(self.slot_no):
            return False
        late = self.slots.missed(self.slot_no, now)
        self.slot_no = self.slots.first_from(now + 1e-9)
        return not late

    def next_seq(self, now: float) -> int:
        """Sequence numbers are send times in whole seconds, strictly increasing."""
        self.last_seq = max(self.last_seq + 1, int(now))
        return self.last_seq

    def choose(self, now: float, vehicle: Vehicle, know: Knowledge) -> Message | None:
        """One frame for the slot just taken, most urgent first (see the module docstring)."""
        cfg = self.config
        heard = know.members.heard_field(now)
        me = know.index
        if vehicle.aborted:
            if self.own_abort_left > 0:
                self.own_abort_left -= 1
                return Abort(me, self.next_seq(now), int(now), heard)
            if self.push_cleared > 0:
                self.push_cleared -= 1
                return self._cleared(now, know, heard)
            return None
        if vehicle.done:
            if self.home_left > 0:
                self.home_left -= 1
                return self._pose(now, vehicle, know, heard)
            return None
        self.since_pose += 1
        if self.aborts:
            news = self.aborts.popleft()
            return Abort(me, self.next_seq(now), news.t_s, heard, news.subject)
        if self.since_pose >= cfg.pose_every_cycles:
            return self._pose(now, vehicle, know, heard)
        if self.holdings:
            entry = self.holdings[0]
            tasks = tuple(t for t in entry.tasks if t not in know.cleared)
            entry.repeats -= 1
            if entry.repeats <= 0 or not tasks:
                self.holdings.popleft()
            if tasks:
                return entry.cls(me, self.next_seq(now), entry.t_s, tasks, heard)
        slot = self.slot_no  # the slot after the one taken: rotation and refresh clocks
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
                    self.queue_holding(True, c, tasks)
                entry = self.holdings.popleft()
                return entry.cls(me, self.next_seq(now), entry.t_s, entry.tasks, heard)
        return self._pose(now, vehicle, know, heard)

    def _pose(self, now: float, vehicle: Vehicle, know: Knowledge, heard: int) -> Pose:
        self.since_pose = 0
        return Pose(know.index, self.next_seq(now), vehicle.pos, int(round(vehicle.yaw_deg)),
                    vehicle.state(), know.cleared.digest(), heard)

    def _cleared(self, now: float, know: Knowledge, heard: int) -> ClearedSegment:
        # Rotate over segments; the one holding our latest clear goes first.
        cleared = know.cleared
        seg = cleared.segment_of(know.treated[-1][0]) if know.treated and self.push_cleared \
            else int(self.slot_no % cleared.n_segments)
        return ClearedSegment(know.index, self.next_seq(now), cleared.digest(), seg,
                              cleared.segment(seg), heard)
