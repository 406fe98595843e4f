"""The reef as the camera shows it (the map is a prior): sightings, looks, finds, aliases.

What the camera saw comes in as vehicle reports (`fleet_bus.vehicle_port`: `Sighted`,
`Looked`) and finds heard from peers as FOUND frames. These functions update the beliefs
(`fleet_agent.beliefs`, in the knowledge) and return what follows: a new find is named in
this vehicle's slots and owed to the fleet, a spot found empty is cleared for everyone, COTS a
look found beyond the battery are released, an aggregation treated under an alias clears its
find. On an exact map there is nothing to see and nothing here runs.
"""

from __future__ import annotations

from fleet_agent.beliefs import UNKNOWN
from fleet_agent.config import AgentConfig
from fleet_agent.intents import Count, Hold, Intent, Note, Owe, SeekWork, Tell
from fleet_agent.knowledge import Knowledge
from fleet_agent.motion import Inspected
from fleet_agent.outbox import FindsGap, Owed
from fleet_agent.records import Clear, FoundSpot
from fleet_agent.wire import MAX_TENTHS, Codec, Found
from fleet_bus.telemetry import position_detail
from fleet_bus.vehicle_port import Looked, Sighted


def where(know: Knowledge, task: int) -> str:
    """A find's position for the log ("x,y,z" m): the world's bookkeeping names the
    aggregation treated by where it is; predicted spots need nothing (their task says)."""
    if task < know.beliefs.n:
        return ""
    return position_detail(tuple(know.problem.xyz[task]))


def on_looked(know: Knowledge, config: AgentConfig, r: Looked) -> list[Intent]:
    """A look ended: learn what is there, then inject it or move on (`OwnVehicle.looked`)."""
    own = know.own
    if own.inspecting != r.task:
        return [Count("inspection_stale")]  # the look was abandoned meanwhile
    if r.present:
        know.beliefs.learn(r.task, True, r.priority, r.service_s)
    ev = own.looked(r.task, r.service_s if r.present else None, r.t_s)
    if ev is None:
        return []
    know.touch()
    return inspected(know, config, ev)


def inspected(know: Knowledge, config: AgentConfig, ev: Inspected) -> list[Intent]:
    """An empty spot is done for everyone (grow-only, gossiped) and its time goes to other
    work; COTS beyond the battery are left to others."""
    if not ev.present:
        know.beliefs.learn(ev.task, False)
        out: list[Intent] = []
        if know.clear([ev.task]):
            out += [Owe(Owed.CLEARED, 2), Note(Clear(ev.t_s, (ev.task,), own=False))]
        out.append(Tell(ev.t_s, "empty", (ev.task,)))
        return out + ([SeekWork()] if config.discovery else [])
    detail = "present" if ev.treating else "present, beyond the battery"
    out = [Tell(ev.t_s, "inspected", (ev.task,), detail=detail)]
    return out + ([] if ev.treating else [Hold((ev.task,), False)])


def on_sighted(know: Knowledge, config: AgentConfig, codec: Codec, seen: Sighted,
               now: float) -> list[Intent]:
    """An aggregation along the track: a predicted spot now known, or news."""
    if not config.discovery:
        return [Count("sightings_ignored")]
    b = know.beliefs
    what = b.match(seen.pos)
    if what is None:
        return _discover(know, codec, seen, now)
    if what[0] == "task" and b.state[what[1]] == UNKNOWN and what[1] not in know.cleared:
        b.learn(what[1], True, seen.priority, seen.service_s)
    return []


def _discover(know: Knowledge, codec: Codec, seen: Sighted, now: float) -> list[Intent]:
    """An aggregation the map missed: name it, tell the fleet, plan it once settled."""
    b = know.beliefs
    slot = b.own_slot()
    if slot is None:
        return [Count("finds_dropped")]
    # What the fleet will know: the wire's figures, so every vehicle plans the same find.
    pos = codec.dequantise(*codec.quantise(seen.pos))
    rho = min(round(seen.priority * 10), MAX_TENTHS) / 10
    service = min(round(seen.service_s * 10), MAX_TENTHS) / 10
    if not b.add_find(slot, pos, rho, service, now):
        return [Count("finds_refused")]  # on land once on the wire's grid: nobody could go
    return [Count("finds"), Note(FoundSpot(now, slot, pos, rho, service, durable=True)),
            Owe(Owed.FIND, slot), Tell(now, "found", (slot,),
                                      detail=f"{where(know, slot)} rho {rho:g}")]


def on_found(know: Knowledge, msg: Found, now: float) -> list[Intent]:
    """A peer's find: kept (or counted as a conflict, or refused on land); a digest unlike
    ours starts the finds' anti-entropy (`outbox`)."""
    b = know.beliefs
    if b.exact:
        return [Count("drop_found_static")]
    conflicts, refused = b.conflicts, b.refused
    out: list[Intent] = []
    if b.add_find(msg.slot, msg.pos, msg.priority, msg.service_s, now):
        out.append(Note(FoundSpot(now, msg.slot, msg.pos, msg.priority, msg.service_s)))
    elif b.conflicts != conflicts:
        out.append(Count("drop_found_conflict"))
    elif b.refused != refused:
        out.append(Count("drop_found_on_land"))
    if msg.digest != b.digest():
        out.append(Owe(Owed.FINDS, FindsGap(msg.digest, b.digest(), tuple(b.finds))))
    return out + fold_aliases(know, now)


def fold_aliases(know: Knowledge, now: float) -> list[Intent]:
    """An aggregation treated under an alias is treated: its find is cleared too."""
    b = know.beliefs
    new = [h for s, h in b.alias.items() if s in know.cleared and h not in know.cleared]
    return [Note(Clear(now, (h,), own=False)) for h in set(new) if know.clear([h])]
