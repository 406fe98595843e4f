"""How an agent comes back from its journal after a restart.

What comes back: the cleared set, its own treatments, every claim and release it heard,
peers' final states (aborted, home), whether it had aborted or got home, and its last
checkpoint (position, distance, route, sequence number, replay high-water marks). Time lost
while down is lost battery too; an injection cut short is redone (it never completed).
Silence is counted from the restart: the agent could not listen while it was down.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Mapping, Sequence

from fleet_agent import membership as mb
from fleet_agent import records as rec
from fleet_agent.io_types import Outputs

if TYPE_CHECKING:
    from fleet_agent.agent import Agent

KNOWN_KINDS = ("start", "clr", "hold", "peer", "abort", "home", "restart", "ckpt", "find")


def restore(agent: "Agent", journal: Sequence[Mapping[str, Any]], now: float,
            out: Outputs) -> None:
    """Rebuild ``agent`` (fresh, at ``now``) from ``journal``; the restart's own records and
    event go to ``out``."""
    know, own = agent.know, agent.own
    n_tasks = agent.problem.n_tasks
    ckpt: rec.Checkpoint | None = None
    aborted = False
    home_at: float | None = None
    for doc in journal:
        r = rec.parse(doc) if isinstance(doc, Mapping) else None
        if r is None:
            if not isinstance(doc, Mapping) or doc.get("k") in KNOWN_KINDS:
                agent.count("journal_bad_records")
            continue
        if isinstance(r, rec.Clear):
            for t in r.tasks:
                if 0 <= t < n_tasks:
                    know.cleared.add(t)
                    if r.own and all(t != x for x, _ in know.treated):
                        know.treated.append((t, r.t_s))
        elif isinstance(r, rec.FoundSpot) and know.beliefs is not None:
            know.beliefs.add_find(r.slot, r.pos, r.priority, r.service_s, r.t_s)
        elif isinstance(r, rec.Hold):
            know.holdings.apply(r.v, r.t_s, list(r.tasks), r.claim)
        elif isinstance(r, rec.PeerState) and r.status in (mb.ABORTED, mb.HOME):
            know.members.mark(r.v, r.status, r.t_s)
        elif isinstance(r, rec.Aborted):
            aborted = True
        elif isinstance(r, rec.Home):
            home_at = r.t_s
        elif isinstance(r, rec.Checkpoint):
            ckpt = r
    for peer in know.members.peers.values():
        peer.evidence_s = max(peer.evidence_s, now)
        peer.since_s = max(peer.since_s, now)
    agent.discovery.rebind()  # finds back in the working problem before the route aims at them
    if ckpt is not None:
        agent.radio.last_seq = ckpt.seq
        know.replay.restore(dict(ckpt.high_water))
        own.restore(now, ckpt.pos, ckpt.distance_m, list(ckpt.route), aborted, home_at)
    else:
        own.restore(now, own.pos, 0.0, agent.fleet.base_routes[agent.index], aborted, home_at)
    if aborted:
        agent.radio.own_abort_left = agent.config.abort_repeats
    agent.radio.push_cleared = 1  # tell the fleet what we know as soon as we can
    out.record(rec.Restarted(now))
    out.event(now, "restart", detail=f"{len(know.cleared)} cleared")
