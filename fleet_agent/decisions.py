"""What the vehicle decides: which spots it takes, and its route.

- takeover: when a peer aborts, or its silence is confirmed, replan the survivors over the
  spots it freed and claim this vehicle's share (`fleet_agent.cooperation.takeover_share`).
  Safe under false suspicion: the taken spots the peer would reach within
  ``takeover_wait_s`` go to the end of the route (`cooperation.after_own`), so they are
  reached as late as the route allows, which leaves the presumed-lost vehicle the most time
  to be heard again; when it is, its claims (the initial plan's, at time 0, or older than
  ours) win and the taken spots leave the route at once (`sync_route`). Its own spots are
  never dropped to make room for taken ones;
- cooperation, the paper's operator online: with spare battery, claim free spots that fit;
  in a dynamic mission its finder weighs a free find against the route's predicted spots
  even without spare battery;
- the route kept true to what the vehicle knows: only spots it holds and nobody cleared,
  held spots folded in, within battery; whatever it holds but will not treat is released.

Every claim and release is journalled (durable) before the radio is asked to announce it.
"""

from __future__ import annotations

from typing import Callable, Collection

from fleet_agent.config import AgentConfig
from fleet_agent.cooperation import (after_own, cooperation_route, detour_fits, live_peer,
                                     live_self, peer_etas, takeover_share)
from fleet_agent.fleet import Fleet
from fleet_agent.io_types import Outputs
from fleet_agent.knowledge import Knowledge
from fleet_agent.radio import Radio
from fleet_agent.records import Hold
from fleet_agent.motion import OwnVehicle
from fleet_agent.routing import cheapest_insertion, fit_route


class Decisions:
    def __init__(self, fleet: Fleet, config: AgentConfig, own: OwnVehicle, know: Knowledge,
                 radio: Radio, now: float, count: Callable[[str], None]) -> None:
        self.fleet, self.config, self.own, self.know, self.radio = (
            fleet, config, own, know, radio)
        self.count = count  # the agent's counters (replans asked of the planner)
        index, k = know.index, know.k
        self.next_coop_s = now + config.coop_period_s * (1.0 + index / k)
        self.coop_soon = False  # a lost claim: look for other work at once
        self.dirty = True  # knowledge changed since the route was last checked against it

    @property
    def active(self) -> bool:
        return not (self.own.done or self.own.aborted)

    def takeover(self, gone: int, now: float, out: Outputs, doubt: float = 0.0) -> None:
        """Replan the survivors over the spots freed by ``gone``; claim this vehicle's share.

        ``doubt``: the chance ``gone`` is in fact alive (0 for an announced abort). Above
        ``takeover_doubt`` the takeover is the safe one: spots this vehicle holds are kept
        whatever the replanner says. At or below it the replanner's route is taken (a vehicle
        may give up one of its own spots for a richer one of the dead peer's, as a
        centralized replan would). Either way the taken spots the peer would itself reach
        within ``takeover_wait_s`` go last: a vehicle cut off by a partition looks dead to
        the others exactly as a dead one does, and its next spots are where a duplicate
        would happen."""
        if not self.active:
            return
        know = self.know
        free = know.free_spots(now)
        if not free:
            return
        peers = [live_peer(know.problem, v, know.peer_pose.get(v), know.peer_route(v), now)
                 for v in know.active_peers()]
        # The same seed on every survivor: equal views give equal answers.
        self.count("replans")
        mine = takeover_share(know.planner, live_self(self.own), peers,
                              know.unavailable(now), know.held_map(),
                              seed=self.fleet.seed * 1000 + gone)
        gained = [t for t in mine if t in free]
        etas = peer_etas(know.problem, gone, know.peer_pose.get(gone), know.freed_route(gone))
        horizon = now + self.config.takeover_wait_s
        soon = [t for t in gained if etas.get(t, horizon) < horizon]
        if gained:
            self.hold(gained, True, now, out)
            out.event(now, "takeover", gained, peer=know.vid(gone))
        why = f"takeover of {know.vid(gone)}"
        if doubt <= self.config.takeover_doubt:
            self.set_route(after_own(mine, soon), now, out, why=why)
        else:
            own = [t for t in self.own.route if t not in know.cleared]
            self.set_route(self.keeping_own(mine, own, soon), now, out, why=why,
                           protect=frozenset(own))

    def cooperate(self, now: float, out: Outputs) -> None:
        """The paper's cooperation operator, online: spend spare battery on free spots."""
        if not self.active or (now < self.next_coop_s and not self.coop_soon):
            return
        cfg, know = self.config, self.know
        self.coop_soon = False
        self.next_coop_s = now + cfg.coop_period_s
        if self.fleet.dynamic is not None and not cfg.discovery:
            return  # --no-discovery: the time empty spots free is not reallocated
        free = know.free_spots(now)
        if not free:
            return
        # A find may be worth more than a predicted spot on the route (worth only what it is
        # expected to hold): its finder weighs it even when no detour fits the slack, or a
        # vehicle whose plan fills its battery would pass an aggregation it has just seen.
        # Only the finder: every vehicle that hears of a find is told to look when it has
        # settled, and claims made in the same cycle race; under loss the loser may never
        # hear it lost (duplicates in benchmarks/dynamic.py at 30 % loss when all looked).
        beliefs = know.beliefs
        finds = beliefs is not None and any(
            t >= beliefs.n and beliefs.finder(t) == know.index for t in free)
        slack = self.own.slack_s(cfg.battery_reserve_s)
        if not finds and (slack < cfg.coop_min_slack_s
                          or not detour_fits(self.own, free, slack)):
            return
        self.count("replans")
        mine = cooperation_route(know.planner, live_self(self.own),
                                 know.unavailable(now), know.held_map(),
                                 seed=self.fleet.seed * 1000 + 100 + know.index)
        gained = [t for t in mine if t in free]
        if gained:
            self.hold(gained, True, now, out)
            if self.fleet.dynamic is not None:
                # the map is a prior: a spot of ours is worth what it is expected to hold, and
                # giving it up for a find is the replanner's call
                self.set_route(mine, now, out, why="cooperation")
                return
            own = [t for t in self.own.route if t not in know.cleared]
            self.set_route(self.keeping_own(mine, own, ()), now, out, why="cooperation",
                           protect=frozenset(own))

    def keeping_own(self, planned: list[int], own: list[int], late: Collection[int]
                    ) -> list[int]:
        """``planned`` (a replanner's route) with the spots in ``late`` moved to its end
        (`cooperation.after_own`), unless that would cost this vehicle one of the spots it
        already holds (``own``, its route now, which fits): then its route as it is, the new
        spots inserted where they cost least, ``late`` ones at the end. The replanner works
        on rounded states and may leave a spot of ours out or order ours longer; a takeover
        or a cooperation must never make a vehicle collect less than its own route would."""
        cand = after_own(planned, late)
        cand += [t for t in own if t not in cand]
        fitted = fit_route(self.own, cand, self.config.battery_reserve_s, own)
        if set(own) <= set(fitted):
            return cand
        route = list(own)
        for t in planned:
            if t not in own and t not in late:
                route = cheapest_insertion(self.own, route, t)
        return route + [t for t in planned if t in late and t not in own]

    def hold(self, tasks: list[int], claim: bool, now: float, out: Outputs) -> None:
        """Claim (or release) ``tasks``: journal it first, then tell the fleet."""
        know, t = self.know, int(now)
        changed = know.holdings.apply(know.index, t, tasks, claim)
        if changed:
            self.dirty = True
            out.record(Hold(know.index, t, tuple(changed), claim, durable=True))
            self.radio.queue_holding(claim, t, changed)
            if claim:
                out.event(now, "claim", changed)

    def sync_route(self, now: float, out: Outputs) -> None:
        """Keep the route to spots this vehicle holds and nobody cleared, within battery;
        fold in held spots missing from it, release what cannot fit."""
        if not self.active or not self.dirty:
            return
        self.dirty = False
        know, own = self.know, self.own
        injecting = own.injecting
        alias = {} if know.beliefs is None else know.beliefs.alias
        route = [t for t in own.route if t not in know.cleared
                 and (t == injecting or (know.holder(t) == know.index and t not in alias))]
        orphans = [t for t in know.held_by(know.index) if t not in route and t not in know.cleared]
        for t in orphans:
            route = cheapest_insertion(own, route, t)
        self.set_route(route, now, out, why="sync")

    def set_route(self, route: list[int], now: float, out: Outputs, why: str,
                  protect: frozenset[int] = frozenset()) -> None:
        fitted = fit_route(self.own, route, self.config.battery_reserve_s, protect)
        # Whatever this vehicle holds but will not treat is released for the others.
        dropped = [t for t in self.know.held_by(self.know.index) if t not in fitted]
        if dropped:
            self.hold(dropped, False, now, out)
        if fitted != self.own.route:
            self.own.set_route(fitted)
            if why != "sync":
                out.event(now, "replan", detail=why)
