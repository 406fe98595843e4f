"""What a peer says of itself is weighed against what it could have done
(`fleet_agent.policies.plausible`): an insider holding one vehicle's keys can lie about that
vehicle, but a lie beyond its own work is refused or waits for a second peer's word, and it
is counted against it (the report's suspects)."""

from __future__ import annotations

import math

from fleet_agent.agent import Agent
from fleet_agent.fleet import Fleet
from fleet_agent.helms.sim import camera_figures
from fleet_agent.io_types import Outputs
from fleet_agent.policies import hearing, plausible
from fleet_agent.wire import Abort, Claim, ClearedSegment, Digest, Found, Message, Pose
from fleet_agent.witness import new_track
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.truth import reef_from_doc
from test_agent_logic import World
from test_discovery import CONFIG, KEY, RUN, small_doc

NOW = 300.0


def started() -> tuple[World, Agent]:
    world = World()
    world.run_until(NOW)
    return world, world.agent("auv1")


def hear(agent: Agent, msg: Message, now: float = NOW) -> None:
    intents = hearing.content(agent.know, agent.config, msg, now, agent.active)
    agent._apply(intents, now, Outputs(agent.id, agent.know.tids))


def held_by(agent: Agent, v: int) -> list[int]:
    return sorted(agent.know.held_by(v))


def saying(agent: Agent, sender: int, spots: list[int], seq: int = 301) -> ClearedSegment:
    """``sender`` says ``spots`` (all in one segment) are cleared."""
    per = agent.know.cleared.segment_bits
    segment = spots[0] // per
    bits = 0
    for t in spots:
        assert t // per == segment
        bits |= 1 << (t - segment * per)
    return ClearedSegment(sender, seq, Digest(0, 0), segment,
                          bits.to_bytes((per + 7) // 8, "little"))


def test_a_peer_saying_another_s_spot_is_cleared_waits_for_a_second_word() -> None:
    _, agent = started()
    spot = held_by(agent, 1)[-1]  # auv2's, still to treat
    hear(agent, saying(agent, 2, [spot]))  # auv3 alone says it
    assert spot not in agent.know.cleared
    assert agent.counters.get("cleared_waiting") == 1
    hear(agent, saying(agent, 1, [spot], 302))  # the holder says it too
    assert spot in agent.know.cleared


def test_an_insider_saying_everything_is_cleared_takes_only_its_own_and_free_spots() -> None:
    _, agent = started()
    know = agent.know
    bits = know.cleared.segment_bits
    everything = [t for t in range(min(bits, know.problem.n_tasks)) if t not in know.cleared]
    others = [t for t in everything if know.holder(t) not in (None, 2)]
    assert others, "the scenario gives auv1 and auv2 work in segment 0"
    hear(agent, saying(agent, 2, everything))
    assert all(t not in know.cleared for t in others)  # ours and auv2's still to treat
    assert all(t in know.cleared for t in everything if t not in others)
    assert agent.counters.get("cleared_waiting") == len(others)


def test_a_claim_on_every_spot_is_cut_to_what_its_battery_could_treat() -> None:
    _, agent = started()
    know = agent.know
    free = sorted(know.free_spots(NOW))
    hear(agent, Claim(2, 301, 301, tuple(range(know.problem.n_tasks))))
    got = held_by(agent, 2)
    spec = know.problem.vehicles[2]
    pose = know.peer_pose[2]
    assert plausible.work_s(know.problem, pose.pos, spec.speed_mps, got) \
        <= plausible.HELD_SLACK * (spec.battery_s - pose.t_s)
    assert len(got) < know.problem.n_tasks - len(know.cleared)
    assert held_by(agent, 0), "our own plan is not handed over to the liar"
    assert know.suspicion[2] > 0
    assert agent.status(NOW).suspects == {"auv3": know.suspicion[2]}
    assert free, "the scenario leaves free spots to claim"


def test_a_claim_within_reach_is_taken_whole() -> None:
    _, agent = started()
    know = agent.know
    spot = min(know.free_spots(NOW),
               key=lambda t: sum((a - b) ** 2 for a, b in zip(know.problem.xyz[t],
                                                               know.peer_pose[2].pos)))
    hear(agent, Claim(2, 301, 301, (spot,)))
    assert know.holder(spot) == 2
    assert not know.suspicion


def test_news_of_another_s_abort_needs_two_peers() -> None:
    _, agent = started()
    hear(agent, Abort(2, 301, 290, subject=1))  # auv3 says auv2 aborted
    assert agent.know.members.status(1) == "alive"
    assert agent.counters.get("abort_waiting") == 1
    # the subject itself saying so is enough (frame from auv2, about auv2)
    hear(agent, Abort(1, 302, 291))
    assert agent.know.members.status(1) == "aborted"


def test_home_said_far_from_the_rendezvous_is_refused() -> None:
    _, agent = started()
    know = agent.know
    pose = know.peer_pose[2]
    hear(agent, Pose(2, 301, pose.pos, 0, "home", Digest(0, 0)))
    assert know.members.status(2) == "alive"
    assert know.suspicion[2] == 1
    rdv = know.problem.vehicles[2].rendezvous
    hear(agent, Pose(2, 302, rdv, 0, "home", Digest(0, 0)))
    assert know.members.status(2) == "home"


def dynamic_agent() -> Agent:
    doc = small_doc()
    problem = problem_from_dict(doc)
    fleet = Fleet.build(problem, KEY, 4, CONFIG, run_id=RUN,
                        camera=camera_figures(reef_from_doc(doc, problem)))
    return Agent(fleet, 0, CONFIG)


def test_a_find_is_weighed_against_the_scenario_and_its_finder_s_track() -> None:
    agent = dynamic_agent()
    know, b = agent.know, agent.know.beliefs
    slot = b.n + 2 * b.cap  # auv3's first find
    top = float(max(b.scenario.priority))
    here = (100.0, 100.0, -3.0)
    know.tracks[2] = new_track()
    know.tracks[2].append((50.0, here))
    assert plausible.find(know, 2, slot, here, 3 * top, 60.0, 60.0) == plausible.REFUSE
    assert plausible.find(know, 2, slot, here, top, 10**5, 60.0) == plausible.REFUSE
    assert plausible.find(know, 2, slot, here, top, 60.0, 60.0) == plausible.TAKE
    far = (here[0] + 500.0, here[1], here[2])  # 500 m away ten seconds after a pose
    assert plausible.find(know, 2, slot, far, top, 60.0, 60.0) == plausible.REFUSE
    # relayed by auv2: waits for the finder or a second peer
    assert plausible.find(know, 1, slot, here, top, 60.0, 60.0) == plausible.WAIT


def test_a_relayed_find_of_a_gone_finder_is_taken_from_one_peer() -> None:
    agent = dynamic_agent()
    know, b = agent.know, agent.know.beliefs
    slot = b.n + 2 * b.cap
    top = float(max(b.scenario.priority))
    hear(agent, Abort(2, 10, 10), 10.0)  # auv3 itself says it aborted
    assert know.members.status(2) == "aborted"
    assert plausible.find(know, 1, slot, (100.0, 100.0, -3.0), top, 60.0, 20.0) \
        == plausible.TAKE


def test_an_insider_s_finds_far_from_where_it_has_been_are_refused_and_counted() -> None:
    agent = dynamic_agent()
    know, b = agent.know, agent.know.beliefs
    hear(agent, Pose(2, 10, (100.0, 100.0, -3.0), 0, "transit", Digest(0, 0)), 10.0)
    slot = b.n + 2 * b.cap
    hear(agent, Found(2, 11, Digest(0, 0), slot, (550.0, 550.0, -3.0), 10.0, 60.0), 11.0)
    assert slot not in b.finds
    assert know.suspicion[2] == 1 and agent.counters.get("implausible_find") == 1


def test_near_track_places_a_point_between_poses_and_after_the_last() -> None:
    track = [(0.0, (0.0, 0.0, 0.0)), (100.0, (100.0, 0.0, 0.0))]
    assert plausible.near_track(track, (50.0, 5.0, 0.0), 10.0, 1.0, 100.0)
    # 40 m off the leg: only if it could have detoured (speed x dt / 2 = 50 m of slack)
    assert plausible.near_track(track, (50.0, 40.0, 0.0), 10.0, 1.0, 100.0)
    assert not plausible.near_track(track, (50.0, 40.0, 0.0), 10.0, 0.2, 100.0)
    # after the last pose: within speed x the time since
    assert not plausible.near_track(track, (300.0, 0.0, 0.0), 10.0, 1.0, 150.0)
    assert plausible.near_track(track, (300.0, 0.0, 0.0), 10.0, 1.0, 300.0)
    assert not plausible.near_track([], (0.0, 0.0, 0.0), 10.0, 1.0, 0.0)


def test_a_fleet_without_liars_suspects_nobody() -> None:
    world = World()
    world.run_until(3000.0)
    for vid in ("auv1", "auv2", "auv3"):
        agent = world.agent(vid)
        assert not agent.know.suspicion, (vid, dict(agent.know.suspicion))
        assert not any(k.startswith("implausible_") for k in agent.counters), agent.counters


def test_a_peers_track_says_where_it_was() -> None:
    """`witness.position_on`: linear between its poses, the first before them, None from the
    last on (membership judges a silence where each vehicle was when it began)."""
    from fleet_agent.witness import extend, new_track, position_on

    track = new_track((0.0, 0.0, 0.0))
    for t in (100.0, 200.0, 300.0):
        extend(track, t, (t, 2.0 * t, 0.0))
    assert position_on(track, 150.0) == (150.0, 300.0, 0.0)
    assert position_on(track, -5.0) == (0.0, 0.0, 0.0)
    assert position_on(track, 300.0) is None and position_on(new_track(), 10.0) is None


def test_a_claim_of_its_own_unheard_find_late_in_a_dive_is_taken() -> None:
    """Its FOUND lost, a find is judged where its finder is, not at the slot's placeholder
    (the station): late in a dive that would be beyond its battery, the claim refused, and
    the find planned by a second vehicle (preset seed 2 at 30 % loss, docs/search.md)."""
    agent = dynamic_agent()
    know, b = agent.know, agent.know.beliefs
    spec = know.problem.vehicles[2]
    far = (spec.start[0] + 400.0, spec.start[1] + 400.0, -3.0)
    late = spec.battery_s - 200.0  # 200 s of battery left: the station is 566 m away
    hear(agent, Pose(2, int(late), far, 0, "transit", Digest(0, 0)), late)
    know.clear(know.held_by(2))  # its plan is done
    own, others = b.n + 2 * b.cap, b.n + 1 * b.cap  # auv3's find; auv2's, both unheard
    hear(agent, Claim(2, int(late) + 1, int(late) + 1, (own,)), late + 1)
    assert know.holder(own) == 2 and not know.suspicion
    hear(agent, Claim(2, int(late) + 2, int(late) + 2, (others,)), late + 2)
    assert know.holder(others) != 2 and know.suspicion[2] == 1  # another's: where it is unknown


def test_held_spots_its_track_passed_leave_the_bound_on_all_it_holds() -> None:
    """Hard seed 31 at 30 % loss: auv2's clears of spots it had treated were lost to auv1,
    which then refused auv2's claim of one more spot (all it seemed to hold did not fit its
    battery twice over), took the spot as free and treated it too. A held spot the
    claimer's heard track has passed counts as done in that bound; one it has not passed
    still counts."""
    from fleet_agent.witness import extend, new_track

    def claim_after_passing(passed: bool) -> tuple[Agent, int]:
        agent = dynamic_agent()
        know = agent.know
        spec = know.problem.vehicles[2]
        held = know.held_by(2)
        late = spec.battery_s - 400.0  # 400 s of battery left
        spot = max((t for t in range(know.beliefs.n) if know.holder(t) is None),
                   key=lambda t: min(math.dist(know.problem.xyz[t][:2], know.problem.xyz[h][:2])
                                     for h in held))  # a free spot away from what it holds
        here = tuple(float(c) for c in know.problem.xyz[spot])
        here = (here[0] + 5.0, here[1], here[2])
        if passed:  # its track went over every spot it holds, then here
            track = know.tracks[2] = new_track(spec.start)
            for i, t in enumerate(held):
                extend(track, (late - 100.0) * (i + 1) / len(held), tuple(know.problem.xyz[t]))
        else:  # heard only here, lately
            track = know.tracks[2] = new_track()
        for t in (late - 60.0, late - 30.0):
            extend(track, t, here)
        hear(agent, Pose(2, int(late), here, 0, "transit", Digest(0, 0)), late)
        assert plausible.work_s(know.problem, here, spec.speed_mps, [spot]) < 400.0
        assert plausible.work_s(know.problem, here, spec.speed_mps, [*held, spot]) > 800.0
        hear(agent, Claim(2, int(late) + 1, int(late) + 1, (spot,)), late + 1)
        return agent, spot

    agent, spot = claim_after_passing(True)
    assert agent.know.holder(spot) == 2 and not agent.know.suspicion
    agent, spot = claim_after_passing(False)
    assert agent.know.holder(spot) != 2 and agent.know.suspicion[2] == 1


def test_hard_seed_31_at_30_percent_loss_treats_each_aggregation_once() -> None:
    """The mission the rule above came from (beyond `benchmarks/dynamic.py`'s 20 seeds)."""
    from test_unproven import lossy_mission

    assert lossy_mission("hard", 31)[1] == 0
