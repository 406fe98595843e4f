"""What a frame from a peer changes, and what to answer.

A frame whose fleet MAC checked is evidence of life at once (`alive`): its sender, and the
peers its heard codes say it heard, may be revived; forged, such evidence only keeps a silent
vehicle in the fleet longer, never takes its work (silence is not death). Everything else
waits until the frame is proven its sender's (`fleet_bus.tesla`: a cycle later): the heard
codes that confirm a suspect's silence (`confirmed`: a takeover), then the content
(`content`): a pose (where the peer is, and whether its cleared set
may lack something of ours), a segment of the cleared set (merged: a grow-only set), a claim
or a release (the one conflict rule of `fleet_agent.negotiation`; a claim on a spot we hold
by an earlier claim, or know cleared, is answered at once), a find (`policies.discovery`),
or news of an abort.
"""

from __future__ import annotations

import numpy as np

from fleet_agent import membership as mb
from fleet_agent import witness
from fleet_agent.config import AgentConfig
from fleet_agent.intents import Count, Intent, LastWords, Note, Owe, SeekWork, Tell
from fleet_agent.knowledge import Knowledge, PeerPose
from fleet_agent.outbox import AbortNews, Holding, Owed
from fleet_agent.policies import discovery, plausible
from fleet_agent.policies.takeover import takeover
from fleet_agent.records import Clear, Hold, PeerState
from fleet_agent.wire import Abort, Claim, ClearedSegment, Found, Message, Pose, Release
from fleet_bus.states import EventKind, VehicleState


def alive(know: Knowledge, msg: Message, now: float) -> list[Intent]:
    """What the frame says of who is alive: its sender and the peers it heard (revivals)."""
    v, members = msg.sender, know.members
    revived = [v] if members.heard(v, float(msg.seq), now) else []
    revived += members.take_heard(v, msg.heard, float(msg.seq), now)
    out: list[Intent] = []
    for u in revived:
        # Its claims live again: the overlap is settled now (spots taken from it leave the
        # route), and whatever of ours a takeover released is looked at again at once.
        know.touch()
        out += [SeekWork(), Tell(now, EventKind.REVIVED, peer=know.vid(u)),
                Note(PeerState(u, mb.ALIVE, now))]
    return out


def confirmed(know: Knowledge, config: AgentConfig, msg: Message, now: float,
              active: bool) -> list[Intent]:
    """The silences the (proven) frame's heard codes confirm: those peers are lost."""
    out: list[Intent] = []
    for u in know.members.confirm(msg.sender, msg.heard, float(msg.seq), now):
        out += lost(know, config, u, now, active)
    return out


def content(know: Knowledge, config: AgentConfig, msg: Message, now: float,
            active: bool) -> list[Intent]:
    """What the frame's message changes, and what to answer."""
    if isinstance(msg, Pose):
        return _pose(know, config, msg, now, active)
    if isinstance(msg, ClearedSegment):
        return _cleared(know, msg, now)
    if isinstance(msg, (Claim, Release)):
        return _holding(know, msg, now)
    if isinstance(msg, Found):
        verdict = plausible.find(know, msg.sender, msg.slot, msg.pos, msg.priority,
                                 msg.service_s, now, msg.sigma_m)
        if verdict == plausible.REFUSE:
            return _suspect(know, msg.sender, "find")
        return discovery.on_found(know, msg, now) if verdict == plausible.TAKE else \
            [Count("find_waiting")]
    if isinstance(msg, Abort) and msg.who != know.index:
        if not plausible.abort_news(know, msg.sender, msg.who):
            return [Count("abort_waiting")]  # one peer's word about another: wait for two
        news, out = gone(know, config, msg.who, mb.ABORTED, now, active, msg.t_s)
        return out + ([Count("abort_relayed_in")] if news and msg.who != msg.sender else [])
    return []


def _suspect(know: Knowledge, v: int, what: str, n: int = 1) -> list[Intent]:
    """``v`` said ``n`` thing(s) of kind ``what`` that could not be: refused, and counted
    against it (the report's suspects)."""
    know.suspicion[v] += n
    return [Count(f"implausible_{what}", n)]


def _cleared(know: Knowledge, msg: ClearedSegment, now: float) -> list[Intent]:
    """A segment of a peer's cleared set: what it is news of and plausible is taken (a
    grow-only set), the rest waits for a second word; a peer that lacks some of ours is owed
    a push."""
    news = know.cleared.news_in(msg.segment, msg.bits)
    out: list[Intent] = []
    take, waiting = plausible.cleared(know, msg.sender, news, now)
    new = know.clear(take)
    if new:
        out.append(Note(Clear(now, tuple(new), own=False)))
        out += discovery.fold_aliases(know, now)
    if waiting:
        out.append(Count("cleared_waiting", waiting))
    if know.cleared.missing_from(msg.segment, msg.bits):
        out.append(Owe(Owed.LACKS, msg.sender))
    return out


def lost(know: Knowledge, config: AgentConfig, v: int, now: float,
         active: bool) -> list[Intent]:
    """Another vehicle confirmed ``v``'s silence: its work is taken over."""
    know.touch()
    out: list[Intent] = [Note(PeerState(v, mb.LOST, now)), LastWords(v),
                         Tell(now, EventKind.LOST, peer=know.vid(v), detail="silent")]
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
        out += [LastWords(v), Tell(now, EventKind.LOST, peer=know.vid(v), detail="aborted")]
        if active:
            # Pass the news on once: a peer that missed every announcement learns it from us
            # instead of waiting for the silence to be noticed.
            out.append(Owe(Owed.ABORT, AbortNews(v, int(now) if t_event is None else t_event)))
            if before in mb.WORKING:
                out += takeover(know, config, v, now)
    return True, out


def last_words(know: Knowledge, v: int, msgs: list[Message], now: float) -> list[Intent]:
    """A gone peer's unproven last frames: its own spots it says are cleared (a lie there
    costs only its own work; a duplicate of its last treatments costs everyone)."""
    own = {t for t in range(know.problem.n_tasks) if know.holdings.claim_time(t, v) is not None
           or t in know.fleet.base_routes[v]}
    out: list[Intent] = []
    for msg in msgs:
        if isinstance(msg, ClearedSegment):
            lo = msg.segment * know.cleared.segment_bits
            bits = int.from_bytes(msg.bits, "little")
            said = [lo + i for i in range(bits.bit_length()) if bits >> i & 1]
            new = know.clear(t for t in said if t in own and t < know.problem.n_tasks)
            if new:
                out += [Count("last_words"), Note(Clear(now, tuple(new), own=False))]
    return out


def _pose(know: Knowledge, config: AgentConfig, msg: Pose, now: float,
          active: bool) -> list[Intent]:
    v = msg.sender
    know.peer_pose[v] = PeerPose(msg.pos, float(msg.seq), msg.state)
    know.peer_digest[v] = msg.digest
    start = know.problem.vehicles[v].start
    witness.extend(know.tracks.setdefault(v, witness.new_track(start)), float(msg.seq), msg.pos)
    mine = know.cleared.digest()
    # Push only if the peer may lack something we have: equal sizes with different hashes,
    # or a smaller set (sizes are mod 128; a larger set will push to us instead).
    behind = (mine.count - msg.digest.count) % 128
    working = msg.state not in ("home", "aborted")  # a watcher needs no cleared set
    out: list[Intent] = []
    if working and msg.digest != mine and (behind == 0 or behind < 64):
        out.append(Owe(Owed.LACKS, v))
    if active and msg.state == VehicleState.INJECTING:
        out += _seen_at_work(know, v, msg.pos, now)
    if msg.state == VehicleState.HOME and not plausible.home(know, v, msg.pos):
        out += _suspect(know, v, "home")
    elif msg.state == VehicleState.HOME:
        out += gone(know, config, v, mb.HOME, now, active)[1]
    elif msg.state == VehicleState.ABORTED:
        out += gone(know, config, v, mb.ABORTED, now, active)[1]
    return out


# A peer's pose within this of a spot places it there: its estimate when it works a spot is
# where it steered to, the spot in its own frame (fault fuzz seed 41, 0.5 % drift: 1.0 m).
AT_WORK_M = 5.0


def _seen_at_work(know: Knowledge, v: int, pos: tuple[float, float, float],
                  now: float) -> list[Intent]:
    """A peer's pose says it is at work (waiting, looking or injecting) at a spot this vehicle
    is on its way to: the peer's claim never reached us (fault fuzz seed 41, about 60 % loss:
    all three sends of it lost, while 13 other frames of that peer got through), and going on
    would treat the spot twice. The spot is left to the peer: released and out of this
    vehicle's plans (`Knowledge.doubtful`), not cleared (the peer will clear it; if it does not,
    another may take it: the fleet learns nothing false). Only spots this vehicle is not at
    itself: two vehicles at one spot are the claim contest's to settle, and each would yield
    to the other here."""
    own = know.own
    here = own.at_spot
    mine = [t for t in own.route if t != here and t not in know.cleared
            and t not in know.doubtful]
    if not mine:
        return []
    at = np.asarray(pos[:2], dtype=float)
    d = np.hypot(*(know.problem.xyz[mine, :2] - at).T)
    near = tuple(t for t, dt in zip(mine, d) if dt <= AT_WORK_M)
    if not near:
        return []
    # A spot there that the peer holds is the one it is at (fault fuzz seed 8, 2 % drift: a
    # peer at its own spot, 4 m from one of ours, took ours from us and nobody treated it).
    d = np.hypot(*(know.problem.xyz[:, :2] - at).T)
    if any(know.holder(int(t)) == v for t in np.flatnonzero(d <= AT_WORK_M)
           if int(t) not in know.cleared):
        return []
    return [*discovery.leave(know, near, "spots_left_to_worker", now),
            Tell(now, EventKind.REPLAN, near, peer=know.vid(v),
                 detail="left out: the peer was seen at work there")]


def _holding(know: Knowledge, msg: Claim | Release, now: float) -> list[Intent]:
    is_claim, own = isinstance(msg, Claim), know.own
    mine_before = set(own.route)
    tasks = plausible.claims(know, msg.sender, msg.tasks) if is_claim else msg.tasks
    changed = know.hold(msg.sender, msg.t_s, tasks, is_claim)
    out = _contest(know, msg.tasks) if is_claim else []
    if len(tasks) < len(msg.tasks):
        out += _suspect(know, msg.sender, "claim", len(msg.tasks) - len(tasks))
    if changed:
        out.append(Note(Hold(msg.sender, msg.t_s, tuple(changed), is_claim)))
        lost_spots = [t for t in changed if t in mine_before and know.holder(t) != know.index]
        # The spot being injected is told when the route leaves it (`route.sync`: with how
        # long it was injected, the timeline's figure).
        told = tuple(t for t in lost_spots if t != own.injecting)
        if told:
            out.append(Tell(now, EventKind.CLAIM_LOST, told, peer=know.vid(msg.sender)))
        if lost_spots:
            out.append(SeekWork())
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
