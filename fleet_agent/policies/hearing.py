"""What a frame from a peer changes, and what to answer.

A frame that passed the agent's checks (authentic, fresh, not our own) is evidence first:
its sender is alive, and its heard codes say whom the sender heard, which may revive a peer
declared lost or confirm a suspect's silence (`fleet_agent.membership`; a confirmed silence
is a takeover). Then its content: a pose (where the peer is, and whether its cleared set
may lack something of ours), a segment of the cleared set (merged: a grow-only set), a claim
or a release (the one conflict rule of `fleet_agent.negotiation`; a claim on a spot we hold
by an earlier claim, or know cleared, is answered at once), a find (`policies.discovery`),
or news of an abort.
"""

from __future__ import annotations

from fleet_agent import membership as mb
from fleet_agent.config import AgentConfig
from fleet_agent.intents import Count, Intent, Note, Owe, SeekWork, Tell
from fleet_agent.knowledge import Knowledge, PeerPose
from fleet_agent.outbox import AbortNews, Holding, Owed
from fleet_agent.policies import discovery
from fleet_agent.policies.takeover import takeover
from fleet_agent.records import Clear, Hold, PeerState
from fleet_agent.wire import Abort, Claim, ClearedSegment, Found, Message, Pose, Release


def evidence(know: Knowledge, config: AgentConfig, msg: Message, now: float,
             active: bool) -> list[Intent]:
    """What the frame says of who is alive: revivals, and silences it confirms."""
    v, members = msg.sender, know.members
    revived = [v] if members.heard(v, float(msg.seq), now) else []
    revived += members.take_heard(v, msg.heard, float(msg.seq), now)
    out: list[Intent] = []
    for u in revived:
        # Its claims live again: the overlap is settled now (spots taken from it leave the
        # route), and whatever of ours a takeover released is looked at again at once.
        know.touch()
        out += [SeekWork(), Tell(now, "revived", peer=know.vid(u)),
                Note(PeerState(u, mb.ALIVE, now))]
    for u in members.confirm(v, msg.heard, float(msg.seq), now):
        out += lost(know, config, u, now, active)
    return out


def content(know: Knowledge, config: AgentConfig, msg: Message, now: float,
            active: bool) -> list[Intent]:
    """What the frame's message changes, and what to answer."""
    if isinstance(msg, Pose):
        return _pose(know, config, msg, now, active)
    if isinstance(msg, ClearedSegment):
        out: list[Intent] = []
        new = know.merge_segment(msg.segment, msg.bits)
        if new:
            out.append(Note(Clear(now, tuple(new), own=False)))
            out += discovery.fold_aliases(know, now)
        if know.cleared.missing_from(msg.segment, msg.bits):
            out.append(Owe(Owed.LACKS, msg.sender))
        return out
    if isinstance(msg, (Claim, Release)):
        return _holding(know, msg, now)
    if isinstance(msg, Found):
        return discovery.on_found(know, msg, now)
    if isinstance(msg, Abort) and msg.who != know.index:
        news, out = gone(know, config, msg.who, mb.ABORTED, now, active, msg.t_s)
        return out + ([Count("abort_relayed_in")] if news and msg.who != msg.sender else [])
    return []


def lost(know: Knowledge, config: AgentConfig, v: int, now: float,
         active: bool) -> list[Intent]:
    """Another vehicle confirmed ``v``'s silence: its work is taken over."""
    know.touch()
    out: list[Intent] = [Note(PeerState(v, mb.LOST, now)),
                         Tell(now, "lost", peer=know.vid(v), detail="silent")]
    if active:
        out += takeover(know, config, v, now, doubt=know.members.doubt(now))
    return out


def gone(know: Knowledge, config: AgentConfig, v: int, status: str, now: float,
         active: bool, t_event: int | None = None) -> tuple[bool, list[Intent]]:
    """An announced abort or arrival home; whether it was news, and what follows."""
    before = know.members.status(v)
    if not know.members.mark(v, status, now):
        return False, []
    know.touch()
    out: list[Intent] = [Note(PeerState(v, status, now))]
    if status == mb.ABORTED:
        out.append(Tell(now, "lost", peer=know.vid(v), detail="aborted"))
        if active:
            # Pass the news on once: a peer that missed every announcement learns it from us
            # instead of waiting for the silence to be noticed.
            out.append(Owe(Owed.ABORT, AbortNews(v, int(now) if t_event is None else t_event)))
            if before in mb.WORKING:
                out += takeover(know, config, v, now)
    return True, out


def _pose(know: Knowledge, config: AgentConfig, msg: Pose, now: float,
          active: bool) -> list[Intent]:
    v = msg.sender
    know.peer_pose[v] = PeerPose(msg.pos, float(msg.seq), msg.state)
    know.peer_digest[v] = msg.digest
    mine = know.cleared.digest()
    # Push only if the peer may lack something we have: equal sizes with different hashes,
    # or a smaller set (sizes are mod 128; a larger set will push to us instead).
    behind = (mine.count - msg.digest.count) % 128
    working = msg.state not in ("home", "aborted")  # a watcher needs no cleared set
    out: list[Intent] = []
    if working and msg.digest != mine and (behind == 0 or behind < 64):
        out.append(Owe(Owed.LACKS, v))
    if msg.state == "home":
        out += gone(know, config, v, mb.HOME, now, active)[1]
    elif msg.state == "aborted":
        out += gone(know, config, v, mb.ABORTED, now, active)[1]
    return out


def _holding(know: Knowledge, msg: Claim | Release, now: float) -> list[Intent]:
    is_claim, own = isinstance(msg, Claim), know.own
    mine_before = set(own.route)
    changed = know.hold(msg.sender, msg.t_s, msg.tasks, is_claim)
    out = _contest(know, msg.tasks) if is_claim else []
    if changed:
        out.append(Note(Hold(msg.sender, msg.t_s, tuple(changed), is_claim)))
        lost_spots = [t for t in changed if t in mine_before and know.holder(t) != know.index
                      and t != own.injecting]
        if lost_spots:
            out += [Tell(now, "claim_lost", tuple(lost_spots), peer=know.vid(msg.sender)),
                    SeekWork()]
    return out


def _contest(know: Knowledge, tasks: tuple[int, ...]) -> list[Intent]:
    """A peer claims spots it cannot have: answer at once, not at the next refresh. A claim
    on a spot we hold by an earlier claim means the peer missed ours (we re-send it); on a
    spot we know is cleared, that it missed the clear (we push that segment). Unanswered, it
    would fly there and treat the spot again (a claim race under loss)."""
    by_time: dict[int, list[int]] = {}
    for t in tasks:
        since = know.holdings.claim_time(t, know.index)
        if since and t not in know.cleared and know.holder(t) == know.index:
            by_time.setdefault(since, []).append(t)
    out: list[Intent] = [Owe(Owed.ANSWER, Holding(True, c, tuple(group)))
                         for c, group in sorted(by_time.items())]
    done = {know.cleared.segment_of(t) for t in tasks if t in know.cleared}
    return out + [Owe(Owed.SEGMENT, s) for s in sorted(done)]
