"""The reef as the camera shows it (the map is a prior): sightings, looks, finds, aliases.

What the camera saw comes in as vehicle reports (`fleet_bus.vehicle_port`: `Sighted`,
`Looked`) and finds heard from peers as FOUND frames. These functions update the beliefs
(`fleet_agent.beliefs`, in the knowledge) and return what follows: a new find is named in
this vehicle's slots and owed to the fleet, a spot found empty is cleared for everyone, COTS a
look found beyond the battery are released, an aggregation treated under an alias clears its
find. On an exact map there is nothing to see and nothing here runs.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from statistics import NormalDist

from fleet_agent.association import (AssociationParams, Estimate, could_be_treated,
                                     distance2, feature2, innovation_var, probably_treated,
                                     same_aggregation, sighting, unlike_priority)
from fleet_agent.beliefs import EMPTY, UNKNOWN
from fleet_agent.config import AgentConfig
from fleet_agent.intents import Count, Hold, Intent, Note, Owe, SeekWork, Tell
from fleet_agent.knowledge import Knowledge
from fleet_agent.motion import Inspected
from fleet_agent.outbox import FindsGap, Owed
from fleet_agent.policies.plausible import been_there
from fleet_agent.records import Clear, Doubt, FoundSpot
from fleet_agent.wire import MAX_TENTHS, SIGMA_UNIT_M, Codec, Found, sigma_code
from fleet_bus.states import EventKind
from fleet_bus.telemetry import cleared_detail, position_detail
from fleet_bus.vehicle_port import Injected, Looked, Sighted

# A look shows the spot looked at, not an aggregation already treated, only when the spot is
# this many times likelier (Gaussian likelihoods of the two estimates): treating twice is what
# the fleet has promised never to do; skipping costs one aggregation's priority. Only at a find
# and where the vehicle's navigation is less sure than the map (`_treated_already`): where it
# is surer, the look's position tells neighbouring aggregations apart and "nearer" has never
# treated twice, while the odds skipped real aggregations a few metres off their spots (the
# dynamic benchmark's exact-navigation missions: preset 68,680 against 68,869); a predicted
# spot is distinct from a treated one by the map's word, as `treated_estimates` holds it, while
# a find may be a treated aggregation seen by a drifted vehicle (make demo's mission: a look
# 1 m from predicted spot 1, 3.5 m from a treated one, at a sigma of 4 m, skipped under the
# odds: 2,919 against 3,001 in process; docs/search.md).
LOOK_ODDS = 4.0
LOOK_ODDS_COST = 2.0 * math.log(LOOK_ODDS)  # the same in -2 ln likelihood


def treated_detail(know: Knowledge, task: int, injected_s: float) -> str:
    """A cleared event's detail (`fleet_bus.telemetry.cleared_detail`): a find's position
    ("x,y,z" m: the world's bookkeeping names the aggregation treated by where it is;
    predicted spots need none, their task says), then how long the injection lasted."""
    pos = None if task < know.beliefs.n else tuple(know.problem.xyz[task])
    return cleared_detail(injected_s, pos)


def needs_look(know: Knowledge, task: int) -> bool:
    """Must the vehicle look before injecting ``task`` (`motion.Conduct.needs_look`)? A spot
    it knows nothing of (`Beliefs.unknown`), or a find it may stand over a treated neighbour
    at. The vehicle flies to the find with an error of sigma s (its own navigation's and the
    finder's when it saw it, together), and an injection treats the aggregation nearest under
    the camera: it stands nearer a neighbour d away than the find with the chance Q(d / 2s)
    (the half-plane beyond the bisector). It looks when that exceeds `look_first_p` for a
    treated aggregation of another rho (one alike the look could not tell from the find).
    Hard seed 37 at 1 % drift: auv3, sent to find 97 (rho 2.5) at a sigma of 8.6 m, stood
    over the aggregation auv1 had treated as find 96 (rho 60), 22.8 m away on the map (a
    chance of 0.09), and injected it again. The look tells them apart by the rho it measures
    (`on_looked`). A look at every find within the footprint and 3 sigmas of a treated one
    cost 0.44 % of the priority over 120 drifting missions (docs/search.md)."""
    b = know.beliefs
    if b.unknown(task):
        return True
    f = b.finds.get(task)
    if f is None or b.camera is None:
        return False
    sigma = math.hypot(f.sigma_m, know.own.sigma_m)
    if sigma <= 0.0:
        return False  # exact navigation: never off (and no treated spots to list)
    # Q(d / 2s) > p  <=>  d < 2 s Q^-1(p)
    reach = 2.0 * sigma * _inverse_q(b.config.look_first_p)
    mine = b.find_estimate(f)
    # A neighbour of unknown rho counts (the look compares what it sees with the find's);
    # one of alike rho does not (the look could not tell them apart).
    return any(math.dist(t.xy, f.pos[:2]) < reach
               and (t.priority is None or unlike_priority(t, mine, b.params))
               for t in treated_estimates(know, but=task))


def _inverse_q(p: float) -> float:
    """The standard normal's upper quantile: Q(x) = p (inf at 0, -inf at 1)."""
    return -NormalDist().inv_cdf(p) if 0.0 < p < 1.0 else (math.inf if p <= 0.0 else -math.inf)


def on_looked(know: Knowledge, config: AgentConfig, r: Looked) -> list[Intent]:
    """A look ended: learn what is there, then inject it or move on (`OwnVehicle.looked`)."""
    own = know.own
    if own.inspecting != r.task:
        return [Count("inspection_stale")]  # the look was abandoned meanwhile
    counts = [Count("looks_at_finds")] if r.task in know.beliefs.finds else []
    skip = _not_to_inject(know, r)
    if skip is not None:  # on to the next spot
        if own.looked(r.task, None, r.t_s) is None:
            return []
        know.touch()
        return counts + skip() + ([SeekWork()] if config.discovery else [])
    if r.present:
        know.beliefs.learn(r.task, True, r.priority, r.service_s)  # a look is sure
        if r.pos is not None and r.task < know.beliefs.n and _landmark(know, r.pos, r.task):
            know.touch()  # the goals moved with the vehicle's frame
    if know.search is not None and r.task < know.beliefs.n:
        know.search.learn(r.task, r.present)
    ev = own.looked(r.task, r.service_s if r.present else None, r.t_s)
    if ev is None:
        return []
    know.touch()
    return counts + inspected(know, config, ev)


def _not_to_inject(know: Knowledge, r: Looked) -> Callable[[], list[Intent]] | None:
    """What to do instead of injecting the COTS a look shows, or None (inject them, or
    nothing is there): at a find, COTS of another rho are a neighbour (`_another_rho`);
    anywhere, COTS already treated are not injected again, and a find a peer holds is left
    to it."""
    if not r.present:
        return None
    if _another_rho(know, r):
        return lambda: leave(know, (r.task,), "looks_not_the_find", r.t_s)
    if r.pos is None:
        return None
    seen = _seen(know, r.pos, r.priority)
    if _treated_already(know, r.task, seen):
        return lambda: _treated_at_look(know, r)
    if _held_find(know, seen) is not None:
        return lambda: leave(know, (r.task,), "looks_left_to_finder", r.t_s)
    return None


def _seen(know: Knowledge, pos: tuple[float, ...], priority: float | None) -> Estimate:
    """What the camera saw at ``pos`` (the vehicle's frame), as an estimate in the map's,
    with the rho it measured (None: not said)."""
    return sighting(know.own.frame.to_map(pos), know.own.sigma_m, know.beliefs.params,
                    priority)


def _treated_already(know: Knowledge, task: int, est: Estimate) -> bool:
    """Is the aggregation ``est`` seen at ``task`` one already treated: inside the treated
    gate of a treated spot (`treated_estimates`: where this vehicle measured its own
    injections, and the spots cleared as treated) and nearer it than the spot looked at?
    The map's spots are distinct, but a drifted vehicle sent to one may be looking at its
    neighbour's aggregation: on Green Island (1 % drift, seed 8) auv1 was sent to spots 7
    and 15, 13.5 m apart on the map with one real aggregation between them, stood 9 m east
    of each in turn, and injected that aggregation from both; on the preset reef (seed 1)
    auv3 injected at spot 47 what auv2 had treated as spot 80. Two real aggregations on
    neighbouring spots stay two: each is seen nearer its own spot. At a find, where the
    vehicle's navigation sigma exceeds the map's, nearer by a clear margin (`LOOK_ODDS`): two
    aggregations 11 m apart are then hard to tell (fault fuzz seed 151, hard reef, 0.5 %
    drift: auv1, sigma 3.8 m, sent to find 144, stood 3.7 m from the aggregation auv3 had
    treated as spot 27 and 7.7 m from the find's, saw COTS 4 m from the find and 6 m from
    the spot, 1.8 times as likely the find, and injected spot 27's again)."""
    if know.beliefs.exact:
        return False
    b = know.beliefs
    treated = treated_estimates(know, but=task)
    if not treated:
        return False
    odds = know.own.sigma_m > b.params.map_sigma_m and task >= b.n
    cost = _likelihood_cost if odds else distance2
    own = cost(est, b.estimate(task), b.params) + (LOOK_ODDS_COST if odds else 0.0)
    return any(cost(est, t, b.params) < own and could_be_treated(est, t, b.params)
               for t in treated)


def _likelihood_cost(a: Estimate, b: Estimate, params: AssociationParams) -> float:
    """-2 ln of the Gaussian likelihood that ``a`` is the aggregation ``b``, up to a shared
    constant: d2 + 2 ln S (Blackman & Popoli 1999, sec. 6.2: a vague candidate does not win
    by its vagueness alone)."""
    return distance2(a, b, params) + 2.0 * math.log(innovation_var(a, b, params))


def _held_find(know: Knowledge, est: Estimate) -> int | None:
    """A find another vehicle holds (its finder from its FOUND on, or a claim) that ``est``
    is, its rho alike (both measured): the look shows that find's aggregation, or None.
    The map's spots are distinct, but a drifted vehicle may have named a spot's own
    aggregation a find (hard seed 40, 1 % drift: auv3, 16 m off, named spot 30's
    aggregation find 140 and treated it at 636 s; auv1 looked at spot 30 at 660 s, knowing
    find 140 and its holder but not yet its clear, and injected it again)."""
    b = know.beliefs
    if b.exact or est.priority is None:
        return None
    for slot, f in b.finds.items():
        if slot in know.cleared or slot in b.alias:
            continue
        if _peer_holds(know, slot) and same_aggregation(est, b.find_estimate(f), b.params):
            return slot
    return None


def _peer_holds(know: Knowledge, task: int) -> bool:
    """Does another vehicle alive hold ``task`` (its finder from its FOUND on, or a claim)?"""
    holder = know.holder(task)
    return holder is not None and holder != know.index


def _another_rho(know: Knowledge, r: Looked) -> bool:
    """Does a look at a find show COTS of another rho than the find's (`unlike_priority`)?
    Then the vehicle, unsure where it is, stands over a neighbour, not the find. A vehicle
    looks at a find only when its navigation and the finder's may together put it over a
    treated neighbour (`needs_look`)."""
    f = know.beliefs.finds.get(r.task)
    if f is None:
        return False
    mine = know.beliefs.find_estimate(f)  # the camera measured both: the same rho's error
    return unlike_priority(replace(mine, priority=r.priority), mine, know.beliefs.params)


def leave_out(know: Knowledge, tasks: tuple[int, ...], t_s: float) -> list[Intent]:
    """Leave ``tasks`` out of this vehicle's plans (`Knowledge.doubtful`) from ``t_s`` on, and
    journal it: a restart must not plan them again."""
    know.doubtful.update(tasks)
    return [Note(Doubt(t_s, tuple(tasks)))]


def leave(know: Knowledge, tasks: tuple[int, ...], counter: str,
          t_s: float) -> list[Intent]:
    """Not injected here, and ``tasks`` left out of this vehicle's plans
    (`Knowledge.doubtful`) and released, but not cleared: the fleet learns nothing false.
    Also a spot a peer was seen at work at (`hearing._seen_at_work`).
    A find whose look shows another rho is somewhere near, where another vehicle (or this
    one with a better fix) may find it. A spot whose look shows a find a peer holds is that
    find's: cleared here, it would make every peer judge the find treated, its holder
    included, before anyone treated it; when the find is cleared, `fold_treated` judges the
    spot."""
    return [*leave_out(know, tasks, t_s), Count(counter, len(tasks)), Hold(tasks, False)]


def _treated_at_look(know: Knowledge, r: Looked) -> list[Intent]:
    """The look shows an aggregation this vehicle treated: not injected again, and the spot
    is taken as treated (it is the one the map put there, or it was never seen: either way
    nobody is to inject there again), as `fold_treated` judges one."""
    return [Count("looks_treated"), *_judge_treated(know, (r.task,), r.t_s, owe=True)]


def _judge_treated(know: Knowledge, tasks: tuple[int, ...], t_s: float,
                   owe: bool) -> list[Intent]:
    """Take ``tasks`` as treated (judged, never measured: `treated_estimates` leaves them
    out, so judgements do not chain) and clear them; ``owe``: this vehicle's own look
    judged, so the fleet is told (a fold from what everyone hears is judged by everyone)."""
    know.folded.update(tasks)
    out: list[Intent] = []
    if know.clear(list(tasks)):
        out += [Owe(Owed.CLEARED, 2)] if owe else []
        out.append(Note(Clear(t_s, tasks, own=False)))
    return out + [Tell(t_s, EventKind.JUDGED_TREATED, tasks)]


def inspected(know: Knowledge, config: AgentConfig, ev: Inspected) -> list[Intent]:
    """An empty spot is done for everyone (grow-only, gossiped) and its time goes to other
    work; COTS beyond the battery are left to others."""
    if not ev.present:
        know.beliefs.learn(ev.task, False)
        out: list[Intent] = []
        if know.clear([ev.task]):
            out += [Owe(Owed.CLEARED, 2), Note(Clear(ev.t_s, (ev.task,), own=False))]
        out.append(Tell(ev.t_s, EventKind.EMPTY, (ev.task,)))
        return out + ([SeekWork()] if config.discovery else [])
    detail = "present" if ev.treating else "present, beyond the battery"
    out = [Tell(ev.t_s, EventKind.INSPECTED, (ev.task,), detail=detail)]
    return out + ([] if ev.treating else [Hold((ev.task,), False)])


def on_sighted(know: Knowledge, config: AgentConfig, codec: Codec, seen: Sighted,
               now: float) -> list[Intent]:
    """An aggregation along the track (`association`, docs/search.md): a predicted spot now
    known, a find already known, something already treated (by anyone, or where this
    vehicle's camera measured an injection of its own), or news."""
    if not config.discovery:
        return [Count("sightings_ignored")]
    b = know.beliefs
    params = b.params
    est = _seen(know, seen.pos, seen.priority)
    what, sure = b.resolve(est)
    if what is None:
        if probably_treated(est, treated_estimates(know), params):
            return [Count("sightings_treated")]  # seen again: never treated twice
        return _name(know, codec, seen, est, now)[1]  # missed by the map: a find
    kind, spot = what
    if kind == "task" and sure:
        # No landmark from a sighting along the track: which aggregation it is rests on the
        # frame being right, and where the map missed aggregations near its spots a wrong
        # one moves the frame with a small variance, then confirms itself (a look is at the
        # spot it names: `on_looked` takes that one).
        if b.state[spot] == UNKNOWN and spot not in know.cleared:
            if _treated_already(know, spot, est):
                return [Count("sightings_treated")]  # a look there will tell
            b.learn(spot, True, seen.priority, seen.service_s, sighted=est)
            if est.sigma_m > config.look_first_sigma_m:
                b.look_first.add(spot)
            if know.search is not None:
                know.search.learn(spot, True)
    return [] if sure else [Count("sightings_ambiguous")]  # a look will tell which


def _landmark(know: Knowledge, seen_vehicle: tuple[float, ...], task: int) -> bool:
    """The camera saw predicted spot ``task`` at ``seen_vehicle`` (the vehicle's frame): a
    landmark for the frame (`fleet_agent.landmarks`), of the variance of the map's position,
    the camera's offset and a point of the aggregation about its centre."""
    params = know.beliefs.params
    return know.own.frame.landmark(seen_vehicle, know.beliefs.scenario.tasks[task].pos,
                                   params.map_sigma_m ** 2 + params.camera_sigma_m ** 2
                                   + params.extent_var / 2)


def remember_injection(know: Knowledge, r: Injected) -> Estimate | None:
    """Keep where the camera measured what this injection treated (an estimate in the
    map's frame, appended to ``know.injections``, and returned), or None when the vehicle
    did not say."""
    if r.pos is None or know.beliefs.exact:
        return None
    b = know.beliefs
    est = _seen(know, r.pos, r.priority)
    know.injections.append(est)
    # A spot known present from a sighting near what was just treated may be this very
    # aggregation, seen from a drifted track: looked at before it is injected (hard seed 9,
    # 1 % drift: auv3 sighted "spot 38" at 2863 s, treated spot 1 at 2949 s, and injected
    # at 38 without a look what it had treated at 1). Near the spot on the map, or near
    # where the camera saw what it took for the spot: a fault fuzz (hard reef, 1 % drift,
    # fixes every 900 s, seed 169) had auv3 treat spot 83's aggregation at 2368 s and inject
    # it again at 2462 s as spot 78, which it had sighted there, the map's 78 being farther.
    for t in [t for t, seen in b.sighted.items() if t not in know.cleared
              and any(probably_treated(at, (est,), b.params)
                      for at in (b.estimate(t), *seen))]:
        b.doubt(t)
    return est


def treated_elsewhere(know: Knowledge, codec: Codec, r: Injected, seen: Estimate | None
                      ) -> list[Intent]:
    """The injection at ``r.task`` measured COTS of another rho than the spot's (its look's,
    or the find's): a drifted vehicle sent to a spot treated whatever was in view, its
    neighbour (hard reef, 1 % drift: 18 of 1,236 injections over 20 missions). Where the
    vehicle really injected, ``seen``, is its own (`remember_injection`); the fleet must
    learn it too, or another vehicle treats that aggregation again under its own name: the
    known spot it surely is is cleared as treated, or a find is named for it and cleared at
    once. The
    spot sent to stays cleared (the cleared set only grows): its aggregation is a miss."""
    b = know.beliefs
    measured = _measured(know, r.task)
    if seen is None or seen.priority is None or measured is None:  # (no rho: not compared)
        return []
    expected, service_s = measured
    f = feature2(seen, replace(seen, priority=expected))
    if f is None or f <= b.params.treated_feature_gate:
        return []  # the spot's own COTS (or too alike to tell)
    out: list[Intent] = [Count("injected_elsewhere")]
    what, sure = b.resolve(seen, but=r.task)
    if what is not None:
        spot = what[1]
        if not sure:
            return out + [Count("injected_elsewhere_ambiguous")]
        if spot in know.cleared:
            return out
        return out + _judge_treated(know, (spot,), r.t_s, owe=True)
    assert r.pos is not None and r.priority is not None  # ``seen`` was measured from them
    slot, told = _name(know, codec, Sighted(r.t_s, r.pos, r.priority, service_s), seen, r.t_s)
    out += told
    return out if slot is None else out + _judge_treated(know, (slot,), r.t_s, owe=True)


def _measured(know: Knowledge, task: int) -> tuple[float, float] | None:
    """The rho and t a camera measured of spot ``task``: a predicted spot's look (or
    sighting), a find's finder's; None if none did (an operator's spot, a spot never seen).
    A find named for what was injected instead carries them: it is cleared at once and
    never planned."""
    b = know.beliefs
    if task < b.n:
        return b.real.get(task)
    f = b.finds.get(task)
    return None if f is None else (f.priority, f.service_s)


def treated_estimates(know: Knowledge, finds_only: bool = False,
                      but: int | None = None) -> list[Estimate]:
    """Where the spots taken as treated are (`association.probably_treated`): every cleared
    spot but those this vehicle saw empty and those it only judged treated (`fold_treated`:
    no chains of judgements), each as its estimate, and where this vehicle's camera measured
    what it injected; ``finds_only``: the finds of them (a predicted spot is held only
    against treated finds: the map says its spots are distinct, and a look tells them
    apart)."""
    b = know.beliefs
    out = [] if finds_only else list(know.injections)
    for t in know.cleared:
        if t == but or t in know.folded or (t < b.n and (finds_only or b.state[t] == EMPTY)):
            continue
        if t >= b.n and t not in b.finds and t not in b.added:
            continue
        out.append(b.estimate(t))
    return out


def fold_treated(know: Knowledge, now: float) -> list[Intent]:
    """Never treat a spot twice (docs/search.md, "Never twice"): a spot nobody has cleared
    whose estimate could be an aggregation already treated is cleared too (a find held
    against every treated spot, a predicted spot against treated finds: the map says its
    spots are distinct; an operator's added spot is held as a find is). A find a live peer
    holds is left to it: it measured the find and its own fold judges it, while a peer's
    judgement, pushed in a cleared set, stops its injection (Green Island seed 1: two peers
    matched auv2's fresh find against a spot auv2 had just found empty, and nobody treated
    the aggregation). Run when the cleared set, the finds, the merges or the holders change."""
    b = know.beliefs
    if b.exact:
        return []
    wait_key = (len(know.cleared), len(b.finds), know.holdings.version)
    if wait_key != know.await_key:
        know.await_key = wait_key
        awaiting = await_gaps(know, now)
        if awaiting != know.awaiting:
            know.awaiting = awaiting
            know.touch()
    key = _fold_key(know)
    if key == know.fold_key:
        return []
    know.fold_key = key
    params = b.params
    all_treated = treated_estimates(know)
    finds_treated = treated_estimates(know, finds_only=True)
    if not all_treated:
        return []
    new = []
    for s, f in [*b.finds.items(), *b.added.items()]:
        if s in know.cleared or s in b.alias:
            continue
        if _peer_holds(know, s):
            continue  # it measured it, and its own fold judges it
        if probably_treated(b.estimate(s), all_treated, params):
            new.append(s)
    if finds_treated:
        for t in range(b.n):
            if t not in know.cleared and b.state[t] != EMPTY and \
                    probably_treated(b.estimate(t), finds_treated, params):
                new.append(t)
    if not new:
        return []
    judged = _judge_treated(know, tuple(new), now, owe=False)
    know.fold_key = _fold_key(know)
    return [Count("spots_judged_treated", len(new)), *judged]


def _fold_key(know: Knowledge) -> tuple[int, ...]:
    """What `fold_treated`'s judgement depends on: the cleared set, the finds, the merges,
    and who holds the finds (a holder's release or loss hands its find to the fold)."""
    b = know.beliefs
    return (len(know.cleared), len(b.finds) + len(b.added), len(b.alias),
            know.holdings.version, know.members.alive_version)


def await_gaps(know: Knowledge, now: float) -> frozenset[int]:
    """The finds not to plan yet (docs/search.md, "Never twice"): a peer has cleared, claimed or
    released a find this vehicle has never heard of (its FOUND frame was lost; the cleared set,
    the claim or the release came through, and the gap is asked for: `FindsGap`), so where it is
    is unknown; any open find here that peer's heard track passed near (`plausible.been_there`'s
    reach), or any at all when none of its track was heard, may be that aggregation under the
    other's name, and waits until the FOUND arrives (the cleared set, the claims or the finds
    change: judged again). Two vehicles side by side name one aggregation seconds apart; the
    claim of the first is on the air a cycle before its FOUND (hard seed 15 at 30 % loss: a
    claim heard at 418 s, the FOUND at 628 s, the aggregation treated twice). A release counts
    as a claim does (a fault fuzz, hard reef, 2 % drift, 50 % loss, seed 94: auv2 heard auv3
    release its find 145 at 2,736 s, but neither its FOUND nor its claims, named the aggregation
    find 118 at 2,808 s and treated it 80 s after auv3)."""
    b = know.beliefs
    unknown = [t for t in know.holdings.named_since_plan() if b.is_find_slot(t)]
    gaps = [t for t in know.cleared if t >= b.n and t not in b.finds]
    gaps += [t for t in unknown if t not in b.finds]
    if not gaps:
        return frozenset()
    finders = {b.finder(t) for t in gaps}
    out = set()
    for s in b.finds:
        if s in know.cleared or s in b.alias:
            continue
        for f in finders:
            if f not in know.tracks or been_there(know, f, s, now):
                out.add(s)
                break
    return frozenset(out)


def _name(know: Knowledge, codec: Codec, seen: Sighted, est: Estimate, now: float
          ) -> tuple[int | None, list[Intent]]:
    """Name a find for ``seen`` in this vehicle's next slot and tell the fleet: the slot
    (None if none was free, or the find fell on land) and what follows."""
    b = know.beliefs
    slot = b.own_slot()
    if slot is None:
        return None, [Count("finds_dropped")]
    # What the fleet will know: the wire's figures, so every vehicle plans the same find.
    pos = codec.dequantise(*codec.quantise((*est.xy, seen.pos[2])))
    rho = min(round(seen.priority * 10), MAX_TENTHS) / 10
    service = min(round(seen.service_s * 10), MAX_TENTHS) / 10
    sigma = sigma_code(est.sigma_m) * SIGMA_UNIT_M
    if not know.add_find(slot, pos, rho, service, now, sigma):
        return None, [Count("finds_refused")]  # on land once on the wire's grid: nobody goes
    at = position_detail(tuple(know.problem.xyz[slot]))
    return slot, [Count("finds"), Note(FoundSpot(now, slot, pos, rho, service, durable=True,
                                                 sigma_m=sigma)),
                  Owe(Owed.FIND, slot), Tell(now, EventKind.FOUND, (slot,),
                                            detail=f"{at} rho {rho:g}")]


def on_found(know: Knowledge, msg: Found, now: float) -> list[Intent]:
    """A peer's find: kept (or counted as a conflict, or refused on land); a digest unlike
    ours starts the finds' anti-entropy (`outbox`)."""
    b = know.beliefs
    if b.exact:
        return [Count("drop_found_static")]
    if not b.is_find_slot(msg.slot):
        return [Count("drop_found_not_a_find")]  # the operator's slots: from its orders only
    conflicts, refused = b.conflicts, b.refused
    out: list[Intent] = []
    if know.add_find(msg.slot, msg.pos, msg.priority, msg.service_s, now, msg.sigma_m):
        out.append(Note(FoundSpot(now, msg.slot, msg.pos, msg.priority, msg.service_s,
                                  sigma_m=msg.sigma_m)))
    elif b.conflicts != conflicts:
        out.append(Count("drop_found_conflict"))
    elif b.refused != refused:
        out.append(Count("drop_found_on_land"))
    if msg.digest != b.digest():
        newest = sorted(b.finds, key=lambda s: (-b.finds[s].learned_s, s))
        out.append(Owe(Owed.FINDS, FindsGap(msg.digest, b.digest(), tuple(newest))))
    return out + fold_aliases(know, now)


def fold_aliases(know: Knowledge, now: float) -> list[Intent]:
    """An aggregation treated under an alias is treated: its find is cleared too."""
    b = know.beliefs
    new = [h for s, h in b.alias.items() if s in know.cleared and h not in know.cleared]
    return [Note(Clear(now, (h,), own=False)) for h in set(new) if know.clear([h])]
