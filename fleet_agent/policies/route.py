"""The route kept true to what the vehicle knows, and what a replan may change of it.

- `sync`: only spots this vehicle holds, nobody cleared and no unknown find may be (the spot
  being injected stays, unless a live peer holds it),
  held spots missing from it folded in where they cost least; the agent fits it to the
  battery and releases what it will not treat (`intents.Steer`);
- `keeping_own`: a replanner's route that never costs the vehicle one of its own spots.
"""

from __future__ import annotations

from typing import Collection

from fleet_agent.intents import Intent, Steer, Tell
from fleet_agent.knowledge import Knowledge
from fleet_agent.motion import OwnVehicle
from fleet_agent.policies.replans import after_own
from fleet_agent.routing import cheapest_insertion, fit_route
from fleet_bus.states import EventKind
from fleet_bus.telemetry import stopped_detail


def sync(know: Knowledge) -> list[Intent]:
    """Keep the route to spots this vehicle holds and nobody cleared; fold in held spots
    missing from it."""
    own = know.own
    injecting, alias = own.injecting, know.beliefs.alias
    # A find awaiting a peer's unknown cleared find (`discovery.await_gaps`) leaves the route
    # too, not only the replans: a vehicle already on its way to it would treat it.
    waiting = know.awaiting
    # The spot being injected stays unless a live peer holds it: the loser of a claim race
    # that learns it mid-injection stops (the holder never stops for a later claim, so one
    # of the two finishes; fault fuzz seed 74: the earlier claim heard 55 s into the loser's
    # injection, the spot treated twice).
    gone = injecting is not None and injecting in know.cleared  # a peer's clear heard
    to = None if injecting is None or gone else know.holder(injecting)
    keep = to in (None, know.index)
    route = [t for t in own.route if t not in know.cleared
             and ((t == injecting and keep)
                  or (know.holder(t) == know.index and t not in alias and t not in waiting))]
    orphans = [t for t in know.held_by(know.index) if t not in route and t not in know.cleared
               and t not in waiting]
    for t in orphans:
        route = cheapest_insertion(own, route, t)
    steer = Steer(tuple(route), "sync")
    if injecting is None or injecting in route:
        return [steer]
    # Left: to a live peer's earlier claim, or because a peer's clear marks it treated (this
    # vehicle's own clear comes after its injection has ended, never during it).
    if gone:
        return [_stopped(know, injecting, EventKind.JUDGED_TREATED, None), steer]
    assert to is not None  # kept unless cleared or held by a live peer
    return [_stopped(know, injecting, EventKind.CLAIM_LOST, to), steer]


def _stopped(know: Knowledge, task: int, kind: EventKind, holder: int | None) -> Tell:
    """The log's word that the spot being injected is left: to ``holder``, a live peer
    (claim lost), or as treated by another (judged treated); the event says how long this
    vehicle injected (the timeline's injecting time, `fleet_bus.telemetry.stopped_detail`)."""
    own = know.own
    return Tell(own.t_s, kind, (task,), peer="" if holder is None else know.vid(holder),
                detail=stopped_detail(own.t_s - own.injecting_since_s))


def keeping_own(own: OwnVehicle, reserve_s: float, planned: list[int], held: list[int],
                late: Collection[int]) -> list[int]:
    """``planned`` (a replanner's route) with the spots in ``late`` moved to its end
    (`replans.after_own`), unless that would cost this vehicle one of the spots it already
    holds (``held``, its route now, which fits): then its route as it is, the new spots
    inserted where they cost least, ``late`` ones at the end. The replanner works on rounded
    states and may leave a spot of ours out or order ours longer; a takeover or a cooperation
    must never make a vehicle collect less than its own route would."""
    cand = after_own(planned, late)
    cand += [t for t in held if t not in cand]
    fitted = fit_route(own, cand, reserve_s, held)
    if set(held) <= set(fitted):
        return cand
    route = list(held)
    for t in planned:
        if t not in held and t not in late:
            route = cheapest_insertion(own, route, t)
    return route + [t for t in planned if t in late and t not in held]
