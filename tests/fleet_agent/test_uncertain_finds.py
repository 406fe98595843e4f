"""Issue 30 in the agent: finds under navigation error merge by the association rule, a
treated aggregation seen again is never injected, the vehicle's frame follows the map's
landmarks, a search is flown only when it is worth more than the next spot, and a find's
sigma travels in one byte."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fleet_agent.agent import Agent
from fleet_agent.association import probably_treated, sighting
from fleet_agent.beliefs import Beliefs
from fleet_agent.config import AgentConfig
from fleet_agent.fleet import Fleet
from fleet_agent.helms.sim import camera_figures
from fleet_agent.io_types import Helm, Tick
from fleet_agent.landmarks import MapFrame
from fleet_agent.motion import Activity
from fleet_agent import records as rec
from fleet_agent.intents import Hold
from fleet_agent.policies import discovery, searching
from fleet_agent.policies.cooperate import cooperate, held_finds
from fleet_agent.restore import fold
from fleet_agent.wire import MAX_SIGMA_M, Codec, Digest, Found
from fleet_bus.vehicle_port import Arrived, GoTo, Injected, Looked, NavFix, Sighted
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.dynamic import DynamicParams, generate_dynamic_doc
from reef_sim.scenarios.field import GeneratorParams
from reef_sim.truth import reef_from_doc

KEY = bytes(range(16))
RUN = "test-uncertain"
CONFIG = AgentConfig(plan_iterations=30, replan_iterations=10).with_key(KEY)
DRIFT_SIGMA = 3.0  # 1 % drift over 300 m, per axis
# The dynamic generator's exact map: spots where their aggregations are, aggregations points
EXACT = dataclasses.replace(CONFIG, map_sigma_m=0.5, aggregation_extent_m=1.0)


def small_doc(seed: int = 5) -> dict:
    params = DynamicParams(base=GeneratorParams(name="small", n_tasks=30, n_vehicles=3,
                                                size_m=600.0, battery_s=1500.0,
                                                service_s=60.0), n_unmapped=5)
    return generate_dynamic_doc(params, np.random.default_rng(seed))


def build(config: AgentConfig = CONFIG) -> Fleet:
    doc = small_doc()
    problem = problem_from_dict(doc)
    return Fleet.build(problem, KEY, 4, config, run_id=RUN,
                       camera=camera_figures(reef_from_doc(doc, problem)))


@pytest.fixture(scope="module")
def fleet() -> Fleet:
    return build()


def off_map(fleet: Fleet, clear_m: float = 60.0) -> tuple[float, float, float]:
    """A place no predicted spot is within ``clear_m`` of."""
    assert fleet.dynamic is not None
    xyz = fleet.dynamic.scenario.xyz[:fleet.dynamic.scenario.n_tasks]
    for x in np.arange(20.0, 600.0, 13.0):
        for y in np.arange(20.0, 600.0, 17.0):
            if np.linalg.norm(xyz[:, :2] - (x, y), axis=1).min() > clear_m:
                return (float(x), float(y), -3.0)
    raise AssertionError("no place off the map")


def _lonely_spot(fleet: Fleet, but: int | None = None) -> int:
    """The predicted spot farthest from any other (a sighting of it is sure), not ``but``."""
    xy = fleet.dynamic.scenario.xyz[:fleet.dynamic.scenario.n_tasks, :2]
    d = np.linalg.norm(xy[:, None] - xy[None], axis=2)
    np.fill_diagonal(d, np.inf)
    if but is not None:
        d[but] = -1.0
    return int(np.argmax(d.min(axis=1)))


def _send_to(agent: Agent, spot: int) -> None:
    """Route the agent to ``spot`` as its holder (a claim at 0 by the lowest index wins, as
    the initial plan's): a vehicle never injects a spot a live peer holds."""
    agent.know.hold(agent.index, 0, [spot], True)
    assert agent.know.holder(spot) == agent.index
    agent.own.set_route([spot])


# -- merging ------------------------------------------------------------------------------------


def test_two_vehicles_finds_of_one_aggregation_8_m_apart_merge(fleet):
    """Each finder's 1 % drift over 300 m (3 m per axis) with the default rule: 8 m apart is
    one aggregation (d2 = 2.1), 40 m apart two (d2 = 52)."""
    b = Beliefs(fleet.dynamic.scenario, fleet.dynamic.camera, CONFIG, 0, 0, 7.5)
    pos = off_map(fleet)
    a, c, far = b.n + CONFIG.find_slots, b.n + 2 * CONFIG.find_slots, b.n + 1
    assert b.add_find(c, pos, 40.0, 60.0, 0.0, DRIFT_SIGMA)
    assert b.add_find(a, (pos[0] + 8.0, pos[1], pos[2]), 40.0, 60.0, 0.0, DRIFT_SIGMA)
    assert b.alias == {c: a}
    assert b.add_find(far, (pos[0] - 40.0, pos[1], pos[2]), 40.0, 60.0, 0.0, DRIFT_SIGMA)
    assert b.alias == {c: a}  # 40 m off: another aggregation


def test_merging_is_order_free_and_transitive(fleet):
    """Every vehicle folds the same aliases from the same finds, whatever their order."""
    pos = off_map(fleet)
    n = fleet.dynamic.scenario.n_tasks
    finds = [(n + 2 * CONFIG.find_slots, 0.0), (n + CONFIG.find_slots, 7.0), (n + 3, 14.0)]
    aliases = set()
    for order in ([0, 1, 2], [2, 1, 0], [1, 2, 0]):
        b = Beliefs(fleet.dynamic.scenario, fleet.dynamic.camera, CONFIG, 0, 0, 7.5)
        for k in order:
            slot, dx = finds[k]
            b.add_find(slot, (pos[0] + dx, pos[1], pos[2]), 40.0, 60.0, 0.0, 1.0)
        aliases.add(tuple(sorted(b.alias.items())))
    assert aliases == {((n + CONFIG.find_slots, n + 3), (n + 2 * CONFIG.find_slots, n + 3))}


# -- never twice --------------------------------------------------------------------------------


def test_a_treated_aggregation_seen_again_is_not_injected(fleet):
    """auv2 treats its find; seen again 6 m off by a drifted camera it is no news, and a
    peer's find of it (heard) is judged treated once nobody alive holds it: cleared, never
    in the route. While its finder lives, the find is the finder's to judge."""
    agent = Agent(fleet, 1, CONFIG)
    pos = off_map(fleet)
    agent.step(Tick(1.0), [NavFix(1.0, pos, sigma_m=DRIFT_SIGMA),
                           Sighted(1.0, pos, 50.0, 60.0)])
    b, know = agent.know.beliefs, agent.know
    (slot,) = b.finds
    assert b.finds[slot].sigma_m == pytest.approx(3.0, abs=0.5)
    know.treat(slot, 2.0)
    again = (pos[0] + 6.0, pos[1], pos[2])
    agent.step(Tick(3.0), [Sighted(3.0, again, 50.0, 60.0)])
    assert len(b.finds) == 1 and agent.counters.get("sightings_ignored", 0) == 0

    codec = fleet.codec

    def heard(slot: int, at: tuple[float, float, float], seq: int) -> None:
        msg = codec.decode(codec.encode(Found(2, seq, Digest(1, 0), slot, at, 50.0, 60.0,
                                              sigma_m=DRIFT_SIGMA)))
        discovery.on_found(know, msg, float(seq))
        agent.step(Tick(float(seq) + 1.0))

    # a peer (auv3) that saw it 6 m off names it: one aggregation, an alias nobody plans
    peer = b.n + 2 * CONFIG.find_slots
    heard(peer, again, 4)
    assert b.alias == {peer: slot} and peer in b.blocked(1e9)
    # 18 m off: beyond the merge gate (0.99), inside the looser "treated" one (0.999)
    other = peer + 1
    heard(other, (pos[0], pos[1] + 18.0, pos[2]), 6)
    assert other not in b.alias
    assert know.holder(other) == 2 and other not in know.cleared  # auv3 judges its own
    assert know.members.mark(2, "lost", 7.0)
    agent.step(Tick(8.0))
    assert other in know.cleared and other in know.folded
    assert agent.counters["spots_judged_treated"] == 1
    assert peer not in agent.own.route and other not in agent.own.route


def test_where_an_injection_really_was_is_held_against_later_sightings(fleet):
    """A drifted vehicle sent to a spot may inject a neighbour in view there: the camera's
    measure of what it injected (`Injected.pos`) is a treated estimate, so that neighbour
    seen later is no news; the journal keeps it for a restart."""
    agent = Agent(fleet, 0, CONFIG)
    know = agent.know
    head = agent.own.route[0]
    p = fleet.dynamic.scenario.tasks[head].pos
    agent.step(Tick(1.0), [NavFix(1.0, p, sigma_m=DRIFT_SIGMA), Arrived(1.0, head)])
    agent.step(Tick(2.0), [Looked(2.0, head, True, 50.0, 60.0)])
    neighbour = (p[0] + 25.0, p[1], p[2])  # what it really injected, 25 m off its spot
    agent.step(Tick(70.0), [Injected(70.0, head, neighbour)])
    assert head in know.cleared and len(know.injections) == 1
    finds = len(know.beliefs.finds)
    agent.step(Tick(80.0), [Sighted(80.0, (neighbour[0] + 2.0, p[1], p[2]), 50.0, 60.0)])
    assert len(know.beliefs.finds) == finds
    assert agent.counters["sightings_treated"] == 1
    clr = rec.parse(rec.Clear(70.0, (head,), True, (*neighbour[:2], 3.0)).doc())
    assert isinstance(clr, rec.Clear) and clr.at == (*neighbour[:2], 3.0)
    snap = fold([{"k": "start", "t": 0.0}, clr.doc()], fleet.problem.n_tasks)
    assert snap.injections == [(*neighbour[:2], 3.0)]


def test_a_find_waits_while_a_peers_cleared_find_is_unknown(fleet):
    """Under loss a peer's cleared set may arrive without its FOUND: the find it cleared
    could be the aggregation this vehicle found under its own name. Its own find waits (out
    of every plan) until the peer's find is heard, then is judged as usual: here one
    aggregation, so treated, never planned."""
    agent = Agent(fleet, 1, CONFIG)
    know, b = agent.know, agent.know.beliefs
    pos = off_map(fleet)
    agent.step(Tick(1.0), [NavFix(1.0, pos), Sighted(1.0, pos, 50.0, 60.0)])
    (mine,) = b.finds
    theirs = b.n + 2 * CONFIG.find_slots  # auv3's first find: cleared, never heard
    know.clear([theirs])
    agent.step(Tick(2.0))
    assert know.awaiting == {mine} and mine in know.unavailable(2.0)
    assert mine not in know.free_spots(2.0)
    codec = fleet.codec
    msg = codec.decode(codec.encode(Found(2, 1, Digest(1, 0), theirs, pos, 50.0, 60.0)))
    discovery.on_found(know, msg, 3.0)
    agent.step(Tick(4.0))
    assert know.awaiting == frozenset()
    assert mine in know.cleared and mine not in agent.own.route


def test_a_find_waits_while_a_peers_claimed_find_is_unknown_and_leaves_the_route(fleet):
    """Two vehicles side by side name one aggregation seconds apart; the first one's claim
    is on the air before its FOUND. A claim of a find unknown here holds this vehicle's
    finds near the claimer as a cleared one does, and a held find leaves the route the
    vehicle is already flying, not only its replans."""
    agent = Agent(fleet, 1, CONFIG)
    know, b = agent.know, agent.know.beliefs
    pos = off_map(fleet)
    agent.step(Tick(1.0), [NavFix(1.0, pos), Sighted(1.0, pos, 50.0, 60.0)])
    (mine,) = b.finds
    know.hold(1, 2, [mine], True)
    agent.own.route = [mine]
    theirs = b.n + 2 * CONFIG.find_slots  # auv3's first find: claimed, its FOUND unheard
    know.hold(2, 1, [theirs], True)
    out = agent.step(Tick(3.0))
    assert know.awaiting == {mine} and mine not in agent.own.route, out
    codec = fleet.codec
    msg = codec.decode(codec.encode(Found(2, 1, Digest(1, 0), theirs, pos, 50.0, 60.0)))
    discovery.on_found(know, msg, 4.0)
    agent.step(Tick(5.0))
    # one aggregation under two names: auv3 claimed it first (1 s against 2 s), so it holds
    # it under either name, and this vehicle never flies to it
    assert know.awaiting == frozenset() and b.alias == {theirs: mine}
    assert know.holder(mine) == 2 and mine not in know.held_by(1)
    assert mine not in agent.own.route and know.held_map()[mine] == 2


def test_a_find_waits_while_a_peers_released_find_is_unknown(fleet):
    """A release names a find as a claim does: it exists, where is unknown. A fault fuzz
    (hard reef, 2 % drift, 50 % loss, seed 94): auv2 heard auv3 release its find 145 (a
    claim then a release; neither its FOUND nor its claims came through), named the same
    aggregation find 118 and treated it 80 s after auv3."""
    agent = Agent(fleet, 1, CONFIG)
    know, b = agent.know, agent.know.beliefs
    pos = off_map(fleet)
    agent.step(Tick(1.0), [NavFix(1.0, pos), Sighted(1.0, pos, 50.0, 60.0)])
    (mine,) = b.finds
    theirs = b.n + 2 * CONFIG.find_slots  # auv3's first find: released, its FOUND unheard
    know.hold(2, 1, [theirs], False)
    agent.step(Tick(2.0))
    assert know.awaiting == {mine} and mine in know.unavailable(2.0)
    codec = fleet.codec
    msg = codec.decode(codec.encode(Found(2, 1, Digest(1, 0), theirs, pos, 50.0, 60.0)))
    discovery.on_found(know, msg, 3.0)
    agent.step(Tick(4.0))
    assert know.awaiting == frozenset() and b.alias == {theirs: mine}


def test_a_claim_under_an_alias_settles_a_cycle_after_the_other_name_is_learned(fleet):
    """A vehicle that holds an aggregation through its own name learns the other name late:
    claims under that name were in flight before it knew to look for them."""
    agent = Agent(fleet, 1, CONFIG)
    know, b = agent.know, agent.know.beliefs
    pos = off_map(fleet)
    theirs = b.n + 0 * CONFIG.find_slots  # auv1's first find: the lower slot, the spot
    agent.step(Tick(1.0), [NavFix(1.0, pos), Sighted(1.0, pos, 50.0, 60.0)])
    (mine,) = b.finds
    know.hold(1, 2, [mine], True)
    assert know.settled_s(mine) == 2 + know.claim_settle_s
    codec = fleet.codec
    msg = codec.decode(codec.encode(Found(0, 1, Digest(1, 0), theirs, pos, 50.0, 60.0)))
    discovery.on_found(know, msg, 40.0)
    # auv0 holds its find from its FOUND on (a claim at 0), until it claims in its own time
    assert b.alias == {mine: theirs} and know.holder(theirs) == 0
    assert theirs not in know.held_by(1)
    know.hold(0, 50, [theirs], True)  # later than ours: ours holds
    assert know.holder(theirs) == 1
    assert know.settled_s(theirs) == 40.0 + know.claim_settle_s


def test_a_peer_that_heard_the_found_and_not_the_claim_leaves_the_find_to_its_finder(fleet):
    """The claim race of hard seed 15 at 1 % drift: a peer heard a find's FOUND and not its
    finder's claim, took the settled find for free, and both treated it. A find is its
    finder's from the FOUND on: not free, not in anyone else's plan, until its finder gives
    it up or is gone."""
    agent = Agent(fleet, 1, CONFIG)
    know, b = agent.know, agent.know.beliefs
    theirs = b.n  # auv1's first find
    codec = fleet.codec
    msg = codec.decode(codec.encode(Found(0, 1, Digest(1, 0), theirs, off_map(fleet), 90.0,
                                          60.0)))
    discovery.on_found(know, msg, 10.0)
    later = 10.0 + b.settle_s + 1.0
    assert theirs not in b.blocked(later)  # settled: planned by whoever may
    assert know.holder(theirs) == 0 and theirs not in know.free_spots(later)
    assert theirs not in held_finds(know, later)  # the finder's to weigh, not ours
    assert theirs not in cooperate(know, CONFIG, later)[-1:] and theirs not in agent.own.route
    know.hold(0, int(later), [theirs], False)  # its finder gave it up: the fleet's now
    assert know.holder(theirs) is None and theirs in know.free_spots(later)


def test_a_find_of_a_finder_gone_home_or_lost_is_free():
    fleet = build()
    agent = Agent(fleet, 1, CONFIG)
    know, b = agent.know, agent.know.beliefs
    theirs, other = b.n, b.n + 2 * CONFIG.find_slots
    codec = fleet.codec
    pos = off_map(fleet)
    for finder, slot, dx in ((0, theirs, 0.0), (2, other, 30.0)):
        msg = codec.decode(codec.encode(Found(finder, 1, Digest(1, 0), slot,
                                              (pos[0] + dx, pos[1], pos[2]), 40.0, 60.0)))
        discovery.on_found(know, msg, 10.0)
    later = 10.0 + b.settle_s + 1.0
    assert {theirs, other} <= set(b.finds)
    assert {theirs, other}.isdisjoint(know.free_spots(later))
    assert know.members.mark(0, "home", later) and know.members.mark(2, "lost", later)
    assert {theirs, other} <= know.free_spots(later)  # home without it; lost: taken over


def test_a_finder_weighs_its_held_find_then_claims_it_or_gives_it_up(fleet):
    agent = Agent(fleet, 1, CONFIG)
    know, b = agent.know, agent.know.beliefs
    pos = off_map(fleet)
    agent.step(Tick(1.0), [NavFix(1.0, pos), Sighted(1.0, pos, 90.0, 60.0)])
    (mine,) = b.finds
    assert know.holder(mine) == 1 and held_finds(know, 1.0) == []  # settling: not weighed yet
    assert mine not in agent.own.route  # nor flown to
    later = b.finds[mine].learned_s + b.settle_s + 1.0
    assert held_finds(know, later) == [mine]
    out = cooperate(know, CONFIG, later)
    holds = [i for i in out if isinstance(i, Hold)]
    assert holds == [Hold((mine,), True)]  # rich and next to it: taken on, in its own time
    agent.own.capacity_s = agent.own.t_s + 1.0  # no battery left for anything
    out = cooperate(know, CONFIG, later)
    assert Hold((mine,), False) in out  # given up to the fleet


def test_a_predicted_spot_is_judged_treated_only_by_a_treated_find(fleet):
    """The map says its spots are distinct: a treated predicted spot never clears another;
    a treated find within the gate of one does (a drifted vehicle took it for news)."""
    agent = Agent(fleet, 0, CONFIG)
    b, know = agent.know.beliefs, agent.know
    sc = fleet.dynamic.scenario
    d = np.linalg.norm(sc.xyz[:b.n, None, :2] - sc.xyz[None, :b.n, :2], axis=2)
    np.fill_diagonal(d, np.inf)
    t, u = map(int, np.unravel_index(np.argmin(d), d.shape))  # the two closest spots
    know.treat(t, 1.0)
    agent.step(Tick(2.0))
    assert u not in know.cleared
    slot = b.own_slot()
    pos = sc.tasks[u].pos
    assert b.add_find(slot, (pos[0] + 2.0, pos[1], pos[2]), 30.0, 60.0, 2.0, 1.0)
    know.treat(slot, 3.0)
    agent.step(Tick(4.0))
    assert u in know.cleared and u in know.folded


# -- the vehicle's frame ----------------------------------------------------------------------


def test_a_landmark_corrects_the_frame_and_a_fix_starts_it_again():
    frame = MapFrame()
    frame.nav(10.0)  # 10 m per axis of drift
    assert frame.landmark((105.0, 48.0), (100.0, 50.0), 0.5)
    assert frame.offset == pytest.approx((5.0 * 100 / 100.5, -2.0 * 100 / 100.5))
    assert frame.sigma_m < 1.0
    assert frame.to_vehicle(frame.to_map((1.0, 2.0, -3.0))) == pytest.approx((1.0, 2.0, -3.0))
    frame.nav(12.0)  # drift since: the offset is as uncertain as what grew
    assert frame.var == pytest.approx(100 * 0.5 / 100.5 + 144 - 100)
    frame.nav(1.0)  # a USBL fix: the vehicle's frame moved
    assert frame.offset == (0.0, 0.0) and frame.sigma_m == pytest.approx(1.0)


def test_with_exact_navigation_the_frame_never_moves():
    frame = MapFrame()
    frame.nav(0.0)
    assert not frame.landmark((105.0, 48.0), (100.0, 50.0), 0.5)
    assert frame.offset == (0.0, 0.0)


def test_a_look_at_a_predicted_spot_moves_the_goals(fleet):
    """A drifted vehicle (3 m per axis) looks at its first spot and its camera shows the
    COTS 3 m east of the map's: its frame's offset is the Kalman update toward 3 m east, and
    the next goal it is sent to moves by it, in its own frame."""
    f = build(EXACT)
    agent = Agent(f, 0, EXACT)
    head = agent.own.route[0]
    p = f.dynamic.scenario.tasks[head].pos
    agent.step(Tick(1.0), [NavFix(1.0, p, sigma_m=DRIFT_SIGMA), Arrived(1.0, head)])
    assert agent.own.inspecting == head
    agent.step(Tick(2.0), [Looked(2.0, head, True, 50.0, 60.0, (p[0] + 3.0, p[1], p[2]))])
    assert agent.own.frame.fixes == 1
    ox, oy = agent.own.frame.offset
    r = 0.5 ** 2 + 0.5 ** 2 + 1.0 ** 2 / 4  # map, camera, a point of the aggregation
    assert ox == pytest.approx(3.0 * 9 / (9 + r)) and oy == pytest.approx(0.0, abs=1e-9)
    agent.step(Tick(70.0), [Injected(70.0, head)])
    after = agent.own.command()
    assert isinstance(after, GoTo)
    goal = after.waypoints[-1]
    target = agent.own.problem.xyz[after.target]
    assert goal[0] - target[0] == pytest.approx(ox) and goal[1] - target[1] == pytest.approx(oy)


def test_a_sighting_along_the_track_never_moves_the_frame(fleet):
    """Which spot a sighting is rests on the frame itself (a missed aggregation near a
    spot, taken for it, would move the frame and then confirm itself): only looks do."""
    f = build(EXACT)
    agent = Agent(f, 0, EXACT)
    spot = _lonely_spot(f)
    p = f.dynamic.scenario.tasks[spot].pos  # the loneliest spot: surely the one seen
    agent.step(Tick(1.0), [NavFix(1.0, agent.own.pos, sigma_m=DRIFT_SIGMA),
                           Sighted(1.0, (p[0] + 3.0, p[1], p[2]), 50.0, 60.0)])
    assert agent.own.frame.fixes == 0 and agent.own.frame.offset == (0.0, 0.0)
    assert agent.know.beliefs.state[spot] == "present"  # what it saw is still learnt


def test_the_frame_grows_with_the_way_from_its_landmark_not_from_the_start():
    """After a landmark far from the start, a vehicle crossing at a constant distance from
    home keeps its own sigma, but its error changes by the drift rate times the way from
    the landmark (heading and scale biases): the frame's variance says so. And heading back
    toward the start (its sigma falls smoothly) is no position fix."""
    frame = MapFrame()
    k = 0.01
    frame.nav(0.0, (0.0, 0.0))
    frame.nav(k * 500.0, (500.0, 0.0))  # the rate is read: 1 % per metre
    assert frame.rate2 == pytest.approx(k * k)
    assert frame.landmark((505.0, 0.0), (500.0, 0.0), 0.5)
    small = frame.var
    frame.nav(k * 500.0, (0.0, 500.0))  # a quarter circle around home: the same sigma
    way = math.dist((505.0, 0.0), (0.0, 500.0))
    assert frame.var == pytest.approx(small + k * k * way ** 2)
    offset = frame.offset
    frame.nav(k * 490.0, (0.0, 490.0))  # 10 m back toward home: no fix
    assert frame.offset == offset
    frame.nav(1.0, (0.0, 480.0))  # a USBL fix: the frame starts again
    assert frame.offset == (0.0, 0.0) and frame.sigma_m == pytest.approx(1.0)


# -- search -------------------------------------------------------------------------------------


def searcher(fleet_config: AgentConfig) -> tuple[Agent, int]:
    f = build(fleet_config)
    agent = Agent(f, 0, fleet_config)
    assert agent.know.search is not None
    own = agent.own
    task = own.route[0]
    own.activity, own.busy_until_s = Activity.INJECTING, 60.0
    own.pos = tuple(float(c) for c in agent.problem.xyz[task])
    return agent, task


def nothing_else(agent: Agent, task: int) -> None:
    """Every other spot done: the way home is all that is left after ``task``."""
    agent.know.clear([t for t in range(agent.know.beliefs.n) if t != task])
    agent.own.route = [task]


SEARCH = dataclasses.replace(CONFIG, search_per_spot=0.45, search_ring_min_m=10.0,
                             search_ring_max_m=70.0, search_empty_weight=0.3)


def test_a_search_is_chosen_only_when_it_beats_the_next_known_spot():
    """After an injection: with its next spot worth its expected value the vehicle goes on;
    with a next spot worth nothing (or none) it orbits the spot it treated, and the orbit is
    flown on its way and counted in its time."""
    agent, task = searcher(SEARCH)
    nxt = agent.own.route[1]
    assert agent.problem.priority[nxt] > 0
    agent.step(Tick(60.0), [Injected(60.0, task)])
    assert agent.counters.get("searches_declined") == 1 and agent.own.detour is None

    agent, task = searcher(SEARCH)
    nothing_else(agent, task)
    finish = agent.own.time_to_finish_s([])
    out = agent.step(Tick(60.0), [Injected(60.0, task)])
    assert agent.counters.get("searches") == 1 and agent.own.detour is not None
    waypoints, duration = agent.own.detour
    assert math.dist(waypoints[0][:2], waypoints[-1][:2]) < 1e-6  # back where it began
    assert agent.own.time_to_finish_s() == pytest.approx(finish + duration, rel=0.05)
    helm = [o for o in out if isinstance(o, Helm)]
    assert helm  # the orbit first, then the way home
    np.testing.assert_allclose(helm[-1].command.waypoints[:len(waypoints) - 1], waypoints[1:])


def test_a_spot_is_weighed_for_a_search_once():
    agent, task = searcher(SEARCH)
    nothing_else(agent, task)
    agent.step(Tick(60.0), [Injected(60.0, task)])
    assert searching.after_injection(agent.know, SEARCH, task) == []
    assert agent.counters.get("searches") == 1


def test_without_a_belief_nothing_is_searched(fleet):
    agent = Agent(fleet, 0, CONFIG)
    assert agent.know.search is None
    assert searching.after_injection(agent.know, CONFIG, agent.own.route[0]) == []


# -- the wire ---------------------------------------------------------------------------------


@pytest.mark.parametrize("sigma,back", [(0.0, 0.0), (0.5, 0.5), (3.04, 3.5), (12.0, 12.0),
                                        (1e6, MAX_SIGMA_M)])
def test_a_finds_sigma_round_trips_in_its_byte_rounded_up(fleet, sigma, back):
    codec: Codec = fleet.codec
    n = fleet.dynamic.scenario.n_tasks
    msg = Found(1, 9, Digest(3, 77), n + 2, (100.0, 200.0, -3.0), 42.5, 61.0, sigma_m=sigma)
    frame = codec.encode(msg)
    assert len(frame) <= codec.max_frame_bytes
    got = codec.decode(frame)
    assert got.sigma_m == back and got.slot == n + 2 and got.priority == 42.5


def _held_rebuilt(know) -> dict[int, int]:
    """`Knowledge.held_map` computed from scratch: every spot's holder under any of its
    names, nobody's cleared spots and no alias."""
    alias, cleared = know.beliefs.alias, know.cleared
    held = {t: h for t, h in know.holdings.holders(know.members.alive).items()
            if t not in cleared and t not in alias}
    for head in {h for h in alias.values() if h not in cleared}:
        v = know.holder(head)
        if v is None:
            held.pop(head, None)
        else:
            held[head] = v
    return held


@pytest.mark.parametrize("seed", range(4))
def test_the_held_map_kept_up_to_date_equals_one_rebuilt(fleet, seed):
    """`held_map` is brought up to date from the spots touched since; at every step it
    equals the map walked over every spot, through claims, releases, clears, finds that
    merge and a peer that aborts."""
    rng = np.random.default_rng(seed)
    agent = Agent(fleet, 0, CONFIG)
    know, b = agent.know, agent.know.beliefs
    base = off_map(fleet)
    slots = [b.n + v * CONFIG.find_slots + i for v in range(3) for i in range(2)]
    n = know.problem.n_tasks
    for step in range(160):
        op = rng.integers(6)
        if op <= 1:
            tasks = [int(t) for t in rng.choice([*range(b.n), *slots], size=2)]
            know.hold(int(rng.integers(3)), int(rng.integers(1, 50)), tasks, bool(op))
        elif op == 2:
            know.clear([int(rng.integers(n))])
        elif op == 3 and slots:
            slot = slots.pop(int(rng.integers(len(slots))))
            near = (base[0] + float(rng.uniform(-6, 6)), base[1], base[2])
            b.add_find(slot, near, 40.0, 60.0, float(step), DRIFT_SIGMA)
        if step == 80:
            assert know.members.mark(2, "aborted", float(step))
        if rng.random() < 0.5:
            assert know.held_map() == _held_rebuilt(know), step
    assert b.alias and know.members.status(2) == "aborted"
    assert know.held_map() == _held_rebuilt(know)


def _inject_at_head(agent: Agent, fleet: Fleet, measured: tuple[float, float, float]) -> int:
    """The agent's first spot: arrive, look (present), inject what its camera measured at
    ``measured``; the spot."""
    head = agent.own.route[0]
    p = fleet.dynamic.scenario.tasks[head].pos
    agent.step(Tick(1.0), [NavFix(1.0, p, sigma_m=DRIFT_SIGMA), Arrived(1.0, head)])
    agent.step(Tick(2.0), [Looked(2.0, head, True, 50.0, 60.0)])
    agent.step(Tick(70.0), [Injected(70.0, head, measured)])
    assert head in agent.know.cleared and len(agent.know.injections) == 1
    return head


@pytest.mark.parametrize("seen_off_m, treated", [(13.0, True), (0.0, False)])
def test_a_look_showing_what_this_vehicle_injected_is_not_injected_again(fleet, seen_off_m,
                                                                         treated):
    """Green Island, 1 % drift: sent to two spots 13.5 m apart with one aggregation between
    them, a vehicle injected it from both. Its camera measured the first injection 13 m
    from the second spot; a look there showing COTS at that measure is that aggregation
    (judged treated, not injected); COTS on the spot itself are its own, and injected."""
    agent = Agent(fleet, 0, CONFIG)
    know = agent.know
    u = _lonely_spot(fleet, agent.own.route[0])
    q = fleet.dynamic.scenario.tasks[u].pos
    _inject_at_head(agent, fleet, (q[0] + 13.0, q[1], q[2]))
    _send_to(agent, u)
    agent.step(Tick(80.0), [NavFix(80.0, q, sigma_m=DRIFT_SIGMA), Arrived(80.0, u)])
    assert agent.own.inspecting == u
    seen = (q[0] + seen_off_m + 0.5, q[1], q[2])
    agent.step(Tick(90.0), [Looked(90.0, u, True, 50.0, 60.0, seen)])
    assert (agent.own.injecting == u) is not treated
    assert (u in know.cleared and u in know.folded) is treated
    assert agent.counters.get("looks_treated", 0) == int(treated)


@pytest.mark.parametrize("injected_off_m, doubted", [(5.0, True), (60.0, False)])
def test_a_spot_known_present_from_a_sighting_is_looked_at_after_an_injection_near_it(
        fleet, injected_off_m, doubted):
    """Hard reef seed 9, 1 % drift: auv3 sighted "spot 38" along its track, then treated
    spot 1 nearby, and at 38 injected without a look what it had treated at 1. A spot known
    present from a sighting alone is unknown again (looked at before any injection) once the
    vehicle injects something near it; far from it, it stays known."""
    agent = Agent(fleet, 0, CONFIG)
    b = agent.know.beliefs
    u = _lonely_spot(fleet, agent.own.route[0])
    q = fleet.dynamic.scenario.tasks[u].pos
    agent.step(Tick(0.5), [NavFix(0.5, q, sigma_m=DRIFT_SIGMA), Sighted(0.5, q, 50.0, 60.0)])
    assert b.state[u] == "present" and u in b.sighted
    _inject_at_head(agent, fleet, (q[0] + injected_off_m, q[1], q[2]))
    assert (b.state[u] == "unknown") is doubted and (u in b.sighted) is not doubted
    assert b.unknown(u) is doubted  # unknown: the vehicle looks before it injects


def test_a_spot_sighted_where_the_vehicle_then_injects_is_looked_at_whatever_the_map_says(fleet):
    """A fault fuzz (hard reef, 1 % drift, fixes every 900 s, seed 169): auv3 took an
    aggregation for spot 78 while its sigma was large, treated it as spot 83, and injected it
    again at 78, whose place on the map lay beyond the treated gate of the injection. Where
    the camera saw what it took for the spot counts too: the sighting kept its own sigma."""
    agent = Agent(fleet, 0, CONFIG)
    b = agent.know.beliefs
    u = _lonely_spot(fleet, agent.own.route[0])
    q = fleet.dynamic.scenario.tasks[u].pos
    seen = (q[0] + 30.0, q[1], q[2])
    agent.step(Tick(0.5), [NavFix(0.5, q, sigma_m=12.0), Sighted(0.5, seen, 50.0, 60.0)])
    assert b.state[u] == "present" and u in b.sighted  # sure at a sigma of 12 m
    assert not probably_treated(b.estimate(u), (sighting(seen, DRIFT_SIGMA, b.params),),
                                b.params)  # the map's u is beyond the gate of an injection
    _inject_at_head(agent, fleet, seen)  # at a sigma of 3 m, what the camera saw at 0.5 s
    assert b.state[u] == "unknown" and u not in b.sighted
    assert b.unknown(u)  # the vehicle looks before it injects


# -- the priority beside the position -----------------------------------------------------------


def test_finds_in_one_gate_of_unlike_rho_stay_two_and_too_close_to_aim_between_are_one(fleet):
    """Two finds 20 m apart by finders 8 m unsure: one by position (the 0.99 gate reaches
    34 m), two by their rho (51 and 13.7: the cameras would not differ so); 1 m apart
    they are one whatever their rho (a vehicle sent to one treats whichever is nearer)."""
    b = Beliefs(fleet.dynamic.scenario, fleet.dynamic.camera, CONFIG, 0, 0, 7.5)
    pos = off_map(fleet)
    a, c = b.n + CONFIG.find_slots, b.n + 2 * CONFIG.find_slots
    assert b.add_find(a, pos, 51.0, 60.0, 0.0, 8.0)
    assert b.add_find(c, (pos[0] + 20.0, pos[1], pos[2]), 13.7, 60.0, 0.0, 8.0)
    assert b.alias == {}
    assert b.add_find(c + 1, (pos[0], pos[1] + 20.0, pos[2]), 51.0, 60.0, 0.0, 8.0)
    assert b.alias == {c + 1: a}  # the same rho: the first aggregation seen again
    assert b.add_find(c + 2, (pos[0], pos[1] + 1.0, pos[2]), 90.0, 60.0, 0.0, 2.0)
    assert b.alias == {c + 1: a, c + 2: a}


def test_a_sighting_in_a_finds_gate_of_another_rho_is_named(fleet):
    """The loss measured at 1 % drift: sightings of an aggregation the map missed taken
    for a known find 20-30 m off. Its rho tells it apart: a find of its own."""
    agent = Agent(fleet, 1, CONFIG)
    pos = off_map(fleet)
    agent.step(Tick(1.0), [NavFix(1.0, pos, sigma_m=8.0), Sighted(1.0, pos, 51.0, 60.0)])
    near = (pos[0] + 20.0, pos[1], pos[2])
    agent.step(Tick(2.0), [Sighted(2.0, near, 51.0, 60.0)])
    assert len(agent.know.beliefs.finds) == 1  # the same aggregation, seen again
    agent.step(Tick(3.0), [Sighted(3.0, near, 13.7, 60.0)])
    b = agent.know.beliefs
    assert sorted(f.priority for f in b.finds.values()) == [13.7, 51.0] and not b.alias


@pytest.mark.parametrize("rho, elsewhere", [(50.0, False), (50.0 * 1.2, False),
                                            (12.0, True)])
def test_an_injection_that_measured_another_rho_tells_the_fleet_what_it_treated(
        fleet, rho, elsewhere):
    """A drifted vehicle sent to a spot treats whatever is in view (preset seed 17, 1 %
    drift: sent to spot 0, auv2 injected spot 28's aggregation 18 m off, and auv3 injected
    it again at 28). The camera's rho of what it injected against the look's: another
    aggregation is named a find and cleared at once, so the fleet holds it treated; the
    look's own (within the camera's error) is nothing more."""
    agent = Agent(fleet, 0, CONFIG)
    know = agent.know
    pos = off_map(fleet)
    head = agent.own.route[0]
    p = fleet.dynamic.scenario.tasks[head].pos
    agent.step(Tick(1.0), [NavFix(1.0, p, sigma_m=DRIFT_SIGMA), Arrived(1.0, head)])
    agent.step(Tick(2.0), [Looked(2.0, head, True, 50.0, 60.0)])
    agent.step(Tick(70.0), [NavFix(70.0, pos, sigma_m=DRIFT_SIGMA),
                            Injected(70.0, head, pos, rho)])
    assert head in know.cleared
    b = know.beliefs
    named = [s for s, f in b.finds.items() if f.priority == rho]
    assert agent.counters.get("injected_elsewhere", 0) == int(elsewhere)
    assert len(named) == int(elsewhere)
    if elsewhere:
        assert named[0] in know.cleared
        # a peer's later sighting of it there is no news: it is held treated
        finds = len(b.finds)
        agent.step(Tick(80.0), [Sighted(80.0, (pos[0] + 3.0, pos[1], pos[2]), rho, 60.0)])
        assert len(b.finds) == finds


def test_an_injection_elsewhere_at_a_known_find_clears_that_find(fleet):
    agent = Agent(fleet, 0, CONFIG)
    know = agent.know
    pos = off_map(fleet)
    peer = know.beliefs.n + 2 * CONFIG.find_slots
    codec = fleet.codec
    msg = codec.decode(codec.encode(Found(2, 1, Digest(1, 0), peer, pos, 12.0, 60.0,
                                          sigma_m=DRIFT_SIGMA)))
    discovery.on_found(know, msg, 1.0)
    head = agent.own.route[0]
    p = fleet.dynamic.scenario.tasks[head].pos
    agent.step(Tick(1.0), [NavFix(1.0, p, sigma_m=DRIFT_SIGMA), Arrived(1.0, head)])
    agent.step(Tick(2.0), [Looked(2.0, head, True, 50.0, 60.0)])
    agent.step(Tick(70.0), [NavFix(70.0, pos, sigma_m=DRIFT_SIGMA),
                            Injected(70.0, head, (pos[0] + 2.0, pos[1], pos[2]), 12.0)])
    assert peer in know.cleared and len(know.beliefs.finds) == 1
    assert agent.counters["injected_elsewhere"] == 1


@pytest.mark.parametrize("sigma_m, looks", [(1.0, False), (8.0, True)])
def test_a_spot_known_from_an_unsure_sighting_is_looked_at_before_it_is_injected(
        sigma_m, looks):
    """Preset seed 17 at 1 % drift: auv3 knew spot 28 present from a sighting 8 m unsure
    (of another aggregation), injected there without a look, and treated what auv2 had
    treated as spot 0. Above `look_first_sigma_m` the sighting still raises the spot's
    value, and the vehicle looks (its camera names the aggregation; a landmark for its
    frame) before injecting; a sure navigation injects at once."""
    f = build(EXACT)
    agent = Agent(f, 0, EXACT)
    spot = _lonely_spot(f)
    p = f.dynamic.scenario.tasks[spot].pos
    agent.step(Tick(1.0), [NavFix(1.0, agent.own.pos, sigma_m=sigma_m),
                           Sighted(1.0, (p[0] + 1.0, p[1], p[2]), 50.0, 60.0)])
    b = agent.know.beliefs
    assert b.state[spot] == "present" and b.unknown(spot) is looks
    _send_to(agent, spot)
    agent.step(Tick(2.0), [NavFix(2.0, p, sigma_m=sigma_m), Arrived(2.0, spot)])
    assert (agent.own.inspecting == spot) is looks
    assert (agent.own.injecting == spot) is not looks
    if looks:  # the look settles it: injected, and no look again
        agent.step(Tick(30.0), [Looked(30.0, spot, True, 50.0, 60.0)])
        assert agent.own.injecting == spot and not b.unknown(spot)


@pytest.mark.parametrize("sigma_m, treated_m, treated_rho, seen, outcome", [
    (1.0, 20.0, 60.0, None, "injected"),  # sure of itself and of the find: no look
    (6.0, 80.0, 60.0, None, "injected"),  # unsure, but nothing treated near: no look
    (6.0, 20.0, 2.6, None, "injected"),  # a treated neighbour alike: a look cannot tell
    (6.0, 20.0, 60.0, 2.5, "injected"),  # the look shows the find's rho: injected
    (6.0, 20.0, 60.0, 60.0, "not the find"),  # another rho: a neighbour, not injected
    (6.0, 20.0, 60.0, 0.0, "empty"),  # nothing under the camera: cleared, as an empty spot
])
def test_a_find_near_a_treated_one_is_looked_at_first_when_navigation_is_unsure(
        sigma_m, treated_m, treated_rho, seen, outcome):
    """Hard seed 37 at 1 % drift: auv1 treated an aggregation of rho 60 as find 96; auv3,
    sent to find 97 (rho 2.5) 23 m away on the map, stood over 96's aggregation and
    injected it again. A vehicle whose navigation and the find's finder's together may put
    it over a treated neighbour looks first; a look showing another rho is a neighbour: not
    injected, the find left out of this vehicle's plans and not cleared (it is somewhere
    near)."""
    f = build(EXACT)
    agent = Agent(f, 0, EXACT)
    know, b = agent.know, agent.know.beliefs
    pos = off_map(f, clear_m=100.0)
    slot = b.n + EXACT.find_slots  # auv2's find
    sigma_find = 1.0 if sigma_m < 4.0 else DRIFT_SIGMA
    assert b.add_find(slot, pos, 2.5, 60.0, 0.0, sigma_find)
    treated = slot + 1  # auv2's other find, treated (cleared) treated_m west of it
    assert b.add_find(treated, (pos[0] - treated_m, pos[1], pos[2]), treated_rho, 60.0, 0.0,
                      3.0)
    know.clear([treated])
    agent.step(Tick(1.0), [NavFix(1.0, agent.own.pos, sigma_m=sigma_m)])
    agent.own.set_route([slot])
    agent.step(Tick(10.0), [NavFix(10.0, pos, sigma_m=sigma_m), Arrived(10.0, slot)])
    looks = sigma_m > 4.0 and treated_m < 40.0 and treated_rho > 10.0
    assert discovery.needs_look(know, slot) is looks
    if looks:
        assert agent.own.inspecting == slot
        at = None if not seen else (pos[0] + 3.0, pos[1], pos[2])
        agent.step(Tick(30.0), [Looked(30.0, slot, bool(seen), seen or 0.0, 60.0, at)])
    assert (agent.own.injecting == slot) is (outcome == "injected")
    assert (slot in know.doubtful) is (outcome == "not the find")
    assert (slot in know.cleared) is (outcome == "empty")
    assert agent.counters.get("looks_not_the_find", 0) == int(outcome == "not the find")
    if outcome == "not the find":
        assert slot not in agent.own.route and slot in know.unavailable(31.0)


@pytest.mark.parametrize("rho, left", [(48.0, True), (150.0, False)])
def test_a_look_showing_a_find_a_peer_holds_is_left_to_it(rho, left):
    """Hard seed 40 at 1 % drift: auv3, 16 m off, named predicted spot 30's aggregation a
    find and treated it; auv1 looked at spot 30 before that clear reached it, knowing the
    find and its holder, and injected it again. A look showing a find a peer holds, rho
    alike, is that find: not injected, the spot left out of this vehicle's plans and not
    cleared (the fleet would judge the find treated before anyone treated it). Of another
    rho it is the spot's own aggregation, injected."""
    f = build(EXACT)
    agent = Agent(f, 0, EXACT)
    know, b = agent.know, agent.know.beliefs
    u = _lonely_spot(f)
    q = f.dynamic.scenario.tasks[u].pos
    slot = b.n + EXACT.find_slots  # auv2's find, 14 m east of the spot: auv2 holds it
    assert b.add_find(slot, (q[0] + 14.0, q[1], q[2]), 48.0, 60.0, 5.0, DRIFT_SIGMA)
    know.holdings.found(slot, 1)
    assert know.holder(slot) == 1
    agent.step(Tick(1.0), [NavFix(1.0, agent.own.pos, sigma_m=6.0)])
    _send_to(agent, u)
    agent.step(Tick(10.0), [NavFix(10.0, q, sigma_m=6.0), Arrived(10.0, u)])
    assert agent.own.inspecting == u
    agent.step(Tick(40.0), [Looked(40.0, u, True, rho, 60.0, (q[0] + 4.0, q[1], q[2]))])
    assert (agent.own.injecting == u) is not left
    assert (u in know.doubtful) is left
    assert u not in know.cleared and slot not in know.cleared
    assert agent.counters.get("looks_left_to_finder", 0) == int(left)
    if left:
        assert u not in agent.own.route and u in know.unavailable(41.0)


def test_hard_seed_37_at_1_percent_drift_treats_each_aggregation_once() -> None:
    """`benchmarks/dynamic.py`'s hard reef, seed 37, at its 1 % drift: auv3, sent to find 97
    (rho 2.5), stood over the aggregation auv1 had treated as find 96 (rho 60) and injected
    it again. It now looks first at a find before treating it; nothing is treated twice.
    (Until the outbox pushed the cleared set ahead of claim repeats, one of 3 looks showed
    another rho and the find was left; the clear now reaches auv3 sooner and 1 look is
    taken.) The vehicles do not climb for GPS fixes here (``surface_sigma_m`` 0): the case
    is matching under the drift itself."""
    from benchmarks.dynamic import DRIFT, SETTINGS, config_of
    from cotsfleet.mission.inprocess import simulate
    from reef_sim.score import world_tally

    params = SETTINGS["hard"]
    doc = generate_dynamic_doc(params, np.random.default_rng(37))
    problem = problem_from_dict(doc)
    reef = reef_from_doc(doc, problem)
    result = simulate(problem, dataclasses.replace(config_of(params, search=True),
                                                   surface_sigma_m=0.0),
                      seed=37, reef=reef, navigation=DRIFT)
    books = {vid: seat.driver.vehicle.treatments for vid, seat in result.backend.seats.items()
             if seat.driver is not None}
    assert world_tally(reef, books)["duplicates"] == 0
    assert sum(v.counters.get("looks_at_finds", 0) for v in result.report.vehicles) >= 1


def _find_beside_a_treated_spot(config: AgentConfig) -> tuple[Agent, int, tuple]:
    """Seed 151's geometry: a peer's find 10 m south of a predicted spot the fleet heard
    treated; the agent (auv1), the find's slot and its position."""
    f = build(config)
    agent = Agent(f, 0, config)
    know, b = agent.know, agent.know.beliefs
    u = _lonely_spot(f)
    q = f.dynamic.scenario.tasks[u].pos
    slot = b.n + 2 * config.find_slots  # auv3's find
    find = (q[0], q[1] - 10.0, q[2])
    assert b.add_find(slot, find, 55.8, 60.0, 5.0, 1.5)
    assert know.clear([u])  # auv3 treated spot u: heard in its cleared set
    return agent, slot, find


@pytest.mark.parametrize("seen_off_m, injected", [((-0.9, 4.1), False), ((0.0, 0.0), True)])
def test_a_look_nearer_a_find_than_a_treated_spot_by_too_little_is_not_injected(seen_off_m,
                                                                              injected):
    """Fault fuzz seed 151 (hard reef, 0.5 % drift): auv3 treated predicted spot 27; auv1,
    at a sigma of 3.8 m, sent to find 144 (another aggregation, 11 m from the spot), stood
    nearer the spot's aggregation, saw COTS 4 m from the find and 6 m from the spot (1.8
    times likelier the find: `discovery.LOOK_ODDS` asks 4) and injected spot 27's again.
    COTS on the find itself are the find's, injected."""
    agent, slot, find = _find_beside_a_treated_spot(EXACT)
    know = agent.know
    know.holdings.found(slot, 2)
    know.hold(2, 5, [slot], False)  # released by auv3
    agent.step(Tick(6.0), [NavFix(6.0, agent.own.pos, sigma_m=3.8)])
    _send_to(agent, slot)
    agent.step(Tick(10.0), [NavFix(10.0, find, sigma_m=3.8), Arrived(10.0, slot)])
    assert agent.own.inspecting == slot
    seen = (find[0] + seen_off_m[0], find[1] + seen_off_m[1], find[2])
    agent.step(Tick(40.0), [Looked(40.0, slot, True, 66.5, 60.0, seen)])
    assert (agent.own.injecting == slot) is injected
    assert (slot in know.cleared) is not injected
    assert agent.counters.get("looks_treated", 0) == int(not injected)


@pytest.mark.parametrize("map_sigma_m, treated", [(0.5, True), (4.0, False)])
def test_the_look_odds_apply_only_where_navigation_is_less_sure_than_the_map(map_sigma_m,
                                                                            treated):
    """Seed 151's look (COTS 4 m from the find, 6 m from the treated spot, navigation sigma
    3.8 m) is taken for the treated aggregation where the map is surer than the vehicle
    (`discovery.LOOK_ODDS`); where the map is vaguer (4 m), "nearer" decides, as it does
    with exact navigation, where the odds skipped real aggregations a few metres off their
    spots."""
    agent, slot, find = _find_beside_a_treated_spot(
        dataclasses.replace(EXACT, map_sigma_m=map_sigma_m))
    know = agent.know
    agent.step(Tick(6.0), [NavFix(6.0, agent.own.pos, sigma_m=3.8)])
    seen = discovery._seen(know, (find[0] - 0.9, find[1] + 4.1, find[2]), 66.5)
    assert discovery._treated_already(know, slot, seen) is treated


def test_a_look_at_a_predicted_spot_keeps_nearer_under_drift() -> None:
    """make demo's mission (1 % drift): auv3, at a sigma of 4 m, looked at predicted spot 1
    and saw COTS 1 m from it, 3.5 m from where a treated aggregation was: 1.1 times likelier
    its own, so `discovery.LOOK_ODDS` would have skipped it (82 of priority lost). A
    predicted spot is distinct from its treated neighbour by the map's word: the look is
    the spot's, by which is nearer; the odds are for finds (seed 151)."""
    from fleet_agent.association import predicted

    config = dataclasses.replace(EXACT, map_sigma_m=3.0)
    f = build(config)
    agent = Agent(f, 0, config)
    know, b = agent.know, agent.know.beliefs
    u = _lonely_spot(f)
    q = f.dynamic.scenario.tasks[u].pos
    treated = predicted((q[0] - 3.5, q[1], q[2]), b.params)
    know.injections.append(treated)
    agent.step(Tick(6.0), [NavFix(6.0, agent.own.pos, sigma_m=4.0)])
    seen = discovery._seen(know, (q[0] - 0.7, q[1] + 0.7, q[2]), 37.6)
    odds_cost = discovery._likelihood_cost(seen, b.estimate(u), b.params) + \
        discovery.LOOK_ODDS_COST
    assert discovery._likelihood_cost(seen, treated, b.params) < odds_cost  # the odds: skip
    assert not discovery._treated_already(know, u, seen)
