"""A peer declared gone: replan the survivors over the spots it freed; take this vehicle's share.

Local: beyond ``takeover_peers`` survivors only those nearest the freed spots replan (who is
near is decided alike on every survivor: `replans.nearest`), over the freed spots and their
own, so a takeover costs the same in any fleet; in a smaller fleet every survivor replans
over every free spot.

Safe under false suspicion: the taken spots the peer would reach within ``takeover_wait_s`` go
to the end of the route (`replans.after_own`), so they are reached as late as the route
allows, which leaves the presumed-lost vehicle the most time to be heard again; when it is,
its claims (the initial plan's, at time 0, or older than ours) win and the taken spots leave
the route at once (`route.sync`). Its own spots are never dropped to make room for taken ones
while the silence may be a false alarm.
"""

from __future__ import annotations

import numpy as np

from fleet_agent import membership as mb
from fleet_agent.config import AgentConfig
from fleet_agent.intents import Count, Hold, Intent, Steer, Tell
from fleet_agent.knowledge import Knowledge
from fleet_agent.policies.discovery import leave_out
from fleet_agent.policies.replans import (after_own, live_peer, live_self, nearest,
                                          peer_etas, takeover_share)
from fleet_agent.policies.route import keeping_own
from fleet_bus.states import EventKind


def takeover(know: Knowledge, config: AgentConfig, gone: int, now: float,
             doubt: float = 0.0) -> list[Intent]:
    """This vehicle's share of ``gone``'s spots, and its route with them.

    ``doubt``: the chance ``gone`` is in fact alive (0 for an announced abort). Above
    ``takeover_doubt`` the takeover is the safe one: spots this vehicle holds are kept
    whatever the replanner says. At or below it the replanner's route is taken (a vehicle
    may give up one of its own spots for a richer one of the dead peer's, as a centralized
    replan would). Either way the taken spots the peer would itself reach within
    ``takeover_wait_s`` go last: a vehicle cut off by a partition looks dead to the others
    exactly as a dead one does, and its next spots are where a duplicate would happen."""
    out: list[Intent] = []
    if know.members.status(gone) == mb.LOST:
        doubtful = tuple(sorted(likely_treated(know, gone) - know.doubtful))
        if doubtful:
            out += [*leave_out(know, doubtful, now),
                    Count("doubtful_spots", len(doubtful)),
                    Tell(now, EventKind.REPLAN, doubtful, peer=know.vid(gone),
                         detail="left out: probably treated by the lost vehicle")]
    free = know.free_spots(now)
    if not free:
        return out
    own = know.own
    active = know.active_peers()
    scope = None
    if len(active) + 1 > config.takeover_peers:
        # Only the survivors nearest the freed spots replan, over those spots and their own:
        # the same problem size in any fleet, and the same choice on every survivor with the
        # same view (positions as believed, ties by index).
        freed = [t for t in know.freed_route(gone) if t in free]
        if not freed:
            return out
        xy = know.problem.xyz[freed, :2].mean(axis=0)
        where = {v: know.whereabouts(v, now) for v in [know.index, *active]}
        near = nearest(where, xy, config.takeover_peers)
        if know.index not in near:
            return out + [Count("takeovers_left_to_nearer")]
        active, scope = [v for v in near if v != know.index], freed
    peers = [live_peer(know.problem, v, know.peer_pose.get(v), know.peer_route(v), now)
             for v in active]
    # The same seed on every survivor: equal views give equal answers.
    mine = takeover_share(know.planner, live_self(own), peers, know.unavailable(now),
                          know.held_map(), seed=know.fleet.seed * 1000 + gone, scope=scope)
    gained = [t for t in mine if t in free]
    etas = peer_etas(know.problem, gone, know.peer_pose.get(gone), know.freed_route(gone))
    horizon = now + config.takeover_wait_s
    soon = [t for t in gained if etas.get(t, horizon) < horizon]
    out.append(Count("replans"))
    if gained:
        out += [Hold(tuple(gained), True),
                Tell(now, EventKind.TAKEOVER, tuple(gained), peer=know.vid(gone))]
    why = f"takeover of {know.vid(gone)}"
    if doubt <= config.takeover_doubt:
        return out + [Steer(tuple(after_own(mine, soon)), why)]
    held = [t for t in own.route if t not in know.cleared]
    planned = keeping_own(own, config.battery_reserve_s, mine, held, soon)
    return out + [Steer(tuple(planned), why, frozenset(held))]


# How far into a silent peer's route (as believed) its last pose is looked for: the clears of
# its that we lack are its last few (its cleared set gossips while it works), and further on,
# in a compact field where its legs cross, the pose would match a leg it has not flown yet.
AHEAD = 6


def likely_treated(know: Knowledge, gone: int, on_leg_m: float = 25.0) -> set[int]:
    """Spots of ``gone``'s route (as believed) that it had probably treated before it fell
    silent, its clear unheard. A vehicle flies its route in order, so its last pose places it
    (among the first `AHEAD` spots): on the leg into a spot of the route (within ``on_leg_m``
    of the straight leg), every spot before that one is behind it; at a spot, that spot too
    (injecting it, just done with it or about to start: it may have finished and died before
    its clear went out); and every spot
    it would have finished, flying on from its last pose, before its next slot after the last
    frame of its own this vehicle took (it may have lived until that slot, the first it was
    silent in: one was heard leaving a spot at 2905 s, treated the next, 22 m on, until 2997 s
    and was killed at 3000 s, its slot).

    Why: a vehicle killed at 3000 s had treated a spot at 2950 s and was on its way to the
    next; its clear never went out, and the taker treated the spot again. Treating a spot
    twice is the one loss a takeover must not make; leaving one out costs at most its
    priority."""
    pose = know.peer_pose.get(gone)
    route = know.freed_route(gone)
    if pose is None or not route:
        return set()
    p = know.problem
    # It may have lived until its next slot, the first it was silent in.
    heard_s = know.members.peers[gone].direct_s
    alive_s = heard_s + know.members.timing.turn_s(gone, heard_s)
    xy = np.asarray(pose.pos[:2], dtype=float)
    head = route[:AHEAD + 1]  # its clears we may lack are its last few: it is near the head
    pts = p.xyz[head, :2]
    done: set[int] = set()
    near = np.flatnonzero(np.linalg.norm(pts - xy, axis=1) <= on_leg_m)
    if len(near):
        # At a spot of its route: those before are behind it, and that one it is injecting,
        # has just left or is about to inject (it may have finished and died untold).
        done |= set(route[:int(near[0]) + 1])
    elif len(head) > 1:  # on a leg: the spot it left and those before are behind it
        a, b = pts[:-1], pts[1:]
        detour = (np.linalg.norm(a - xy, axis=1) + np.linalg.norm(b - xy, axis=1)
                  - np.linalg.norm(b - a, axis=1))
        on = np.flatnonzero(detour <= on_leg_m)
        if len(on):
            done |= set(route[:int(on[0]) + 1])
    rest = [t for t in route if t not in done]
    etas = peer_etas(p, gone, pose, rest)
    return done | {t for t in rest if etas[t] + float(p.service_s[t]) <= alive_s}
