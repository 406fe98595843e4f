"""When the agent sends: its TDMA slot, its sequence numbers, and the slot's message.

Slots: the fleet's schedule (`fleet_bus.tdma.SpatialSchedule`, the same arithmetic as the
water's TDMA MAC): every vehicle not parked owns a slot of every cycle, vehicles far apart
sharing one; with one slot per vehicle, vehicle ``i`` owns slot ``i`` of every cycle of
``n_vehicles * slot_s`` seconds. One frame per slot; a cycle is the heartbeat period. What
goes in a slot is the outbox's choice (`fleet_agent.outbox`: what the agent owes the fleet,
most urgent first).
"""

from __future__ import annotations

from dataclasses import dataclass

from fleet_agent.config import AgentConfig
from fleet_agent.knowledge import Knowledge
from fleet_agent.outbox import ABORTED, HOME, LADDER, MORE, Outbox, Slot
from fleet_agent.wire import Message
from fleet_bus.tdma import SpatialSchedule

SLOT_OFFSET = 0.05  # start this far into the slot (share of it): room for clock skew
# A host later than this share of a slot after its slot opened dates its frame back (a frame
# started now would spill into the next vehicle's slot); the operator paces on it too.
LATE_SHARE = 0.5
_NUDGE_S = 1e-3  # a seq + 1 exactly at an opening is of that turn (turns_before is strict)


@dataclass(frozen=True)
class Slots:
    """This vehicle's slots in the fleet's TDMA schedule: the fleet's spatial schedule
    (``plan``, `fleet_agent.fleet.Fleet.schedule`), or one slot per vehicle in index order."""

    index: int
    n_vehicles: int
    slot_s: float
    plan: SpatialSchedule | None = None

    @property
    def schedule(self) -> SpatialSchedule:
        return self.plan or SpatialSchedule.plain(self.n_vehicles, self.slot_s)

    @property
    def cycle_s(self) -> float:
        """The cycle at the mission start (everyone at the station: the longest, as a rule)."""
        return self.schedule.cycle_s(0.0)

    def next_from(self, t_s: float) -> float:
        """The first of this vehicle's slots (its send time) at or after ``t_s``."""
        return self.schedule.opening(self.index, t_s, SLOT_OFFSET)

    def latest_by(self, t_s: float) -> float | None:
        """The last of this vehicle's slots (its send time) at or before ``t_s``."""
        return self.schedule.latest(self.index, t_s, SLOT_OFFSET)

    def number(self, t_s: float) -> int:
        """How many of this vehicle's slots opened before ``t_s``."""
        return self.schedule.turns_before(self.index, t_s - SLOT_OFFSET * self.slot_s)

    def missed(self, opened_s: float, now_s: float) -> bool:
        """Too late to start the frame of the slot opened at ``opened_s`` now (a slow host):
        sent now it would spill into the next vehicle's slot, so it is dated at the slot's
        opening instead."""
        return now_s - opened_s > LATE_SHARE * self.slot_s

    def time(self, n: int) -> float:
        """This vehicle's send time (its slot's opening) of its turn ``n`` (0: its first)."""
        return self.schedule.nth_opening(self.index, n, SLOT_OFFSET)

    def cycle_of(self, seq: int) -> int:
        """The turn of a frame of this vehicle with sequence number ``seq`` (its send time in
        whole seconds: at most a second before its slot opens, bumped by a second per further
        frame of the slot, never reaching the next slot): the cycle its key belongs to
        (`fleet_bus.tesla`: chain index ``cycle + 1``). A vehicle's cycles are its own turns:
        with the spatial schedule they come at its own pace (every cycle, or every
        ``group``-th one parked), and every receiver counts them from the same schedule."""
        return max(0, self.schedule.turns_before(self.index, seq + 1.0 + _NUDGE_S
                                                 - SLOT_OFFSET * self.slot_s) - 1)

    def disclosure_s(self, cycle: int) -> float:
        """The earliest mission time this vehicle may disclose the key of ``cycle``: a frame
        of its next turn, whose seq can be a second before its slot opens. A frame of
        ``cycle`` heard after that proves nothing about who sent it."""
        return self.time(cycle + 1) - 1.0


class Radio:
    """The slot clock, the sequence numbers and the outbox."""

    def __init__(self, slots: Slots, config: AgentConfig, max_ids: int, now: float) -> None:
        self.slots, self.config = slots, config
        self.outbox = Outbox(config, max_ids)
        self._next = slots.next_from(now)
        # Own slots counted from the mission start (the outbox's refresh clocks): the slot
        # after the one last taken.
        self.slot_no = slots.number(self._next)
        self.last_seq = -1

    def next_slot_s(self) -> float:
        return self._next

    def take_slot(self, now: float) -> tuple[float, int]:
        """Take the latest of this vehicle's slots opened by ``now`` (call once ``now`` has
        reached `next_slot_s`). Returns the frame's send time and how many older slots went
        by unused. The send time is ``now`` in time; a host that ran late (frozen, starved of
        CPU) sends at once but dates the frame at the slot's opening, and the emulated channel
        puts it there (`fleet_bus.link.TxTag`): the water never sees the host's lag, and a
        late host is not heard as a silent vehicle (docs/fleet_agent.md)."""
        latest = self.slots.latest_by(now + 1e-9)
        assert latest is not None and latest >= self._next - 1e-6, "take_slot before the slot"
        taken = self.slots.number(latest + 1e-9)  # slots opened up to the one taken
        skipped = max(0, taken - 1 - self.slot_no)
        self.slot_no = taken
        self._next = self.slots.next_from(latest + 1e-6)
        late = self.slots.missed(latest, now)
        return (latest if late else now), skipped

    def next_seq(self, now: float) -> int:
        """Sequence numbers are send times in whole seconds, strictly increasing."""
        self.last_seq = max(self.last_seq + 1, int(now))
        return self.last_seq

    def message(self, now: float, know: Knowledge) -> Message | None:
        """The message for the slot just taken (None: nothing, a watcher keeping silent)."""
        msgs = self.messages(now, know, 1)
        return msgs[0] if msgs else None

    def messages(self, now: float, know: Knowledge, frames: int) -> list[Message]:
        """The messages for the slot just taken: the first by its ladder, then, if the modem
        carries more frames per transmission (a Micro-Modem PSK packet), whatever else is
        owed, never padding with poses."""
        own = know.own
        rules = ABORTED if own.aborted else HOME if own.done else LADDER
        slot = Slot(now, know.index, know.members.heard_field(now), know,
                    lambda: self.next_seq(now), self.slot_no)
        first = self.outbox.choose(rules, slot)
        out = [] if first is None else [first]
        while out and rules is LADDER and len(out) < frames:
            more = self.outbox.choose(MORE, slot)
            if more is None:
                break
            out.append(more)
        return out
