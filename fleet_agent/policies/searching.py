"""When to look around a spot just treated, rather than go on to the next known one.

COTS aggregate: a spot that held COTS makes its surroundings likely to hold aggregations the
map missed (`fleet_agent.search`: the belief, a Poisson intensity around the predicted spots
by what is known of them, thinned by every pass of the camera). After an injection the
vehicle is at the spot; it weighs an orbit around it (`best_search`) against its next spot
(`worth_searching`: expected priority per second, the way there included, within the battery's
slack) and, if the orbit wins, flies it on its way to the next spot (`OwnVehicle.detour`:
the orbit starts and ends at the spot). What the orbit's camera sees is a sighting like any
other: news is named, told to the fleet and allocated as every find.

The orbit around a spot belongs to the vehicle that treated it: that vehicle alone held the
spot (its claim settled before it began, `Knowledge.settled_s`), so two vehicles never orbit
one spot, without a frame of its own. Each spot is orbited once at most.

Only with a search belief (`AgentConfig.search_per_spot` > 0) in a dynamic mission, with
discovery on (a vehicle that ignores what its camera sees has nothing to search for).
"""

from __future__ import annotations

import math

import numpy as np

from fleet_agent.config import AgentConfig
from fleet_agent.intents import Count, Intent, Tell
from fleet_agent.knowledge import Knowledge
from fleet_agent.search import BeliefParams, SearchBelief, best_search, worth_searching
from fleet_bus.states import EventKind
from fleet_bus.telemetry import position_detail


def belief_of(know: Knowledge, config: AgentConfig) -> SearchBelief | None:
    """The search belief for this vehicle's map (None: no search configured, or an exact
    map), over the map's spots and a margin of the belief's reach."""
    b = know.beliefs
    if b.exact or not config.discovery or config.search_per_spot <= 0 or not b.n:
        return None
    ring = config.search_ring_max_m > 0
    params = BeliefParams(per_spot=config.search_per_spot,
                          ring_min_m=config.search_ring_min_m if ring else None,
                          ring_max_m=config.search_ring_max_m if ring else None,
                          spread_m=config.search_spread_m,
                          empty_weight=config.search_empty_weight, p_cots=config.p_cots,
                          mean_priority=float(np.mean(b.scenario.priority)),
                          mean_service_s=float(np.mean(b.scenario.service_s)))
    xy = b.scenario.xyz[:b.n, :2]
    m = params.reach_m
    bounds = (float(xy[:, 0].min() - m), float(xy[:, 0].max() + m),
              float(xy[:, 1].min() - m), float(xy[:, 1].max() + m))
    return SearchBelief(params, xy, bounds)


def after_injection(know: Knowledge, config: AgentConfig, task: int) -> list[Intent]:
    """The vehicle finished injecting ``task`` and is there: orbit it first, or not."""
    belief, own, b = know.search, know.own, know.beliefs
    camera = b.camera
    if belief is None or camera is None or own.aborted or task in know.searched:
        return []
    know.searched.add(task)
    centre = tuple(float(c) for c in own.pos[:2])
    option = best_search(belief, [centre], speed_mps=own.speed_mps,
                         detect_radius_m=camera.detect_radius_m, p_detect=camera.p_detect)
    if option is None:
        return []
    p = know.problem
    nxt = own.route[0] if own.route else None
    if nxt is None:  # nothing left but the way home: a search costs only its own time
        priority, travel, service = 0.0, 0.0, 0.0
    else:
        priority = float(p.priority[nxt])
        travel = own.leg_time_s(own.pos, tuple(p.xyz[nxt]))
        service = float(p.service_s[nxt])
    if not math.isfinite(travel):
        return []
    slack = own.slack_s(config.battery_reserve_s)
    if not worth_searching(option, 0.0, priority, travel, service, slack_s=slack,
                           margin=config.search_margin):
        return [Count("searches_declined")]
    z = own.pos[2]
    own.set_detour(tuple((x, y, z) for x, y in option.waypoints), option.duration_s)
    know.touch()
    return [Count("searches"), Tell(own.t_s, EventKind.SEARCH, (task,),
                                    detail=f"{position_detail((*centre, z))} expected "
                                           f"{option.expected_finds:.2f} finds")]


def sweep(know: Knowledge, config: AgentConfig) -> None:
    """A leg ended: what the camera passed over and did not report as news thins the belief
    (one call per leg, so a place is one pass however many fixes lie along it)."""
    belief, camera = know.search, know.beliefs.camera
    track, know.leg_track = know.leg_track, [know.own.pos]
    if belief is None or camera is None or len(track) < 2:
        return
    belief.swept(track, camera.detect_radius_m, camera.p_detect)
