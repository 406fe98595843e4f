"""The outbox (`fleet_agent.outbox`): a modem that carries several frames per transmission gets
what is owed in them, in the ladder's order, and never a padding of poses."""

from __future__ import annotations

from dataclasses import replace

from fleet_agent.agent import Agent
from fleet_agent.config import AgentConfig
from fleet_agent.fleet import Fleet
from fleet_agent.outbox import Holding, Owed
from fleet_agent.wire import Abort, Claim, ClearedSegment, Pose, Release
from fleet_bus.modem_port import ModemSpec
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import paper_preset_doc

KEY = bytes(range(16))
CONFIG = AgentConfig(plan_iterations=40, replan_iterations=10).with_key(KEY)
PSK = ModemSpec("micromodem-rate1", 64, 500.0, frames_per_packet=3)


def agent() -> Agent:
    problem = problem_from_dict(paper_preset_doc(5))
    fleet = Fleet.build(problem, KEY, 5, CONFIG, run_id="t", modem=PSK)
    return Agent(fleet, 0, CONFIG)


def test_a_packet_of_three_frames_carries_what_is_owed_in_the_ladders_order() -> None:
    a = agent()
    box = a.radio.outbox
    box.holdings.clear()
    box.owe(Owed.CLAIM, Holding(False, 10, (1, 2)))
    box.owe(Owed.CLAIM, Holding(True, 12, (3,)))
    a.know.cleared.add(7)
    box.owe(Owed.CLEARED, 1)
    box.since_pose = CONFIG.pose_every_cycles  # the heartbeat is due
    msgs = a.radio.messages(20.0, a.know, 3)
    # fresh claim, heartbeat, the push's first send (before the repeats: `cleared_first`)
    assert [type(m) for m in msgs] == [Claim, Pose, ClearedSegment]
    assert len({m.seq for m in msgs}) == 3  # each frame its own sequence number
    later = [a.radio.messages(27.5 + 7.5 * k, a.know, 3) for k in range(4)]
    assert all(Pose not in [type(m) for m in p[1:]] for p in later)  # no padding
    assert Release in [type(m) for p in later for m in p]  # the release got through


def _owing_two_pushes() -> Agent:
    """An agent that treated spot 7 and owes the two pushes of its cleared set a treatment
    owes, nothing else pending."""
    a = agent()
    a.radio.outbox.holdings.clear()
    a.know.cleared.add(7)
    a.radio.outbox.owe(Owed.CLEARED, 2)
    return a


def test_a_push_owed_after_a_treatment_is_not_starved_by_claims_and_releases() -> None:
    # Fault fuzz seed 22 (climbs for a fix on): a vehicle whose route churned sent a claim,
    # a release or a FOUND in every slot its pose left free; the two pushes owed after its
    # treatment waited for minutes, it aborted, and the peer that took its spots over
    # treated that one again.
    a = _owing_two_pushes()
    box = a.radio.outbox
    sent = []
    for k in range(4):
        box.owe(Owed.CLAIM, Holding(False, 10 + k, (20 + k,)))  # churn: a release a slot
        sent += [type(m) for m in a.radio.messages(5.0 + 7.5 * k, a.know, 1)]
    assert sent[:2] == [Pose, ClearedSegment]  # the heartbeat, then the push


def test_an_abort_keeps_the_pushes_owed_and_pushes_right_after_its_first_abort() -> None:
    a = _owing_two_pushes()
    a.radio.outbox.owe(Owed.OWN_ABORT)
    a.know.own.aborted = True
    sent = [type(m) for k in range(8) for m in a.radio.messages(5.0 + 7.5 * k, a.know, 1)]
    assert sent[:3] == [Abort, ClearedSegment, Abort]  # a slot after the first ABORT
    assert sent.count(ClearedSegment) == 2 and sent.count(Abort) == CONFIG.abort_repeats


def test_with_nothing_owed_a_packet_is_one_pose_not_three() -> None:
    a = agent()
    a.radio.outbox.holdings.clear()
    msgs = a.radio.messages(5.0, a.know, 3)
    assert [type(m) for m in msgs] == [Pose]


def test_one_frame_modems_get_one_message() -> None:
    a = agent()
    a.radio.outbox.owe(Owed.CLAIM, Holding(True, 12, (3,)))
    assert len(a.radio.messages(20.0, a.know, 1)) == 1
    assert replace(PSK, frames_per_packet=1).frames_per_packet == 1
