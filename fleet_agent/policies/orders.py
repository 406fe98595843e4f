"""The operator's live orders under water: proven, taken once, acted on, acknowledged, passed on.

An order comes off the modem in a topside ORDER frame (`fleet_bus.orders`), from the boat or
passed on by a peer. It is held until the topside discloses the key of the frame's interval
(TESLA, `fleet_bus.tesla`: the topside's chain, whose commitment every vehicle knows), then:

- refused and counted (``ctl_<reason>``) when its tag is not the topside's (``unsigned``:
  whatever an insider holding the fleet key makes), when it was heard after its key could be
  out (``replayed``: a recording played back proves nothing), when it was issued more than
  ``ctl_max_age_s`` ago (``stale``), or when its spot is not one of the mission's;
- not acted on twice: every order number taken is journalled (``"k": "ord"``), so a repeat (the
  topside's retransmission, a peer passing it on, a restarted agent hearing it again) is only
  acknowledged again and counted (``ctl_repeat``);
- acted on when it names this vehicle or all: ``recall`` goes home now, announced as an abort
  is (peers take its spots over as after an abort) and said as a recall; ``abort`` is the
  operator's abort; ``pause`` keeps station (`policies.navigation`'s hold) until ``resume``;
  ``drop-spot`` marks the spot done for everyone, never treated; ``add-spot`` puts the spot
  in the operator's slot its number names (`Order.added`; `beliefs`: the same task index on
  every vehicle, so the fleet's claims and cleared set cover it as any spot, and one vehicle
  treats it), journals it (``"k": "add"``: a restarted agent rebuilds it) and looks for work;
  refused as ``no_room`` beyond the operator's slots (``operator_slots``), as ``on_land``
  where no vehicle could go.

A vehicle passes on (once each) every ORDER frame whose key is still secret by its next slot,
every topside key it learns, and every other vehicle's ACK, and acknowledges each order it
takes (ACK frames: `take_frame` gives one per slot, in place of a pose).

Pure: no I/O, no clock; the agent feeds `hear` and asks `take_frame` when its slot comes.
"""

from __future__ import annotations

from collections import deque
from typing import Any, Iterable, Mapping

from fleet_agent.config import AgentConfig
from fleet_agent.intents import Count, Intent, Note, Owe, SeekWork, Tell
from fleet_agent.knowledge import Knowledge
from fleet_agent.outbox import Owed
from fleet_agent.policies.navigation import Navigation
from fleet_agent import records as rec
from fleet_bus.orders import (ACKED, ALL, REFUSALS, AckFrame, KeyFrame, Order, OrderCodec,
                              OrderError, OrderFrame, TopsideSchedule)
from fleet_bus.telemetry import position_detail
from fleet_bus.states import EventKind
from fleet_bus.tesla import CLOCK_MARGIN_S, Held, Sender

MAX_LEAD_S = 30.0  # a topside frame dated further ahead of this vehicle's clock is refused
MAX_PENDING = 16  # frames waiting for this vehicle's slot (oldest dropped beyond)
MAX_SEEN = 256  # frames remembered as already passed on
STOP_VERBS = ("recall", "abort")


class Orders:
    """One vehicle's side of the operator's orders (module docstring)."""

    def __init__(self, codec: OrderCodec, schedule: TopsideSchedule, commitment: bytes | None,
                 length: int, index: int, config: AgentConfig,
                 journal: Iterable[Mapping[str, Any]] = ()) -> None:
        self.codec, self.schedule, self.index = codec, schedule, index
        self.vid = codec.vehicles[index]
        self.max_age_s = config.ctl_max_age_s
        self.topside = None if commitment is None else Sender(commitment, length)
        self.taken: set[int] = set()
        self.paused = False
        for doc in journal:  # a restarted agent does not act twice
            if isinstance(doc, Mapping) and doc.get("k") == "ord" and \
                    isinstance(doc.get("n"), int):
                self.taken.add(doc["n"])
                if doc.get("verb") in ("pause", "resume"):
                    self.paused = doc["verb"] == "pause"
        self._pending: deque[tuple[bytes, float]] = deque()  # (frame, send by), for the slot
        self._seen: deque[bytes] = deque()

    # -- frames in ---------------------------------------------------------------------------

    def hear(self, data: bytes, now: float, know: Knowledge, nav: Navigation) -> list[Intent]:
        """A topside or ACK frame off the modem at ``now``."""
        try:
            frame = self.codec.read(data)
        except OrderError as exc:
            return [Count(f"drop_ctl_{exc}")]  # outsiders' bytes: the fleet MAC, the layout
        if isinstance(frame, AckFrame):
            if frame.vehicle != self.index:
                self._pass_on(data, now + self.schedule.interval_s)
            return [Count("ctl_ack_heard")]
        if self.topside is None:
            return [Count("ctl_unproven")]  # no topside chain in this mission
        if frame.sent_s > now + MAX_LEAD_S:
            return [Count("drop_ctl_future")]
        out: list[Intent] = []
        if isinstance(frame, KeyFrame):
            out += self._disclose(frame.sent_s, frame.disclosed, data, now)
        else:
            out += self._hold(frame, data, now)
        good, bad = self.topside.release()
        if bad:
            out.append(Count("ctl_unsigned", len(bad)))
        for h in good:
            if isinstance(h.payload, Order):  # what `_hold` put there
                out += self._take(h.payload, now, know, nav)
        return out

    def _disclose(self, sent_s: int, key: bytes, data: bytes, now: float) -> list[Intent]:
        """A KEY frame: the topside's key of ``lag`` intervals before, passed on if news."""
        assert self.topside is not None
        cycle = self.schedule.disclosed_in(sent_s)
        if cycle < 1:
            return [Count("drop_ctl_malformed")]
        before = self.topside.trusted_cycle
        if not self.topside.disclose(cycle, key):
            return [Count("ctl_unsigned")]
        if self.topside.trusted_cycle > before:  # news: pass it on
            self._pass_on(data, now + self.schedule.interval_s)
        return []

    def _hold(self, f: OrderFrame, data: bytes, now: float) -> list[Intent]:
        assert self.topside is not None
        interval = self.schedule.interval(f.sent_s)
        deadline = self.schedule.disclosure_s(interval)
        if now + CLOCK_MARGIN_S >= deadline:
            return [Count("ctl_replayed")]  # its key may be out: it proves nothing
        if data in self._seen:
            return [Count("ctl_heard_again")]  # held already (a peer passed it on)
        cycle = self.schedule.disclosed_in(f.sent_s)
        if cycle >= 1 and not self.topside.disclose(cycle, f.disclosed):
            return [Count("ctl_unsigned")]  # the key it discloses is not the topside's
        self.topside.hold(Held(interval, f.data, f.tag, f.order))
        self._pass_on(data, deadline - CLOCK_MARGIN_S)
        return []

    # -- what an order does ------------------------------------------------------------------

    def _take(self, order: Order, now: float, know: Knowledge, nav: Navigation
              ) -> list[Intent]:
        if order.target not in (ALL, self.vid):
            return []
        if order.seq in self.taken:
            self._ack(order.seq, ACKED, now)
            return [Count("ctl_repeat")]
        if now - order.issued_s > self.max_age_s:
            self._ack(order.seq, 1 + REFUSALS.index("stale"), now)
            return [Count("ctl_stale"), Tell(now, EventKind.ORDER, detail=f"refused "
                                             f"{order.describe()} #{order.seq}: stale")]
        out = self._act(order, now, know, nav)
        if isinstance(out, str):  # refused for what it asks
            self._ack(order.seq, 1 + REFUSALS.index(out), now)
            return [Count(f"ctl_{out}"), Tell(now, EventKind.ORDER, detail=f"refused "
                                              f"{order.describe()} #{order.seq}: {out}")]
        self.taken.add(order.seq)
        self._ack(order.seq, ACKED, now)
        taken: list[Intent] = [Note(rec.OrderTaken(now, order.seq, order.verb)),
                               Count("ctl_taken"),
                               Tell(now, EventKind.ORDER,
                                    detail=f"{order.describe()} #{order.seq}")]
        return taken + out

    def _act(self, order: Order, now: float, know: Knowledge, nav: Navigation
             ) -> list[Intent] | str:
        """What ``order`` does here, or why it cannot (a `REFUSALS` name)."""
        own = know.own
        active = not (own.done or own.aborted)
        if order.verb in STOP_VERBS:
            if not active:
                return []
            own.abort()
            nav.paused = self.paused = False
            return [Owe(Owed.OWN_ABORT), Note(rec.Aborted(now)),
                    Tell(now, EventKind(order.verb), detail="the operator's order")]
        if order.verb == "pause":
            nav.paused = self.paused = True
            return [Tell(now, EventKind.PAUSE, detail="keeping station")] if active else []
        if order.verb == "resume":
            was = self.paused
            nav.paused = self.paused = False
            know.touch()  # the route is fitted again to what is left of the battery
            return [Tell(now, EventKind.RESUME)] if was and active else []
        if order.verb == "drop-spot":
            task = know.problem.task_index.get(order.spot)
            if task is None:
                return "unknown_spot"
            new = know.clear([task])
            return [Note(rec.Clear(now, (task,), own=False)), Owe(Owed.CLEARED, 1),
                    Tell(now, EventKind.DROPPED, (task,)), SeekWork()] if new else []
        return self._add(order, now, know)

    @staticmethod
    def _add(order: Order, now: float, know: Knowledge) -> list[Intent] | str:
        """The operator's add-spot: its slot from its number, the same on every vehicle."""
        b = know.beliefs
        slot = b.op_slot(order.added)
        if slot is None:
            return "no_room"
        why = b.add_spot(slot, b.added_at(order.x, order.y), order.priority, now)
        if why is not None:
            return why
        spot = b.added[slot]
        know.touch()
        return [Note(rec.SpotAdded(now, slot, spot.pos, spot.priority, spot.service_s)),
                Tell(now, EventKind.ADDED, (slot,), detail=f"{position_detail(spot.pos)} rho "
                     f"{spot.priority:g}"), SeekWork()]

    # -- frames out --------------------------------------------------------------------------

    def _ack(self, seq: int, result: int, now: float) -> None:
        self._queue(self.codec.ack(self.index, now, seq, result), now + self.schedule.interval_s,
                    front=True)

    def _pass_on(self, data: bytes, until_s: float) -> None:
        if data in self._seen:
            return
        self._seen.append(data)
        if len(self._seen) > MAX_SEEN:
            self._seen.popleft()
        self._queue(data, until_s)

    def _queue(self, data: bytes, until_s: float, front: bool = False) -> None:
        if len(self._pending) >= MAX_PENDING:
            self._pending.popleft()
        if front:
            self._pending.appendleft((data, until_s))
        else:
            self._pending.append((data, until_s))

    def take_frame(self, now: float, slot_s: float) -> bytes | None:
        """The frame this vehicle passes on or acknowledges in its slot at ``now``, if any
        (frames whose time is up by the slot's end are dropped)."""
        while self._pending:
            data, until = self._pending.popleft()
            if now + slot_s < until:
                return data
        return None

    @property
    def owes(self) -> bool:
        return bool(self._pending)
