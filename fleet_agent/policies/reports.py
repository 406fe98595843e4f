"""What the vehicle reports (`fleet_bus.vehicle_port`): fixes move the agent's model of it,
arrivals and ends of work change what it does, sightings and looks go to `discovery`."""

from __future__ import annotations

import math

from fleet_agent import records as rec
from fleet_agent.config import AgentConfig
from fleet_agent.intents import Count, Intent, Note, Owe, Tell
from fleet_agent.knowledge import Knowledge
from fleet_agent.outbox import Owed
from fleet_agent.policies import discovery, searching
from fleet_agent.wire import Codec
from fleet_bus.states import EventKind
from fleet_bus.vehicle_port import (
    Arrived,
    Injected,
    Looked,
    NavFix,
    Refused,
    Sighted,
    VehicleReport,
)


def take(know: Knowledge, config: AgentConfig, codec: Codec, r: VehicleReport,
         active: bool) -> list[Intent]:
    """One vehicle report; ``active``: the vehicle is still working (neither home nor
    aborted)."""
    own = know.own
    if isinstance(r, NavFix):
        own.fix(r)
        _track(know)
    elif isinstance(r, Arrived):
        searching.sweep(know, config)
        home = own.arrived(r.target, r.t_s)
        if home is not None:
            know.touch()
            # An aborted vehicle already said goodbye; others announce their arrival.
            said: list[Intent] = [Note(rec.Home(home.t_s)),
                                  Tell(home.t_s, EventKind.REPLAN, detail="home")]
            return said if own.aborted else [Owe(Owed.HOME), *said]
    elif isinstance(r, Injected):
        done = own.injected(r.task, r.t_s)
        if done is None:
            return [Count("injection_stale")]
        know.treat(done.task, done.t_s)
        seen = discovery.remember_injection(know, r)
        at = None if seen is None else (*seen.xy, seen.sigma_m)
        return [Owe(Owed.CLEARED, 2), Note(rec.Clear(done.t_s, (done.task,), own=True, at=at)),
                Tell(done.t_s, EventKind.CLEARED, (done.task,),
                     detail=discovery.treated_detail(know, done.task, done.injected_s)),
                *searching.after_injection(know, config, done.task),
                *discovery.treated_elsewhere(know, codec, r, seen)]
    elif isinstance(r, Looked):
        return discovery.on_looked(know, config, r)
    elif isinstance(r, Sighted):
        if not active:
            return [Count("sensed_ignored")]
        return discovery.on_sighted(know, config, codec, r, r.t_s)
    elif isinstance(r, Refused):
        return [Count("helm_refused"),
                Tell(r.t_s, EventKind.REFUSED, detail=f"{r.command}: {r.reason}")]
    return []


TRACK_STEP_M = 5.0  # the leg's track keeps a point per this much travel (bounded memory)
TRACK_POINTS = 4096


def _track(know: Knowledge) -> None:
    """Where the vehicle went since its last arrival, for the search belief's sweep."""
    if know.search is None:
        return
    track, pos = know.leg_track, know.own.pos
    if not track or math.dist(track[-1][:2], pos[:2]) >= TRACK_STEP_M:
        if len(track) >= TRACK_POINTS:
            del track[1::2]  # thin, keep the ends
        track.append(pos)
