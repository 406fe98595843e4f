"""What peers said that waits for a second word, and what the agent saw of each peer.

Kept with the knowledge (`fleet_agent.knowledge`), judged by `policies.plausible`: a cleared
spot, news of an abort or a relayed find that one peer alone cannot make true, each peer's
recent track (to place its finds), and how often each peer said what could not be.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from dataclasses import dataclass, field

TRACK_POINTS = 512  # positions kept per peer to judge its finds: 10 km of a track at
TRACK_STEP_M = 20.0  # ... one point per this much travel (a dive is a few km)
Point3 = tuple[float, float, float]
Track = deque[tuple[float, Point3]]  # (mission time, position)


@dataclass
class Witness:
    """Who said what that waits for a second word: spot -> senders (cleared), subject ->
    senders (an abort), find slot -> senders (a relayed find)."""

    cleared: dict[int, set[int]] = field(default_factory=dict)
    aborts: dict[int, set[int]] = field(default_factory=dict)
    finds: dict[int, set[int]] = field(default_factory=dict)

    @staticmethod
    def second(book: dict[int, set[int]], key: int, sender: int) -> bool:
        """``sender`` says ``key``: True once two different peers have said it."""
        said = book.setdefault(key, set())
        said.add(sender)
        if len(said) >= 2:
            del book[key]
            return True
        return False


def new_track(start: Point3 | None = None) -> Track:
    """A peer's track, from its start at mission time 0 when known."""
    track: Track = deque(maxlen=TRACK_POINTS)
    if start is not None:
        track.append((0.0, start))
    return track


def extend(track: Track, t_s: float, pos: Point3) -> None:
    """A new pose on ``track``, thinned to one point per `TRACK_STEP_M` of travel: a pose
    close to the point before the last replaces the last. Sound for `policies.plausible.
    near_track`: wherever a vehicle went between any two of its poses lies within half its
    reach (speed x time) of the segment between them, so dropping poses between kept ones
    only widens what it may have seen."""
    if track and t_s < track[-1][0]:
        return  # out of order (a late frame): the track only grows forward
    if len(track) >= 2 and math.dist(track[-2][1], pos) < TRACK_STEP_M:
        track[-1] = (t_s, pos)
    else:
        track.append((t_s, pos))


def position_on(track: Track, t_s: float) -> Point3 | None:
    """Where ``track`` puts its vehicle at ``t_s``: linear between the poses around it, the
    first pose before it; None from its last pose on (reckon from there instead)."""
    if not track or t_s >= track[-1][0]:
        return None
    i = bisect.bisect_right(track, t_s, key=lambda p: p[0])
    if i == 0:
        return track[0][1]
    (ta, pa), (tb, pb) = track[i - 1], track[i]
    w = 0.0 if tb <= ta else (t_s - ta) / (tb - ta)
    return (pa[0] + w * (pb[0] - pa[0]), pa[1] + w * (pb[1] - pa[1]),
            pa[2] + w * (pb[2] - pa[2]))
