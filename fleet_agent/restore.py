"""How an agent comes back from its journal after a restart: a pure fold into a `Snapshot`.

What comes back: the cleared set, its own treatments, the spots it left out as doubtful
(`records.Doubt`), the finds it knew, the spots the operator added (`records.SpotAdded`: the
order itself is taken once), every claim and release it heard, peers' final states
(aborted, home), whether it had aborted or got home, and its last checkpoint (position,
distance, route, sequence number, replay high-water marks). `fold` reads records only;
`restore` applies it to the agent. Time lost while down is lost battery too; an injection
cut short is redone (it never completed). A damaged or foreign record costs that record,
never the journal: it is counted.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

from fleet_agent import membership as mb
from fleet_agent import records as rec
from fleet_agent.association import Estimate
from fleet_agent.io_types import Outputs
from fleet_agent.knowledge import Knowledge
from fleet_agent.outbox import Owed
from fleet_agent.radio import Radio
from fleet_bus.states import EventKind

KNOWN_KINDS = ("start", "clr", "hold", "peer", "abort", "home", "restart", "ckpt", "find",
               "add", "doubt")


@dataclass
class Snapshot:
    """What a journal says the agent knew when it stopped."""

    cleared: list[int] = field(default_factory=list)
    treated: list[tuple[int, float]] = field(default_factory=list)  # own, in order
    injections: list[tuple[float, float, float]] = field(default_factory=list)  # Clear.at
    doubtful: set[int] = field(default_factory=set)  # `rec.Doubt`: out of plans, not cleared
    finds: list[rec.FoundSpot] = field(default_factory=list)
    added: list[rec.SpotAdded] = field(default_factory=list)  # the operator's spots
    holds: list[rec.Hold] = field(default_factory=list)
    finals: list[rec.PeerState] = field(default_factory=list)  # peers aborted or home
    aborted: bool = False
    home_at_s: float | None = None
    checkpoint: rec.Checkpoint | None = None
    bad_records: int = 0  # records of the journal's kinds it could not read


def fold(journal: Sequence[Mapping[str, Any]], n_tasks: int) -> Snapshot:
    """The snapshot of ``journal`` (records of a scenario of ``n_tasks`` spots)."""
    snap = Snapshot()
    cleared: set[int] = set()
    for doc in journal:
        r = rec.parse(doc) if isinstance(doc, Mapping) else None
        if r is None:
            if not isinstance(doc, Mapping) or doc.get("k") in KNOWN_KINDS:
                snap.bad_records += 1
            continue
        if isinstance(r, rec.Clear):
            if r.own and r.at is not None:
                snap.injections.append(r.at)
            for t in r.tasks:
                if 0 <= t < n_tasks:
                    if t not in cleared:
                        cleared.add(t)
                        snap.cleared.append(t)
                    if r.own and all(t != x for x, _ in snap.treated):
                        snap.treated.append((t, r.t_s))
        elif isinstance(r, rec.Doubt):
            snap.doubtful.update(t for t in r.tasks if 0 <= t < n_tasks)
        elif isinstance(r, rec.FoundSpot):
            snap.finds.append(r)
        elif isinstance(r, rec.SpotAdded):
            snap.added.append(r)
        elif isinstance(r, rec.Hold):
            snap.holds.append(r)
        elif isinstance(r, rec.PeerState) and r.status in (mb.ABORTED, mb.HOME):
            snap.finals.append(r)
        elif isinstance(r, rec.Aborted):
            snap.aborted = True
        elif isinstance(r, rec.Home):
            snap.home_at_s = r.t_s
        elif isinstance(r, rec.Checkpoint):
            snap.checkpoint = r
    return snap


def restore(snap: Snapshot, know: Knowledge, radio: Radio, base_route: Sequence[int],
            now: float, out: Outputs) -> None:
    """Bring an agent's ``know`` and ``radio`` back from ``snap`` at ``now`` (its initial route
    ``base_route`` if it never checkpointed). Silence is counted from the restart: the agent
    could not listen while it was down."""
    own = know.own
    know.cleared.update(snap.cleared)
    know.treated = list(snap.treated)
    know.doubtful.update(snap.doubtful)
    know.injections.extend(Estimate((x, y), s) for x, y, s in snap.injections)
    for f in snap.finds:
        know.add_find(f.slot, f.pos, f.priority, f.service_s, f.t_s, f.sigma_m)
    for a in snap.added:
        know.beliefs.add_spot(a.slot, a.pos, a.priority, a.t_s, a.service_s)
    for h in snap.holds:
        know.holdings.apply(h.v, h.t_s, list(h.tasks), h.claim)
    for p in snap.finals:
        if p.v in know.members.peers:
            know.members.mark(p.v, p.status, p.t_s)
    for peer in know.members.peers.values():
        peer.evidence_s = max(peer.evidence_s, now)
        peer.since_s = max(peer.since_s, now)
    know.rebind()  # finds and added spots back in the working problem before the route
    ck = snap.checkpoint
    if ck is not None:
        radio.last_seq = ck.seq
        know.replay.restore(dict(ck.high_water))
        own.restore(now, ck.pos, ck.distance_m, list(ck.route), snap.aborted, snap.home_at_s)
    else:
        own.restore(now, own.pos, 0.0, list(base_route), snap.aborted, snap.home_at_s)
    know.touch()
    if snap.aborted:
        radio.outbox.owe(Owed.OWN_ABORT)
    radio.outbox.owe(Owed.CLEARED, 1)  # tell the fleet what we know as soon as we can
    out.record(rec.Restarted(now))
    out.event(now, EventKind.RESTART, detail=f"{len(know.cleared)} cleared")
