"""What the vehicle decides: which spots it takes, and its route.

- takeover: when a peer aborts or goes silent, replan the survivors over the spots it freed
  and claim this vehicle's share (`fleet_agent.cooperation.takeover_share`);
- cooperation, the paper's operator online: with spare battery, claim free spots that fit;
- the route kept true to what the vehicle knows: only spots it holds and nobody cleared,
  held spots folded in, within battery; whatever it holds but will not treat is released.

Every claim and release is journalled (durable) before the radio is asked to announce it.
"""

from __future__ import annotations

from typing import Callable

from fleet_agent.config import AgentConfig
from fleet_agent.cooperation import (cheapest_insertion, cooperation_route, detour_fits,
                                     live_peer, live_self, takeover_share)
from fleet_agent.fleet import Fleet
from fleet_agent.io_types import Outputs
from fleet_agent.knowledge import Knowledge
from fleet_agent.radio import Radio
from fleet_agent.records import Hold
from fleet_agent.vehicle import Vehicle, fit_route


class Decisions:
    def __init__(self, fleet: Fleet, config: AgentConfig, vehicle: Vehicle, know: Knowledge,
                 radio: Radio, now: float, count: Callable[[str], None]) -> None:
        self.fleet, self.config, self.vehicle, self.know, self.radio = (
            fleet, config, vehicle, know, radio)
        self.count = count  # the agent's counters (replans asked of the planner)
        index, k = know.index, know.k
        self.next_coop_s = now + config.coop_period_s * (1.0 + index / k)
        self.coop_soon = False  # a lost claim: look for other work at once
        self.dirty = True  # knowledge changed since the route was last checked against it

    @property
    def active(self) -> bool:
        return not (self.vehicle.done or self.vehicle.aborted)

    def takeover(self, gone: int, now: float, out: Outputs) -> None:
        """Replan the survivors over the spots freed by ``gone``; claim this vehicle's share."""
        if not self.active:
            return
        know = self.know
        free = know.free_spots()
        if not free:
            return
        peers = [live_peer(know.problem, v, know.peer_pose.get(v), know.peer_route(v), now)
                 for v in know.active_peers()]
        # The same seed on every survivor: equal views give equal answers.
        self.count("replans")
        mine = takeover_share(self.fleet.planner, live_self(self.vehicle), peers,
                              frozenset(know.cleared), know.held_map(),
                              seed=self.fleet.seed * 1000 + gone)
        gained = [t for t in mine if t in free]
        if gained:
            self.hold(gained, True, now, out)
            out.event(now, "takeover", gained, peer=know.vid(gone))
        self.set_route(mine, now, out, why=f"takeover of {know.vid(gone)}")

    def cooperate(self, now: float, out: Outputs) -> None:
        """The paper's cooperation operator, online: spend spare battery on free spots."""
        if not self.active or (now < self.next_coop_s and not self.coop_soon):
            return
        cfg, know = self.config, self.know
        self.coop_soon = False
        self.next_coop_s = now + cfg.coop_period_s
        slack = self.vehicle.slack_s(cfg.battery_reserve_s)
        if slack < cfg.coop_min_slack_s:
            return
        free = know.free_spots()
        if not free or not detour_fits(self.vehicle, free, slack):
            return
        self.count("replans")
        mine = cooperation_route(self.fleet.planner, live_self(self.vehicle),
                                 frozenset(know.cleared), know.held_map(),
                                 seed=self.fleet.seed * 1000 + 100 + know.index)
        gained = [t for t in mine if t in free]
        if gained:
            self.hold(gained, True, now, out)
            self.set_route(mine, now, out, why="cooperation")

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
        know, vehicle = self.know, self.vehicle
        injecting = vehicle.injecting
        route = [t for t in vehicle.route if t not in know.cleared
                 and (t == injecting or know.holder(t) == know.index)]
        orphans = [t for t in know.held_by(know.index) if t not in route and t not in know.cleared]
        for t in orphans:
            route = cheapest_insertion(vehicle, route, t)
        self.set_route(route, now, out, why="sync")

    def set_route(self, route: list[int], now: float, out: Outputs, why: str) -> None:
        fitted = fit_route(self.vehicle, route, self.config.battery_reserve_s)
        # Whatever this vehicle holds but will not treat is released for the others.
        dropped = [t for t in self.know.held_by(self.know.index) if t not in fitted]
        if dropped:
            self.hold(dropped, False, now, out)
        if fitted != self.vehicle.route:
            self.vehicle.set_route(fitted)
            if why != "sync":
                out.event(now, "replan", detail=why)
