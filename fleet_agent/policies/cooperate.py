"""The paper's cooperation operator (Algorithm 3), online: spare battery on free spots.

Every ``coop_period_s`` (at once when `intents.SeekWork` asked), a vehicle with spare
battery asks the replanner for its route with free spots inserted and claims those it gets;
the spots offered are those in its reach (the cheapest detours that fit its spare battery,
at most ``coop_spots``), so the replan's size does not grow with the fleet.
On a map that is a prior, a find is worth what it holds and a predicted spot only what it is
expected to: its finder weighs a free find against the route's predicted spots even without
spare battery, and may give up a spot of its own for it (the replanner's call). On an exact
map a cooperation never costs the vehicle a spot of its own (`route.keeping_own`), unless it
gains a spot the operator added: every vehicle weighs those, with or without spare battery,
as a finder weighs its find.
"""

from __future__ import annotations

from dataclasses import dataclass

from fleet_agent.config import AgentConfig
from fleet_agent.intents import Count, Hold, Intent, Steer
from fleet_agent.knowledge import Knowledge
from fleet_agent.policies.replans import (cheapest_detours, cooperation_route, detour_fits,
                                          live_self)
from fleet_agent.policies.route import keeping_own


@dataclass
class CoopClock:
    """When the operator next runs, and whether it was asked to run at once."""

    next_s: float
    soon: bool = False

    def due(self, now: float, period_s: float) -> bool:
        """Is it time (or was it asked)? If so, the next regular run is a period away."""
        if now < self.next_s and not self.soon:
            return False
        self.soon, self.next_s = False, now + period_s
        return True


def held_finds(know: Knowledge, now: float) -> list[int]:
    """This vehicle's settled finds that it holds by their FOUND alone (neither claimed nor
    released yet, `Holdings.found`): `cooperate` weighs them, then claims or releases each."""
    mine = know.holdings.reserved_by(know.index)
    if not mine:  # most coops: the walk over every find slot (`blocked`) is skipped
        return []
    blocked = know.blocked(now)
    return [t for t in mine if t not in know.cleared and t not in blocked
            and t not in know.doubtful and t not in know.awaiting
            and know.holder(t) == know.index]


def cooperate(know: Knowledge, config: AgentConfig, now: float) -> list[Intent]:
    """The free spots this vehicle takes, and its route with them."""
    beliefs = know.beliefs
    if not beliefs.exact and not config.discovery:
        return []  # --no-discovery: the time empty spots free is not reallocated
    own = know.own
    slack = own.slack_s(config.battery_reserve_s)
    if slack < config.coop_min_slack_s and not beliefs.weighs_without_slack():
        # Nothing to weigh without spare battery: the walk over every spot of the reef is
        # skipped. In a large fleet most vehicles have no slack most of the time; that walk
        # made cooperation grow with fleet x reef.
        return []
    free = know.free_spots(now)
    # Its finds it holds by their FOUND alone (`Holdings.found`): weighed here like a free
    # find of its own, then claimed in its own time or released to the fleet.
    reserved = held_finds(know, now) if not beliefs.exact else []
    if not free and not reserved:
        return []
    # A find may be worth more than a predicted spot on the route (worth only what it is
    # expected to hold): its finder weighs it even when no detour fits the slack, or a
    # vehicle whose plan fills its battery would pass an aggregation it has just seen. Only
    # the finder: every vehicle that hears of a find is told to look when it has settled, and
    # claims made in the same cycle race; under loss the loser may never hear it lost
    # (duplicates in benchmarks/dynamic.py at 30 % loss when all looked). The operator's
    # added spots are weighed by every vehicle: nobody found them, the operator asked for
    # them, and the claim contest (earliest claim, settled before work) leaves one vehicle.
    weigh = [t for t in free if (beliefs.is_find_slot(t) and beliefs.finder(t) == know.index)
             or t in beliefs.added] + reserved
    finds = bool(weigh)
    if not finds and (slack < config.coop_min_slack_s or not detour_fits(own, free, slack)):
        return []
    # Only the free spots in reach go to the replanner: the cheapest detours that fit the
    # spare battery (and this vehicle's own finds), at most ``coop_spots``: the problem does
    # not grow with the fleet's spots.
    offered = cheapest_detours(own, free, slack, config.coop_spots)
    offered += [t for t in weigh if t not in offered]
    mine = cooperation_route(know.planner, live_self(own), know.unavailable(now),
                             know.held_map(), seed=know.fleet.seed * 1000 + 100 + know.index,
                             offered=offered)
    out: list[Intent] = [Count("replans")]
    declined = tuple(t for t in reserved if t not in mine)
    if declined:  # the fleet may have them now
        out.append(Hold(declined, False))
    gained = [t for t in mine if t in free or t in reserved]
    if not gained:
        return out
    out.append(Hold(tuple(gained), True))
    if not beliefs.exact or any(t in beliefs.added for t in gained):
        # a spot of ours is worth what it is expected to hold; the operator's is worth what
        # the operator said, maybe more than one of ours (the replanner's call)
        return out + [Steer(tuple(mine), "cooperation")]
    held = [t for t in own.route if t not in know.cleared]
    planned = keeping_own(own, config.battery_reserve_s, mine, held, ())
    return out + [Steer(tuple(planned), "cooperation", frozenset(held))]
