"""A peer that claims a spot we hold by an earlier claim, or one we know is cleared, missed
our claim or our clear and is on its way: we answer at once (`Agent._contest`), not at the
next refresh (`policies.hearing`). The case that made a duplicate: a find's claim waited behind
older claims and releases for two minutes while a peer, which had missed it, flew there."""

from __future__ import annotations

from fleet_agent.agent import Agent
from fleet_agent.intents import Intent
from fleet_agent.io_types import Outputs
from fleet_agent.knowledge import settled_by_s
from fleet_agent.outbox import Holding, Owed
from fleet_agent.policies import hearing
from fleet_agent.wire import Claim, ClearedSegment, Message
from fleet_bus.telemetry import detail_stopped_s
from test_agent_logic import World


def free_spot(agent: Agent) -> int:
    """A spot no vehicle's initial plan holds."""
    know = agent.know
    return next(t for t in range(know.holdings.n_tasks) if know.holder(t) is None
                and t not in know.cleared)


def claimed_by_auv1() -> tuple[World, Agent, int]:
    world = World()
    world.run_until(300.0)
    agent = world.agent("auv1")
    spot = free_spot(agent)
    agent.know.holdings.apply(agent.know.index, 250, [spot], True)  # our claim, made at 250
    outbox = agent.radio.outbox
    outbox.holdings.clear()
    outbox.owe(Owed.CLAIM, Holding(False, 200, (1, 2)))  # older business ahead of it
    outbox.owe(Owed.CLAIM, Holding(True, 250, (spot,)))
    return world, agent, spot


def injecting_auv1() -> tuple[World, Agent, int]:
    """auv1 at 415 s, mid-injection, and the spot it injects."""
    world = World()
    world.run_until(415.0)
    agent = world.agent("auv1")
    spot = agent.own.injecting
    assert spot is not None
    return world, agent, spot


def logged(world: World, kind: str, agent: Agent, spot: int) -> list:
    """``agent``'s events of ``kind`` naming ``spot``."""
    tid = agent.know.tids([spot])[0]
    return [e for e in world.backend.ledger.events
            if e.id == agent.id and e.kind == kind and tid in e.tasks]


def hear(agent: Agent, msg: Message, now: float = 300.0) -> list[Intent]:
    """``agent`` takes ``msg`` (proven) at ``now``; what it decided."""
    intents = hearing.content(agent.know, agent.config, msg, now, agent.active)
    agent._apply(intents, now, Outputs(agent.id, agent.know.tids))
    return intents


def kinds(agent: Agent) -> list[bool]:
    """Claim (True) or release (False), for each holding owed, in order."""
    return [e.holding.claim for e in agent.radio.outbox.holdings]


def test_a_later_claim_on_our_spot_puts_our_claim_first() -> None:
    _, agent, spot = claimed_by_auv1()
    hear(agent, Claim(1, 301, 280, (spot,)))  # auv2 claims it at 280: it missed ours
    first = agent.radio.outbox.holdings[0].holding
    assert first == Holding(True, 250, (spot,))
    assert kinds(agent) == [True, False]  # moved, not copied
    assert agent.know.holder(spot) == agent.know.index  # the earlier claim still holds it


def test_our_claim_is_owed_again_once_its_sends_are_done() -> None:
    _, agent, spot = claimed_by_auv1()
    agent.radio.outbox.holdings.clear()
    hear(agent, Claim(1, 301, 280, (spot,)))
    first = agent.radio.outbox.holdings[0]
    assert (first.holding.tasks, first.left) == ((spot,), agent.config.claim_repeats)


def test_an_earlier_claim_wins_and_is_not_answered() -> None:
    _, agent, spot = claimed_by_auv1()
    hear(agent, Claim(1, 301, 240, (spot,)))  # auv2 claimed first: the spot is its own
    assert agent.know.holder(spot) == 1
    assert kinds(agent) == [False, True]  # order untouched


def test_a_claim_on_a_spot_we_cleared_gets_that_segment_of_the_cleared_set() -> None:
    _, agent, spot = claimed_by_auv1()
    agent.know.cleared.add(spot)
    hear(agent, Claim(1, 301, 280, (spot,)))
    outbox = agent.radio.outbox
    assert list(outbox.segments) == [agent.know.cleared.segment_of(spot)]
    outbox.since_pose = 0  # not the heartbeat's turn
    msg = agent.radio.message(301.0, agent.know)
    assert isinstance(msg, ClearedSegment) and msg.segment == agent.know.cleared.segment_of(spot)
    assert not outbox.segments


def test_a_new_claim_takes_the_next_slot_even_when_a_pose_is_due() -> None:
    """A vehicle works a spot it claimed late only once an earlier claim could have been
    heard (`Knowledge.settled_s`), which counts on each claim leaving in the next slot."""
    _, agent, spot = claimed_by_auv1()
    radio = agent.radio
    radio.outbox.since_pose = agent.config.pose_every_cycles  # the heartbeat is due
    msg = radio.message(301.0, agent.know)
    assert isinstance(msg, Claim) and (msg.t_s, msg.tasks) == (250, (spot,))
    assert type(radio.message(302.0, agent.know)).__name__ == "Pose"


def test_standing_claims_sent_again_do_not_jump_the_queue() -> None:
    _, agent, spot = claimed_by_auv1()
    radio = agent.radio
    radio.outbox.holdings.clear()
    radio.outbox.since_pose = agent.config.pose_every_cycles
    radio.outbox._queue(Holding(True, 250, (spot,)), fresh=False)  # a standing claim again
    assert type(radio.message(301.0, agent.know)).__name__ == "Pose"


def test_a_late_claim_settles_two_cycles_and_a_slot_after_it_and_the_initial_plan_at_once() -> None:
    world, agent, spot = claimed_by_auv1()
    know, cfg = agent.know, agent.config
    cycle = cfg.slot_s * agent.problem.n_vehicles
    # a cycle more for the claim to be proven its claimer's (`fleet_bus.tesla`)
    assert know.settled_s(spot) == 250 + (cfg.claim_settle_cycles + 1) * cycle + cfg.slot_s + 1.0
    own = agent.own.route[0] if agent.own.route else next(
        t for t in range(know.holdings.n_tasks) if know.holder(t) == know.index)
    assert know.settled_s(own) == 0.0
    assert agent.own.conduct.not_before(spot) == know.settled_s(spot)  # the vehicle obeys it
    # the bound its projection trusts (`Conduct.settled_by`): no spot settles later
    assert settled_by_s(know) == max(know.settled_s(t) for t in range(know.holdings.n_tasks))


def test_the_loser_of_a_claim_race_learning_it_mid_injection_stops() -> None:
    """Fault fuzz seed 74: auv3 claimed a spot 13 s before auv1; auv1 heard it only 55 s into
    its own injection and finished anyway, and the spot was treated twice. The earlier claim
    holds the spot: the loser stops, and the holder (which never stops for a later claim)
    treats it."""
    world, agent, spot = injecting_auv1()
    know = agent.know
    know.holdings.apply(know.index, 300, [spot], True)  # held by our claim at 300
    assert know.holder(spot) == know.index
    msg = Claim(1, 416, 280, (spot,))  # auv2 claimed it at 280: we missed it
    intents = hearing.content(know, agent.config, msg, 416.0, agent.active)
    agent._apply(intents, 416.0, Outputs(agent.id, know.tids))
    assert know.holder(spot) == 1
    world.run_until(600.0)
    assert spot not in agent.own.route and agent.own.injecting != spot
    assert spot not in know.cleared  # not treated by us; auv2 will
    # The log says so once, with how long it injected (the timeline's injecting time).
    told = logged(world, "claim_lost", agent, spot)
    assert len(told) == 1 and told[0].peer == "auv2"
    injected_s = detail_stopped_s(told[0].detail)
    assert injected_s is not None and 0.0 < injected_s <= 416.0 - 300.0


def test_a_peers_clear_heard_mid_injection_stops_it_and_the_log_says_how_long() -> None:
    """A peer's cleared set marks the spot being injected as treated: the vehicle stops (the
    spot is done for everyone), and the log says so once, with how long it injected, so the
    timeline counts that time as injecting, not as transit."""
    world, agent, spot = injecting_auv1()
    know = agent.know
    busy_until = agent.own.busy_until_s
    assert busy_until is not None and busy_until > 430.0
    assert know.clear([spot])  # heard in a peer's cleared set
    world.run_until(600.0)
    assert spot not in agent.own.route and agent.own.injecting != spot
    told = logged(world, "judged_treated", agent, spot)
    assert len(told) == 1 and not told[0].peer
    injected_s = detail_stopped_s(told[0].detail)
    assert injected_s is not None and 0.0 < injected_s <= told[0].t_s - (
        busy_until - float(agent.own.problem.service_s[spot])) + 1e-6
    assert not logged(world, "cleared", agent, spot)
