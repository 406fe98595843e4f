"""A peer's pose that says it is at work at a spot this vehicle is on its way to: the peer's
claim never reached us (fault fuzz seed 41: every send of it lost at about 60 % loss, while
other frames of that peer got through), and going on would treat the spot twice. The spot is
left to the peer (`policies.hearing`): released, out of this vehicle's plans, not cleared."""

from __future__ import annotations

from fleet_agent.agent import Agent
from fleet_agent.intents import Note, Tell
from fleet_agent.policies import hearing
from fleet_agent.records import Doubt
from fleet_agent.restore import fold
from fleet_agent.wire import Pose
from fleet_bus.states import VehicleState
from test_agent_logic import CONFIG, World, fleet
from test_claim_contest import hear, injecting_auv1

PEER = 1  # auv2


def pose_at(agent: Agent, spot: int, state: str, off_m: float = 1.0) -> Pose:
    x, y, z = (float(c) for c in agent.know.problem.xyz[spot])
    return Pose(PEER, 290, (x + off_m, y, z), 0, state, agent.know.cleared.digest())


def in_transit() -> tuple[World, Agent, int]:
    """auv1 at 300 s on its way, and the next spot of its route."""
    world = World()
    world.run_until(300.0)
    agent = world.agent("auv1")
    spot = next(t for t in agent.own.route if t != agent.own.at_spot)
    return world, agent, spot


def test_a_peer_seen_at_work_at_our_next_spot_gets_it() -> None:
    world, agent, spot = in_transit()
    know = agent.know
    said = hear(agent, pose_at(agent, spot, VehicleState.INJECTING), 300.0)
    assert spot in know.doubtful and spot not in know.cleared  # the fleet learns nothing false
    assert know.holder(spot) != know.index  # released
    assert [h.holding.claim for h in agent.radio.outbox.holdings][-1] is False
    assert agent.counters["spots_left_to_worker"] == 1
    world.run_until(330.0)
    assert spot not in agent.own.route
    told = [i for i in said if isinstance(i, Tell) and i.kind == "replan"]
    assert [(t.tasks, t.peer) for t in told] == [((spot,), "auv2")]
    assert "seen at work" in told[0].detail


def test_a_peer_in_transit_or_working_elsewhere_changes_nothing() -> None:
    _, agent, spot = in_transit()
    before = list(agent.own.route)
    hear(agent, pose_at(agent, spot, VehicleState.TRANSIT), 300.0)  # passing by
    hear(agent, pose_at(agent, spot, VehicleState.INJECTING, off_m=hearing.AT_WORK_M + 1.0),
         300.0)  # at work, but farther than a pose's error from our spot
    assert agent.own.route == before and spot not in agent.know.doubtful
    assert "spots_left_to_worker" not in agent.counters


def test_the_spot_a_vehicle_is_at_is_the_claim_contests_not_the_poses() -> None:
    """Two vehicles at one spot would each yield to the other's pose: nobody would treat it.
    Who keeps it is the earlier claim's (`test_claim_contest`)."""
    world, agent, spot = injecting_auv1()
    hear(agent, pose_at(agent, spot, VehicleState.INJECTING), 415.0)
    assert agent.own.injecting == spot and spot not in agent.know.doubtful
    world.run_until(420.0)
    assert agent.own.injecting == spot


def test_a_peer_at_a_spot_of_its_own_beside_ours_keeps_ours() -> None:
    """Its pose places it at the spot it holds, not at ours 4.3 m away (fault fuzz seed 8,
    2 % drift: a peer at its own spot, 4 m from one of ours, took ours and nobody treated
    it)."""
    _, agent, _ = in_transit()
    know = agent.know
    ours, theirs = 33, 54  # 4.3 m apart in this reef, both auv1's at first
    assert ours in agent.own.route and theirs in agent.own.route
    know.hold(know.index, 200, [theirs], False)  # auv1 gave it up, auv2 took it
    know.hold(PEER, 250, [theirs], True)
    assert know.holder(theirs) == PEER
    hear(agent, pose_at(agent, theirs, VehicleState.INJECTING, off_m=0.0), 300.0)
    assert ours not in know.doubtful and know.holder(ours) == know.index
    # without the peer's claim of its own spot there, ours is the spot it is at
    know.hold(PEER, 280, [theirs], False)
    hear(agent, pose_at(agent, theirs, VehicleState.INJECTING, off_m=0.0), 300.0)
    assert ours in know.doubtful


def test_a_restart_still_leaves_the_spot_to_the_peer() -> None:
    """The doubt is journalled (durable): a vehicle restarted on its journal does not plan the
    spot again while the peer working it may be the one whose clear is lost."""
    world, agent, spot = in_transit()
    said = hear(agent, pose_at(agent, spot, VehicleState.INJECTING), 300.0)
    notes = [i.record for i in said if isinstance(i, Note)]
    assert notes == [Doubt(300.0, (spot,))] and notes[0].durable
    journal = world.backend.seats["auv1"].journal.reopen().records + [notes[0].doc()]
    assert fold(journal, agent.know.problem.n_tasks).doubtful == {spot}
    reborn = Agent(fleet(), 0, CONFIG, 310.0, journal)
    assert spot in reborn.know.doubtful and spot not in reborn.know.cleared
    assert spot in reborn.know.unavailable(310.0) and spot not in reborn.know.free_spots(310.0)
    damaged = journal[:-1] + [{"k": "doubt", "t": 300.0, "ids": "x"}]  # counted, not fatal
    assert fold(damaged, agent.know.problem.n_tasks).bad_records == 1
