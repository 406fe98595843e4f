"""What a peer says of itself must be plausible, or it is refused and counted.

A frame proven its sender's (`fleet_bus.tesla`) says who spoke, not that it is true: an
insider holding one vehicle's credentials can still lie about that vehicle. Each thing a
peer says is weighed against what it could have done, so that one vehicle's lies cost at most
what its own work is worth:

- *cleared spots*: a spot is taken as cleared when its sender held it (the initial plan, or a
  claim: its own work), when no other working vehicle holds it, when its sender's track
  passed it (`been_there`), or when two different peers say so; otherwise it waits for a
  second word (`Witness`);
- *claims*: a vehicle may claim no more than it could treat before its battery ends: the
  injection times of what it claims, plus a minimum spanning tree through those spots and its
  last known position at its speed (a lower bound of any route through them), within its
  battery left; and hold, with what it held, no more than twice that (`claims`; a held spot
  its heard track has passed counts as done there, its clear perhaps lost, and a find of
  its own we have not heard of lies where it is); a claim beyond is refused from its last
  spot back;
- *news of another's abort*: taken from the vehicle itself, or from two different peers;
- *home*: said only near its rendezvous;
- *finds*: worth no more than twice the most any predicted spot is worth, taking no longer
  than twice the longest injection; a finder's own find lies near its track (its poses); a
  find relayed by another vehicle waits for its finder or a second peer (unless its finder
  is gone: then one word is all there will be).

What is refused is counted per peer (`Knowledge.suspicion`, in the agent's statuses and so in
the report: the suspects of a mission). What waits is bounded by the scenario (a spot, a
vehicle, a find slot each hold a set of at most the fleet's peers).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

import numpy as np
from scipy.sparse.csgraph import minimum_spanning_tree
from scipy.spatial.distance import pdist, squareform

from fleet_agent.beliefs import Beliefs
from fleet_agent.knowledge import Knowledge
from fleet_agent.witness import Witness, new_track
from hfc_core.model.problem import Problem

HOME_RADIUS_M = 50.0  # "home" said farther than this from its rendezvous is a lie
FIND_MARGIN_M = 15.0  # beyond the camera's reach: navigation and quantisation
FIND_SIGMAS = 3.0  # and its finder's navigation uncertainty, this many sigmas of it ...
FIND_SIGMA_CAP_M = 60.0  # ... at most (a liar's sigma loosens the check no further)
TRACK_SPEED_FACTOR = 1.2  # how much farther than cruise speed a peer may have gone between poses
CLAIM_SLACK = 1.1  # a claim's lower bound against the battery: currents, clock offsets
HELD_SLACK = 2.0  # all a vehicle holds, while its releases are on their way (measured: 1.54)


def cleared(know: Knowledge, sender: int, spots: Iterable[int],
            now: float = 0.0) -> tuple[list[int], int]:
    """Of the ``spots`` ``sender`` says are cleared (news to us), those to take now, and how
    many wait for a second word."""
    take, waiting = [], 0
    for t in spots:
        own = know.holdings.claim_time(t, sender) is not None  # the initial plan's, or claimed
        free = know.holder(t) is None and _known_or_its_own(know.beliefs, sender, t)
        if own or free or been_there(know, sender, t, now) or \
                Witness.second(know.witness.cleared, t, sender):
            take.append(t)
        else:
            waiting += 1
    return take, waiting


def _known_or_its_own(beliefs: Beliefs, sender: int, t: int) -> bool:
    """Whether a clear of ``t``, a spot nobody holds, can be taken from ``sender`` alone: a
    predicted spot, a find we know, or a find slot of the sender's own (it may treat its find
    before the FOUND frame arrives). A slot of someone else's we have not heard of waits for a
    second word: otherwise one CLEARED frame with every bit set would wipe out, ahead of
    time, every find the fleet is yet to make."""
    return beliefs.known(t) or (beliefs.is_find_slot(t) and beliefs.finder(t) == sender)


def been_there(know: Knowledge, sender: int, task: int, now: float) -> bool:
    """Could ``sender`` have been at spot ``task`` (its track passed within the camera's
    reach, the margin and the spot's uncertainty)? A vehicle that claimed a spot we also
    hold (two claims crossed under loss) and treated it says so; waiting for a second word
    there would treat it twice."""
    track = know.tracks.get(sender)
    if track is None:
        return False
    b = know.beliefs
    sigma = b.finds[task].sigma_m if task in b.finds else 0.0
    reach = (b.camera.detect_radius_m if b.camera is not None else 0.0) + FIND_MARGIN_M + \
        min(FIND_SIGMAS * sigma, FIND_SIGMA_CAP_M)
    speed = TRACK_SPEED_FACTOR * know.problem.vehicles[sender].speed_mps
    return near_track(track, tuple(know.problem.xyz[task]), reach, speed, now)


def claims(know: Knowledge, sender: int, tasks: Iterable[int]) -> list[int]:
    """The spots of a claim by ``sender`` that keep it within what it could treat (the
    module docstring); the rest are refused, from the claim's last spot back.

    Judged from its last pose at ``tp``: since then it moved at most speed x (now - tp),
    which lengthens a tree from the old pose by as much as its battery spent meanwhile, so
    the budget is the battery left at ``tp``, not now. Two bounds: what it claims now must fit
    (`CLAIM_SLACK`: its route holds all of it), and all it holds with it must fit twice over
    (`HELD_SLACK`: a vehicle that claims new work releases the work it gives up a frame
    later, and until the release arrives it seems to hold both; the held spots its heard
    track has passed are left out of it where it would refuse)."""
    p = know.problem
    spec = p.vehicles[sender]
    pose = know.peer_pose.get(sender)
    here = pose.pos if pose is not None else spec.start
    budget = spec.battery_s - (pose.t_s if pose is not None else 0.0)
    held = know.held_by(sender)  # from its own claims, not a walk over every spot
    mine = set(held)
    take = [t for t in tasks if t not in mine and t not in know.cleared]
    # A find of its own we have not heard of (its FOUND lost) lies where it saw it, near
    # where it is, not at the slot's placeholder (the station): judged there, or a claim
    # late in a dive would be refused and its find planned by a second vehicle.
    b = know.beliefs
    unheard = {t: here for t in take
               if b.is_find_slot(t) and t not in b.finds and b.finder(t) == sender}
    speed, heard_s = spec.speed_mps, pose.t_s if pose is not None else 0.0
    pending: list[int] | None = None

    def fits(take: list[int]) -> bool:
        nonlocal pending
        if work_s(p, here, speed, take, unheard) > CLAIM_SLACK * budget:
            return False
        if work_s(p, here, speed, held + take, unheard) <= HELD_SLACK * budget:
            return True
        # A held spot its heard track has passed is most likely treated, its clear not yet
        # heard: it leaves the second bound (hard seed 31 at 30 % loss: auv2's claim of a
        # spot refused for two spots it had passed, and the spot treated by both).
        if pending is None:
            pending = [t for t in held if not been_there(know, sender, t, heard_s)]
        return work_s(p, here, speed, pending + take, unheard) <= HELD_SLACK * budget

    while take and not fits(take):
        take.pop()
    return [t for t in tasks if t in mine or t in know.cleared or t in take]


def work_s(problem: Problem, here: Iterable[float], speed: float, spots: list[int],
           at: Mapping[int, Iterable[float]] | None = None) -> float:
    """A lower bound of the time to treat ``spots`` from ``here``: their injections, and a
    minimum spanning tree through them and ``here`` at ``speed`` (a spot in ``at`` taken
    to lie there)."""
    service = float(sum(problem.service_s[t] for t in spots))
    if not spots:
        return service
    pts = np.vstack([np.asarray(tuple(here), dtype=float)[None, :], problem.xyz[spots]])
    for i, t in enumerate(spots):
        if at and t in at:
            pts[i + 1] = tuple(at[t])
    tree = minimum_spanning_tree(squareform(pdist(pts))).sum()
    return service + float(tree) / speed


def abort_news(know: Knowledge, sender: int, subject: int) -> bool:
    """News of ``subject``'s abort from ``sender``: from itself, or from a second peer."""
    return sender == subject or Witness.second(know.witness.aborts, subject, sender)


def home(know: Knowledge, sender: int, pos: Iterable[float]) -> bool:
    """``sender`` says it is home at ``pos``: near its rendezvous?"""
    rdv = know.problem.vehicles[sender].rendezvous
    return math.dist(tuple(pos), rdv) <= HOME_RADIUS_M


TAKE, WAIT, REFUSE = "take", "wait", "refuse"


def find(know: Knowledge, sender: int, slot: int, pos: Iterable[float], priority: float,
         service_s: float, now: float, sigma_m: float = 0.0) -> str:
    """A find as ``sender`` tells it: `REFUSE` beyond the scenario's figures or, told by its
    finder, away from its track; `WAIT` relayed by another until its finder or a second peer
    tells it too; else `TAKE`. Before any pose of the finder, its start places it."""
    b = know.beliefs
    sc = b.scenario
    top = 2.0 * float(max(sc.priority, default=100.0))
    longest = 2.0 * float(max(sc.service_s, default=90.0))
    if not (0.0 <= priority <= top and 0.0 <= service_s <= longest):
        return REFUSE
    if b.exact or not b.n <= slot < b.n + know.problem.n_vehicles * b.cap or slot in b.finds:
        return TAKE  # refused by `discovery.on_found`, or known already (a conflict is
        #              counted there)
    finder = b.finder(slot)
    if finder != sender:
        if know.members.status(finder) != "alive":
            return TAKE  # its finder cannot tell it any more: one word is all there will be
        return TAKE if Witness.second(know.witness.finds, slot, sender) else WAIT
    track = know.tracks.get(sender) or new_track(sc.vehicles[sender].start)
    # Its find and its track are both in its own navigation frame, but a landmark may have
    # moved that frame between its last pose and the find (`fleet_agent.landmarks`).
    reach = (b.camera.detect_radius_m if b.camera is not None else 0.0) + FIND_MARGIN_M + \
        min(FIND_SIGMAS * sigma_m, FIND_SIGMA_CAP_M)
    near = near_track(track, tuple(pos), reach, TRACK_SPEED_FACTOR * sc.vehicles[sender].speed_mps,
                      now)
    return TAKE if near else REFUSE


def near_track(track: Iterable[tuple[float, tuple[float, float, float]]],
               pos: tuple[float, ...], reach_m: float, speed: float, now: float) -> bool:
    """Is ``pos`` within ``reach_m`` of where a vehicle whose poses were ``track`` (time,
    position) could have been by ``now``? Between two poses it was within speed x time of
    the straight line; after the last, within speed x the time since."""
    points = list(track)
    if not points:
        return False
    px, py = pos[0], pos[1]
    for (t0, a), (t1, b) in zip(points, points[1:]):
        r = reach_m + speed * max(0.0, t1 - t0) / 2.0
        # Outside the segment's box grown by r, it is farther than r (most segments of a
        # far peer's track, for most of the spots its cleared set is news of).
        if (px < min(a[0], b[0]) - r or px > max(a[0], b[0]) + r or py < min(a[1], b[1]) - r
                or py > max(a[1], b[1]) + r):
            continue
        if _segment_distance(a, b, pos) <= r:
            return True
    t_last, last = points[-1]
    return math.dist(last[:2], pos[:2]) <= reach_m + speed * max(0.0, now - t_last)


def _segment_distance(a: tuple[float, ...], b: tuple[float, ...], p: tuple[float, ...]) -> float:
    ax, ay, bx, by, px, py = a[0], a[1], b[0], b[1], p[0], p[1]
    dx, dy = bx - ax, by - ay
    d2 = dx * dx + dy * dy
    f = 0.0 if d2 <= 0 else min(1.0, max(0.0, ((px - ax) * dx + (py - ay) * dy) / d2))
    return math.hypot(px - ax - f * dx, py - ay - f * dy)


