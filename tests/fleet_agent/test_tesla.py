"""Which vehicle sent a frame (`fleet_bus.tesla`): key chains, delayed disclosure, and an
insider who holds the fleet key but not another vehicle's chain."""

from __future__ import annotations

import numpy as np
import pytest

from fleet_agent.agent import Agent
from fleet_agent.config import AgentConfig
from fleet_agent.fleet import Fleet
from fleet_agent.io_types import Frame, Tick
from fleet_agent.radio import Slots
from fleet_bus.tdma import SpatialSchedule, Track
from fleet_bus.tesla import CLOCK_MARGIN_S, MAX_HELD, FleetChains, Held, KeyChain, Sender, tag
from fleet_agent.wire import Abort, Claim, Pose, Digest
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import paper_preset_doc

KEY = bytes(range(16))
CONFIG = AgentConfig(plan_iterations=40, replan_iterations=10).with_key(KEY)


def test_a_disclosed_key_is_trusted_only_if_it_hashes_down_to_the_commitment() -> None:
    chain = KeyChain(b"s" * 16, 50)
    peer = Sender(chain.commitment, 50)
    assert peer.disclose(3, chain.key(3))  # three steps down to K_0
    assert peer.key(1) == chain.key(1) and peer.key(4) is None
    assert not peer.disclose(5, b"x" * 8)  # not on the chain: forged
    assert peer.key(5) is None
    assert peer.disclose(2, chain.key(2))  # an old key changes nothing
    assert peer.disclose(9, chain.key(9)) and peer.key(7) == chain.key(7)  # lost frames: fine
    assert not KeyChain(b"t" * 16, 50).commitment == chain.commitment


def test_held_frames_are_released_when_their_key_comes_good_or_forged() -> None:
    chain = KeyChain(b"s" * 16, 50)
    peer = Sender(chain.commitment, 50)
    peer.hold(Held(4, b"real", tag(chain.key(4), b"real"), "real"))
    peer.hold(Held(4, b"fake", tag(b"guessed!", b"fake"), "fake"))
    peer.hold(Held(6, b"later", tag(chain.key(6), b"later"), "later"))
    assert peer.release() == ([], [])  # no key yet: nothing proven
    peer.disclose(5, chain.key(5))
    good, bad = peer.release()
    assert [h.payload for h in good] == ["real"] and [h.payload for h in bad] == ["fake"]
    assert [h.payload for h in peer.held] == ["later"]


def test_what_is_held_is_bounded() -> None:
    peer = Sender(KeyChain(b"s" * 16, 5000).commitment, 5000)
    for c in range(MAX_HELD + 10):
        peer.hold(Held(c + 1, b"", b"????", c))
    assert len(peer.held) == MAX_HELD and peer.dropped == 10


def test_chains_derived_for_a_simulation_are_reproducible() -> None:
    a = FleetChains.derived(KEY, "run", 3, 100)
    assert a == FleetChains.derived(KEY, "run", 3, 100)
    assert a.commitments != FleetChains.derived(KEY, "run-b", 3, 100).commitments
    assert a.seeds is not None and len(set(a.commitments)) == 3


def fleet() -> Fleet:
    return Fleet.build(problem_from_dict(paper_preset_doc(5)), KEY, 5, CONFIG, run_id="t")


def frame_of(sender: Agent, msg: object, cycle: int) -> bytes:
    """``msg`` as ``sender`` would seal it for ``cycle`` (what its own transmit does)."""
    c = cycle + 1
    chain = sender.provenance.chain
    return sender.fleet.codec.encode(msg, chain.key(c), chain.key(c - 1))


def test_a_claim_forged_in_another_vehicles_name_is_refused_once_its_key_is_out() -> None:
    """The insider (vehicle 2) holds the fleet key: the fleet MAC of its forgery in vehicle
    1's name checks. It does not hold vehicle 1's chain: once vehicle 1 discloses the key of
    that cycle, the forgery's tag fails and nothing of it is ever applied."""
    f = fleet()
    me, victim, insider = Agent(f, 0, CONFIG), Agent(f, 1, CONFIG), Agent(f, 2, CONFIG)
    slots = me.provenance.slots[1]
    t0 = slots.time(3)  # victim's slot of cycle 3
    spots = tuple(t for t in range(10) if me.know.holder(t) == 0)[:2]
    chain = insider.provenance.chain
    forged = insider.fleet.codec.encode(Claim(1, int(t0), int(t0), spots), chain.key(4),
                                        chain.key(3))
    me.step(Frame(forged, t0 + 0.5))
    assert all(me.know.holder(t) == 0 for t in spots)  # held, not applied
    # the victim's next frame discloses its real key of cycle 3
    real = frame_of(victim, Pose(1, int(slots.time(4)), (0.0, 0.0, 0.0), 0, "transit",
                                 Digest(0, 0)), 4)
    me.step(Frame(real, slots.time(4) + 0.5))
    key_frame = frame_of(victim, Abort(1, int(slots.time(5)), int(slots.time(5)), subject=2), 5)
    me.step(Frame(key_frame, slots.time(5) + 0.5))
    assert me.counters.get("drop_forged") == 1
    assert all(me.know.holder(t) == 0 for t in spots)  # the forged claim never counted


def test_a_frame_heard_after_its_key_could_be_out_proves_nothing() -> None:
    f = fleet()
    me, peer = Agent(f, 0, CONFIG), Agent(f, 1, CONFIG)
    slots = me.provenance.slots[1]
    msg = Pose(1, int(slots.time(2)), (0.0, 0.0, 0.0), 0, "transit", Digest(0, 0))
    me.step(Frame(frame_of(peer, msg, 2), slots.disclosure_s(2)))  # a whole cycle late
    assert me.counters.get("drop_late_key") == 1


def test_a_peers_own_frames_are_taken_a_cycle_later() -> None:
    f = fleet()
    me, peer = Agent(f, 0, CONFIG), Agent(f, 1, CONFIG)
    slots = me.provenance.slots[1]
    spot = next(t for t in range(f.problem.n_tasks) if me.know.holder(t) is None)
    claim = Claim(1, int(slots.time(3)), int(slots.time(3)), (spot,))
    me.step(Frame(frame_of(peer, claim, 3), slots.time(3) + 0.5))
    assert me.know.holder(spot) is None  # not proven yet
    nxt = Pose(1, int(slots.time(4)), (0.0, 0.0, 0.0), 0, "transit", Digest(0, 0))
    me.step(Frame(frame_of(peer, nxt, 4), slots.time(4) + 0.5))
    assert me.know.holder(spot) is None  # a pose discloses no key
    key = frame_of(peer, Claim(1, int(slots.time(5)), int(slots.time(5)), (spot,)), 5)
    me.step(Frame(key, slots.time(5) + 0.5))
    assert me.know.holder(spot) == 1 and me.counters.get("rx_claim") == 1


@pytest.mark.parametrize("bad", [b"q" * 16, b"short"])
def test_a_chain_seed_the_fleet_does_not_know_is_refused(bad: bytes) -> None:
    with pytest.raises(ValueError):  # another chain, or no chain at all
        Agent(fleet(), 0, CONFIG, chain_seed=bad)


def test_the_agent_discloses_after_a_pose_when_it_has_nothing_else_to_say() -> None:
    a = Agent(fleet(), 0, CONFIG)
    sent = []
    t = 0.0
    while len(sent) < 6:
        t = a.next_wakeup()
        for o in a.step(Tick(t)):
            if type(o).__name__ == "Send":
                sent += list(o.messages)
    assert "key" in sent
    assert all(not (x == "pose" and y == "pose") for x, y in zip(sent, sent[1:]))


def test_a_senders_cycles_are_its_turns_on_the_spatial_schedule() -> None:
    """Where slots are reused (vehicles 10 km apart, some parked in groups taking turns), the
    cycle a receiver computes from a frame's seq is the turn the sender sealed it in, and its
    key is not due out before the frame is heard."""
    tracks = [Track(np.array([0.0, 900.0]), np.array([[0.0, 0.0], [10_000.0 * (v % 2), 0.0]]),
                    900.0 if v < 6 else 1e9) for v in range(10)]
    moving = SpatialSchedule(tracks, 2.5, reuse_m=3500.0, margin_m=300.0, epoch_s=300.0,
                             park_group=2)
    assert moving.cycle_s(1500.0) < 10 * 2.5  # slots are reused, or this tests nothing
    # Four vehicles 10 km apart all share one colour: the cycle's floor of three slots.
    apart = SpatialSchedule([Track(np.array([0.0]), np.array([[10_000.0 * v, 0.0]]), 1e9)
                             for v in range(4)], 2.5, reuse_m=3500.0)
    assert apart.cycle_s(0.0) == 3 * 2.5
    for schedule in (moving, apart):
        for v in range(schedule.n):
            slots = Slots(v, schedule.n, 2.5, schedule)
            for n in range(0, 120, 7):
                opens = slots.time(n)
                for seq in (int(opens), int(opens) + 1):  # a slot's first and second frames
                    assert slots.cycle_of(seq) == n
                    # sent within the second after seq, heard within a second more: in time
                    assert slots.disclosure_s(n) > seq + 2.0 + CLOCK_MARGIN_S
                assert slots.time(n + 1) > opens
