"""Who sent a frame: this vehicle's own frames sealed, its peers' frames proven.

Between the modem and the agent's policies: a frame off the modem has its fleet MAC checked
(`wire.Codec.unseal`: from this fleet, well formed), must not be this vehicle's own played
back, from the future, or heard after its cycle's key could be out; then it is held until its
sender discloses that key (`fleet_bus.tesla`) and comes out proven its sender's, or forged.
What is dropped, and why, is counted. Own frames are tagged under this vehicle's chain key of
the frame's cycle and disclose the key of the cycle before.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from typing import cast

from fleet_agent.fleet import Fleet
from fleet_agent.radio import Slots
from fleet_bus.tdma import SpatialSchedule
from fleet_bus.states import DropReason
from fleet_bus.tesla import CLOCK_MARGIN_S, FleetChains, Held, KeyChain, Sender
from fleet_agent.wire import MAX_LEAD_S, Codec, Message, WireError


@dataclass(frozen=True)
class Taken:
    """A frame taken off the modem: its message if the fleet MAC checked (evidence of life
    at once), and the messages it proved (this one or earlier ones of its sender)."""

    alive: Message | None
    proven: tuple[Message, ...]


class Provenance:
    """This vehicle's chain and what it knows of its peers' (see the module docstring)."""

    def __init__(self, codec: Codec, chains: FleetChains, index: int, seed: bytes,
                 slot_s: float, schedule: SpatialSchedule | None = None) -> None:
        """``schedule``: the fleet's (`Fleet.schedule`): a sender's cycles are its turns in
        it, the same for the sender and every receiver (None: one slot per vehicle)."""
        n = len(chains.commitments)
        self.codec, self.index = codec, index
        self.chain = KeyChain(seed, chains.length)
        if self.chain.commitment != chains.commitments[index]:
            raise ValueError("this vehicle's key chain is not the one the fleet knows")
        self.slots = {v: Slots(v, n, slot_s, schedule) for v in range(n)}
        self.senders = {v: Sender(chains.commitments[v], chains.length)
                        for v in range(n) if v != index}
        self.drops: Counter[str] = Counter()  # why frames were dropped (taken by the agent)

    @staticmethod
    def of(fleet: Fleet, index: int, chain_seed: bytes | None, slot_s: float) -> Provenance:
        """Vehicle ``index``'s, with its chain's seed from its credentials (``chain_seed``) or,
        where the fleet's chains are derived (a simulation), from the fleet."""
        chains = fleet.chains
        assert chains is not None
        seed = chain_seed if chain_seed is not None else \
            (chains.seeds[index] if chains.seeds is not None else None)
        if seed is None:
            vid = fleet.problem.vehicles[index].id
            raise ValueError(f"{vid} has no key chain: give its credentials' seed")
        return Provenance(fleet.codec, chains, index, seed, slot_s, fleet.schedule)

    def seal(self, msg: Message) -> bytes | None:
        """The frame of ``msg`` (None once the chain is spent: counted)."""
        c = self.slots[self.index].cycle_of(msg.seq) + 1
        if c > self.chain.length:
            self.drops[DropReason.CHAIN_SPENT] += 1
            return None
        before = self.chain.key(c - 1) if c > 1 else self.chain.commitment
        return self.codec.encode(msg, self.chain.key(c), before)

    def hear(self, data: bytes, now: float) -> Taken:
        """A frame off the modem at ``now``: what it proves of life at once, and what is now
        proven its sender's."""
        try:
            sealed = self.codec.unseal(data)
        except WireError as exc:
            self.drops[exc.reason] += 1
            return Taken(None, ())
        msg, v = sealed.msg, sealed.msg.sender
        if v == self.index:
            self.drops[DropReason.SELF] += 1  # our own frame played back: a replay
            return Taken(None, ())
        if msg.seq > now + MAX_LEAD_S:  # from the future: forged (see wire.MAX_LEAD_S)
            self.drops[DropReason.FUTURE] += 1
            return Taken(None, ())
        cycle = self.slots[v].cycle_of(msg.seq)
        if now + CLOCK_MARGIN_S >= self.slots[v].disclosure_s(cycle):
            self.drops[DropReason.LATE_KEY] += 1  # its key may be out: it proves nothing
            return Taken(None, ())
        sender = self.senders[v]
        sender.hold(Held(cycle + 1, sealed.data, sealed.tag, msg))
        if sealed.disclosed is not None and not sender.disclose(cycle, sealed.disclosed):
            self.drops[DropReason.FORGED_KEY] += 1
        proven, forged = sender.release()
        if forged:
            self.drops[DropReason.FORGED] += len(forged)
        return Taken(msg, tuple(cast(Message, h.payload) for h in proven))

    def unproven(self) -> list[Message]:
        """What the frames held for their keys say: never acted on, only waited on (a claim
        in one may be earlier than ours, `policies.unproven`)."""
        return [cast(Message, h.payload) for s in self.senders.values() for h in s.held]

    def last_words(self, v: int) -> list[Message]:
        """What ``v`` said and never proved (a vehicle gone before its next key), forgotten
        here: the caller takes what a lie in it could cost ``v`` alone."""
        sender = self.senders.get(v)
        if sender is None:
            return []
        held, sender.held = list(sender.held), type(sender.held)()
        return [cast(Message, h.payload) for h in held]

    def take_drops(self) -> Counter[str]:
        """The drops since the last call."""
        out, self.drops = self.drops, Counter()
        return out
