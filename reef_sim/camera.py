"""The camera on the hidden reef: what a simulated vehicle sees of `reef_sim.truth.Reef`.

Two things the camera does, both pure and seeded:

- *the look*: a vehicle that keeps station at a predicted spot to look learns whether COTS
  are there and, if so, their real priority rho and injection time t (paper eq. 2, as they
  really are). What it sees is decided where the vehicle really is: the aggregation the
  predicted spot names (`reef_sim.truth`) is seen if it lies within ``look_radius_m`` of the
  vehicle's true position (`look`). A vehicle whose navigation put it farther off sees
  nothing there. Other aggregations around are the sweep's (the camera is always on), so a
  look answers one question, whether the predicted aggregation is here, and with exact
  navigation it answers it as the truth's own bookkeeping does (`inspect`). A look at a
  find (a task from ``n_predicted`` on: a slot an agent named, whose aggregation the map
  does not name) shows the aggregation nearest under the camera within the footprint, the
  one an injection there would treat (`treated`): which aggregation that is, the agent
  tells from the rho it measures;
- *sighting*: along any path (transit included), a truth spot within ``detect_radius_m`` of
  the vehicle's true track is seen with probability ``p_detect`` per pass. A pass begins when
  the track comes within reach of the spot after being out of it; each pass has its own draw,
  from a stream keyed by (mission seed, vehicle, spot, pass number), so the in-process
  simulation and the multi-process fleet draw the same numbers whatever their step times.

The camera works on true positions; the vehicle that carries it reports what it saw in its own
navigation frame (`reef_sim.vehicle`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from reef_sim.truth import Reef

Point3 = tuple[float, float, float]
SENSOR_STREAM = 0x5E50  # keeps the camera's draws apart from every other seeded stream


class SeenSpot(NamedTuple):
    """An aggregation seen along the track: where it really is, what it is worth (rho, t),
    which truth spot it is and on which pass, and where the vehicle really was when the pass
    began (the track's first point within reach: the navigation error of the sighting is
    the one there, whatever the polling)."""

    pos: Point3
    priority: float
    service_s: float
    spot: int = -1  # the truth spot's index
    pass_no: int = 0
    at: Point3 | None = None


class Inspection(NamedTuple):
    """What a look at a predicted spot showed: COTS (``present``) with their real priority
    and injection time, or nothing."""

    present: bool
    priority: float = 0.0
    service_s: float = 0.0


def pass_seen(seed: int, vehicle: int, spot: int, pass_no: int, p_detect: float) -> bool:
    """Whether pass ``pass_no`` of ``vehicle`` by truth spot ``spot`` sees it: one uniform
    draw of its own stream against ``p_detect`` (0 never, 1 always)."""
    rng = np.random.default_rng([SENSOR_STREAM, seed, vehicle, spot, pass_no])
    return bool(rng.random() < p_detect)


def entry_point(a: Point3, b: Point3, spot: Point3, reach_m: float) -> Point3:
    """The first point of the segment a-b within ``reach_m`` of ``spot`` (3-D; the point
    nearest to it if rounding leaves none)."""
    pa = np.asarray(a, float)
    d = np.asarray(b, float) - pa
    q = pa - np.asarray(spot, float)
    dd = float(d @ d)
    if dd <= 0.0:
        return a
    # |q + f d|^2 = r^2: the smaller root, clipped to the segment
    half_b, c = float(q @ d), float(q @ q) - reach_m * reach_m
    disc = half_b * half_b - dd * c
    f = (-half_b - math.sqrt(disc)) / dd if disc >= 0 else -half_b / dd
    f = min(1.0, max(0.0, f))
    x, y, z = (pa + f * d).tolist()
    return (x, y, z)


def segment_distance_m(a: Point3, b: Point3, points: np.ndarray) -> np.ndarray:
    """Distance from each row of ``points`` (m, 3) to the segment a-b (3-D)."""
    pa, ab = points - np.asarray(a, float), np.asarray(b, float) - np.asarray(a, float)
    denom = float(ab @ ab)
    if denom <= 0.0:
        return np.linalg.norm(pa, axis=1)
    f = np.clip(pa @ ab / denom, 0.0, 1.0)
    return np.linalg.norm(pa - f[:, None] * ab, axis=1)


class ReefCamera:
    """The hidden reef as one vehicle's camera meets it: call `sweep` with each point of the
    true track and `look` when the vehicle keeps station at a predicted spot to look."""

    # Slack on the reach, so a spot exactly at the detect radius is within it despite the
    # rounding of positions computed along a leg.
    REACH_EPS_M = 1e-6

    def __init__(self, reef: Reef, seed: int, vehicle: int,
                 n_predicted: int | None = None) -> None:
        """``n_predicted``: the map's spots; tasks from it on are finds (None: every task
        is a predicted spot)."""
        self.reef, self.seed, self.vehicle = reef, int(seed), int(vehicle)
        self.n_predicted = n_predicted
        self._xyz = np.array([s.pos for s in reef.spots], dtype=float).reshape(-1, 3)
        self._inside = np.zeros(len(reef.spots), dtype=bool)
        self._passes = np.zeros(len(reef.spots), dtype=np.int64)
        self._last: Point3 | None = None

    @property
    def reach_m(self) -> float:
        return self.reef.detect_radius_m + self.REACH_EPS_M

    def passes(self) -> np.ndarray:
        """Per truth spot, how many passes within reach this camera made (each drew once
        against ``p_detect``): the world's book, for scoring what search would have found."""
        return self._passes.copy()

    def sweep(self, pos: Point3) -> list[SeenSpot]:
        """The track went (in a straight line) from the last position swept to ``pos``: the
        spots seen on the way, each pass drawing once."""
        a = pos if self._last is None else self._last
        self._last = (float(pos[0]), float(pos[1]), float(pos[2]))
        if not len(self._xyz):
            return []
        near = segment_distance_m(a, pos, self._xyz) <= self.reach_m
        entering = near & ~self._inside
        # Still within reach at the end of the piece: the same pass goes on next time.
        self._inside = np.linalg.norm(self._xyz - np.asarray(pos, float), axis=1) <= self.reach_m
        seen = []
        for i in np.flatnonzero(entering).tolist():
            self._passes[i] += 1
            if pass_seen(self.seed, self.vehicle, i, int(self._passes[i]), self.reef.p_detect):
                s = self.reef.spots[i]
                seen.append(SeenSpot(s.pos, s.priority, s.service_s, i, int(self._passes[i]),
                                     entry_point(a, pos, s.pos, self.reach_m)))
        return seen

    def is_find(self, task: int) -> bool:
        """Is ``task`` a find (a slot an agent named), not a predicted spot?"""
        return self.n_predicted is not None and task >= self.n_predicted

    def inspect(self, task: int, pos: Point3 | None = None) -> Inspection:
        """What predicted spot ``task`` really holds (the truth's bookkeeping, wherever the
        vehicle is: for a helm that does not say where it really is). A find holds what
        lies under the camera at ``pos`` (`look`), nothing without one."""
        if self.is_find(task):
            return Inspection(False) if pos is None else self.look(task, pos)
        i = self.reef.of_task(task)
        if i is None:
            return Inspection(False)
        s = self.reef.spots[i]
        return Inspection(True, s.priority, s.service_s)

    def look(self, task: int, pos: Point3) -> Inspection:
        """What a look at ``task`` shows with the vehicle really at ``pos`` (`seen_by_look`):
        the aggregation's rho and injection time, or nothing."""
        i = self.seen_by_look(task, pos)
        if i is None:
            return Inspection(False)
        s = self.reef.spots[i]
        return Inspection(True, s.priority, s.service_s)

    def seen_by_look(self, task: int, pos: Point3) -> int | None:
        """The truth spot a look at ``task`` sees with the vehicle really at ``pos``: at a
        predicted spot the aggregation it names if within ``look_radius_m`` (horizontally:
        the camera looks down at the seabed), at a find the nearest aggregation within it;
        None: nothing."""
        if self.is_find(task):
            return self._nearest_under(pos)
        i = self.reef.of_task(task)
        if i is None or math.dist(self.reef.spots[i].pos[:2], pos[:2]) > \
                self.reef.look_radius_m + self.REACH_EPS_M:
            return None
        return i

    def treated(self, task: int | None, pos: Point3) -> int | None:
        """The truth spot an injection at ``pos`` treats (the world's bookkeeping): the one
        predicted spot ``task`` names if within the look's footprint, else the nearest truth
        spot within it, else None (the vehicle injected bare seabed)."""
        i = None if task is None else self.reef.of_task(task)
        reach = self.reef.look_radius_m + self.REACH_EPS_M
        if i is not None and math.dist(self.reef.spots[i].pos[:2], pos[:2]) <= reach:
            return i
        return self._nearest_under(pos)

    def _nearest_under(self, pos: Point3) -> int | None:
        """The truth spot nearest ``pos`` within the look's footprint, or None."""
        if not len(self._xyz):
            return None
        d = np.hypot(self._xyz[:, 0] - pos[0], self._xyz[:, 1] - pos[1])
        j = int(np.argmin(d))
        return j if d[j] <= self.reef.look_radius_m + self.REACH_EPS_M else None
