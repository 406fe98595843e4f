"""The operator's topside modem: numbers the operator's orders (and its add-spots apart:
`fleet_bus.orders.Order.added` names the spot's slot on every vehicle), sends them into the
water until acknowledged, discloses its key chain, and keeps what the report says of them.

Pure (no I/O, no clock): a backend calls `submit` when the operator orders, `frames(now)` at
`next_s` (and right after a submit) and transmits what it returns from the topside's position
(`fleet_bus.orders.TOPSIDE` node), and hands it every frame the water delivers there (`hear`).

An order goes out at once and again in every later interval of the topside's key schedule
(`fleet_bus.orders.TopsideSchedule`, each time under that interval's key) until every vehicle
it names has acknowledged it or it is older than the vehicles' ``ctl_max_age_s`` (they would
refuse it as stale). Each interval the topside also discloses the key of ``lag`` intervals
before (a KEY frame), for ``lag`` + 1 intervals after its last order frame: the vehicles prove
an order with any later key, so a lost KEY frame costs one interval.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

from fleet_agent.config import AgentConfig
from fleet_agent.fleet import Fleet
from fleet_bus.orders import (ACKED, ALL, MAX_ADDED, REFUSALS, AckFrame, Order, OrderCodec,
                              OrderError, TopsideSchedule)
from fleet_bus.tesla import KeyChain
from hfc_core.model.problem import Problem


@dataclass
class Sent:
    """One order and what came of it."""

    order: Order
    sent: list[float] = field(default_factory=list)  # each transmission
    acked: dict[str, float] = field(default_factory=dict)  # vehicle -> first ack heard
    refused: dict[str, str] = field(default_factory=dict)  # vehicle -> reason it gave


class Topside:
    """The operator's modem at ``position`` (module docstring)."""

    def __init__(self, codec: OrderCodec, schedule: TopsideSchedule, seed: bytes, length: int,
                 position: Sequence[float], max_age_s: float) -> None:
        self.codec, self.schedule = codec, schedule
        self.chain = KeyChain(seed, length)
        self.position = (float(position[0]), float(position[1]), 0.0)  # at the surface
        self.max_age_s = max_age_s
        self.orders: dict[int, Sent] = {}
        self.refused: dict[str, int] = {}  # requests the topside itself refused, by reason
        self.acks_heard = 0
        self._next_seq = 1
        self._next_added = 0  # the operator's add-spots, numbered apart (`Order.added`)
        self._keys_until = 0  # the last interval in which a KEY frame is owed
        self._last_interval = 0  # the interval of the last `frames` call

    def submit(self, order: Order, now: float) -> Order:
        """Number ``order`` and date it ``now``; ValueError if it names an unknown vehicle."""
        if order.target != ALL and order.target not in self.codec.vehicles:
            self.refused["unknown_vehicle"] = self.refused.get("unknown_vehicle", 0) + 1
            raise OrderError(f"no vehicle {order.target!r} in this mission")
        added = self._next_added if order.verb == "add-spot" else 0
        if order.verb == "add-spot" and added > MAX_ADDED:
            self.refused["too_many_adds"] = self.refused.get("too_many_adds", 0) + 1
            raise OrderError(f"the topside numbers at most {MAX_ADDED + 1} add-spots")
        numbered = Order(order.verb, order.target, self._next_seq, int(now), order.x, order.y,
                         order.priority, order.spot, added)
        self._next_seq += 1
        self._next_added += order.verb == "add-spot"
        self.orders[numbered.seq] = Sent(numbered)
        self._last_interval = 0  # send it now, not at the next interval
        return numbered

    def _targets(self, order: Order) -> tuple[str, ...]:
        return self.codec.vehicles if order.target == ALL else (order.target,)

    def _open(self, s: Sent, now: float) -> bool:
        answered = set(s.acked) | set(s.refused)
        return (now - s.order.issued_s <= self.max_age_s
                and any(v not in answered for v in self._targets(s.order)))

    def frames(self, now: float) -> list[bytes]:
        """What the topside transmits at ``now``: every open order not yet sent in this
        interval, and the key owed for this interval."""
        i = self.schedule.interval(now)
        if i > self.chain.length:
            return []
        out: list[bytes] = []
        disclosed_no = self.schedule.disclosed_in(now)
        disclosed = self.chain.key(disclosed_no) if disclosed_no >= 1 else self.chain.commitment
        for s in self.orders.values():
            if self._open(s, now) and (not s.sent or self.schedule.interval(s.sent[-1]) < i):
                s.sent.append(now)
                out.append(self.codec.order(s.order, now, self.chain.key(i), disclosed))
                self._keys_until = max(self._keys_until, i + self.schedule.lag + 1)
        if i != self._last_interval and disclosed_no >= 1 and i <= self._keys_until:
            out.append(self.codec.key(now, disclosed))
        self._last_interval = i
        return out

    def next_s(self, now: float) -> float | None:
        """When `frames` has something to send next (the next interval's start), or None."""
        i = self.schedule.interval(now)
        if i >= self._keys_until and not any(self._open(s, now) for s in self.orders.values()):
            return None
        return i * self.schedule.interval_s + 0.5  # just into the next interval

    def hear(self, data: bytes, now: float) -> AckFrame | None:
        """A frame the water delivered to the topside: an acknowledgement is noted."""
        try:
            frame = self.codec.read(data)
        except OrderError:
            return None
        if not isinstance(frame, AckFrame):
            return None
        s = self.orders.get(frame.seq)
        if s is None or frame.vehicle >= len(self.codec.vehicles):
            return None
        self.acks_heard += 1
        vid = self.codec.vehicles[frame.vehicle]
        if frame.result == ACKED:
            s.acked.setdefault(vid, round(now, 1))
        elif frame.result <= len(REFUSALS):
            s.refused.setdefault(vid, REFUSALS[frame.result - 1])
        return frame

    def section(self, counters: dict[str, dict[str, int]]) -> dict[str, Any]:
        """The report's ``commands`` section; ``counters``: each vehicle's status counters
        (its refusals, repeats and the orders it took)."""
        refused: dict[str, int] = {}
        for c in counters.values():
            for k, n in c.items():
                if k.startswith("ctl_") and k[4:] in REFUSALS or k == "drop_ctl_mac":
                    name = "unsigned" if k == "drop_ctl_mac" else k[4:]
                    refused[name] = refused.get(name, 0) + n
        return {
            "topside": list(self.position),
            "sent": [{"seq": s.order.seq, "order": s.order.describe(), "verb": s.order.verb,
                      "target": s.order.target, "issued_s": s.order.issued_s,
                      "transmissions": len(s.sent), "acked": dict(s.acked),
                      "refused": dict(s.refused)} for s in self.orders.values()],
            "refused": refused,
            "repeats": sum(c.get("ctl_repeat", 0) for c in counters.values()),
            "taken": {v: c.get("ctl_taken", 0) for v, c in counters.items()
                      if c.get("ctl_taken", 0)},
            "operator_refused": dict(self.refused),
        }


def topside_position(problem: Problem) -> tuple[float, float, float]:
    """Where the topside modem is unless told: at the first vehicle's rendezvous (the boat
    that recovers the fleet), at the surface."""
    x, y, _ = problem.vehicles[0].rendezvous
    return (float(x), float(y), 0.0)


def topside_of(problem: Problem, fleet: Fleet, config: AgentConfig,
               position: Sequence[float] | None = None, seed: bytes | None = None) -> Topside:
    """The topside of ``fleet`` (its chain's seed from the credentials, or the derived one of
    a simulation)."""
    chains = fleet.chains
    assert chains is not None and fleet.orders is not None
    seed = seed if seed is not None else chains.topside_seed
    if seed is None:
        raise ValueError("the topside needs its key chain's seed (the operator's credentials)")
    return Topside(fleet.orders, fleet.topside, seed, chains.length,
                   position if position is not None else topside_position(problem),
                   config.ctl_max_age_s)


def forged_order(fleet: Fleet, order: Order, now: float) -> bytes:
    """An order an insider makes: the fleet MAC right (it holds the fleet key), the topside's
    tag under a chain it made up (it does not hold the topside's seed)."""
    assert fleet.orders is not None
    return forged_frame(fleet.orders, fleet.topside, fleet.chains.length if fleet.chains
                        else 64, order, now)


def forged_frame(codec: OrderCodec, schedule: TopsideSchedule, length: int, order: Order,
                 now: float) -> bytes:
    """`forged_order` from the parts a launcher holds (the fleet key's codec, the schedule)."""
    fake = KeyChain(b"an insider's own made-up seed", length)
    numbered = Order(order.verb, order.target, 4_000_000_000, int(now), order.x, order.y,
                     order.priority, order.spot, order.added)
    i = schedule.interval(now)
    return codec.order(numbered, now, fake.key(i), fake.key(max(1, i - 1)))
