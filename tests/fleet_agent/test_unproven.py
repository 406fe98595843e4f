"""A frame heard but not yet proven its sender's holds back the work it may take away, and
is never acted on (`fleet_agent.policies.unproven`)."""

from __future__ import annotations

import numpy as np

from benchmarks.dynamic import SETTINGS, config_of
from cotsfleet.mission.inprocess import SimResult, simulate
from fleet_agent.agent import Agent
from fleet_agent.wire import Claim, Digest, Found, Key, Pose
from fleet_agent.witness import new_track
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.dynamic import generate_dynamic_doc
from reef_sim.score import world_tally
from reef_sim.truth import reef_from_doc
from test_plausible import dynamic_agent
from fleet_agent.policies.unproven import rival

HERE = (300.0, 300.0, -3.0)
CLAIMED = 500  # when auv1 claimed its find


def finder() -> tuple[Agent, int]:
    """auv1 with its own find at `HERE`, claimed at `CLAIMED` s."""
    agent = dynamic_agent()
    know = agent.know
    slot = know.beliefs.own_slot()
    assert slot is not None and know.add_find(slot, HERE, 40.0, 60.0, 400.0)
    know.hold(0, CLAIMED, [slot], True)
    return agent, slot


def test_an_earlier_claim_of_the_spot_holds_it_back_and_a_later_one_does_not() -> None:
    agent, slot = finder()
    know = agent.know
    assert rival(know, [Claim(2, 495, CLAIMED - 5, (slot,))], slot, 520.0)
    assert rival(know, [Claim(2, 495, CLAIMED, (slot,))], slot, 520.0)  # a tie: the contest
    assert not rival(know, [Claim(2, 505, CLAIMED + 5, (slot,))], slot, 520.0)
    assert not rival(know, [Claim(0, 495, CLAIMED - 5, (slot,))], slot, 520.0)  # our own
    assert not rival(know, [Pose(2, 495, HERE, 0, "transit", Digest(0, 0))], slot, 520.0)
    other = next(t for t in sorted(know.free_spots(520.0)) if t < know.beliefs.n)
    assert not rival(know, [Claim(2, 495, CLAIMED - 5, (other,))], slot, 520.0)


def test_the_initial_plan_s_spots_are_never_held_back() -> None:
    agent = dynamic_agent()
    know = agent.know
    spot = know.own.route[0]
    assert not rival(know, [Claim(2, 5, 1, (spot,))], spot, 10.0)


def test_a_claim_of_an_unheard_find_holds_back_a_find_its_claimer_passed_near() -> None:
    """Its FOUND may be lost: the unheard find may be this aggregation under its name."""
    agent, slot = finder()
    know, b = agent.know, agent.know.beliefs
    unheard = b.n + 2 * b.cap  # auv3's first find, not heard of
    claim = Claim(2, 495, CLAIMED - 5, (unheard,))
    assert rival(know, [claim], slot, 520.0)  # auv3's track unknown: it may have been here
    know.tracks[2] = new_track()
    know.tracks[2].append((480.0, (2000.0, 2000.0, -3.0)))  # heard far away
    assert not rival(know, [claim], slot, 520.0)
    know.tracks[2].append((490.0, (HERE[0] + 5.0, HERE[1], -3.0)))  # and then here
    assert rival(know, [claim], slot, 520.0)


def test_a_found_of_what_may_be_the_same_aggregation_holds_it_back() -> None:
    """Its finder holds it from the FOUND on (`Holdings.found`), before our claim."""
    agent, slot = finder()
    b = agent.know.beliefs
    theirs = b.n + 2 * b.cap

    def found(pos: tuple[float, float, float]) -> Found:
        return Found(2, 495, Digest(0, 0), theirs, pos, 40.0, 60.0)

    assert rival(agent.know, [found((HERE[0] + 2.0, HERE[1], HERE[2]))], slot, 520.0)
    assert not rival(agent.know, [found((HERE[0] + 200.0, HERE[1], HERE[2]))], slot, 520.0)


def test_the_agent_waits_while_such_a_frame_is_held_and_no_longer_once_it_is_proven() -> None:
    """Through the agent's own provenance: a peer's claim heard in its frame is held until
    a later frame of the peer discloses its key; the wait lasts as long."""
    agent, slot = finder()
    peer = Agent(agent.fleet, 2, agent.config)
    settled = agent.know.settled_s(slot)
    capped = settled + agent.config.unproven_wait_cycles * agent.radio.slots.cycle_s
    sent = peer.radio.slots.next_from(CLAIMED - 4.0)
    frame = peer.provenance.seal(Claim(2, int(sent), CLAIMED - 5, (slot,)))
    assert frame is not None
    agent.provenance.hear(frame, sent + 0.5)
    assert agent.provenance.unproven()  # heard, not proven
    assert agent._held_back(slot, settled) == capped
    later = peer.radio.slots.next_from(sent + 1.0)
    pose = peer.provenance.seal(Pose(2, int(later), HERE, 0, "transit", Digest(0, 0)))
    assert pose is not None
    assert not agent.provenance.hear(pose, later + 0.5).proven  # a pose discloses no key
    assert agent._held_back(slot, settled) == capped
    later = peer.radio.slots.next_from(later + 1.0)
    key = peer.provenance.seal(Key(2, int(later)))
    assert key is not None
    taken = agent.provenance.hear(key, later + 0.5)
    assert any(isinstance(m, Claim) for m in taken.proven)
    assert agent._held_back(slot, settled) == 0.0
    assert agent.counters.get("waits_unproven") == 1


def lossy_mission(setting: str, seed: int) -> tuple[SimResult, int]:
    """`benchmarks/dynamic.py`'s mission of ``setting`` and ``seed`` at 30 % extra loss, and
    its duplicate treatments by the world's book."""
    params = SETTINGS[setting]
    doc = generate_dynamic_doc(params, np.random.default_rng(seed))
    problem = problem_from_dict(doc)
    reef = reef_from_doc(doc, problem)
    result = simulate(problem, config_of(params, search=True), seed=seed, loss=0.3, reef=reef)
    books = {vid: seat.driver.vehicle.treatments for vid, seat in result.backend.seats.items()
             if seat.driver is not None}
    return result, world_tally(reef, books)["duplicates"]


def test_preset_seed_2_at_30_percent_loss_treats_each_aggregation_once() -> None:
    """The dynamic benchmark's last duplicate (docs/search.md): auv3's claim of its find was
    heard 12 s before auv1's claim of the same aggregation settled, but proven 0.2 s after;
    auv1 now waits for the proof, takes the claim, and leaves the find to auv3."""
    result, duplicates = lossy_mission("preset", 2)
    assert duplicates == 0
    assert sum(v.counters.get("waits_unproven", 0) for v in result.report.vehicles) >= 1
