"""TDMA slot arithmetic, shared by the agents (who send in their own slot) and the water (the
channel's optional TDMA MAC): slot ``i`` of cycle ``n`` opens at ``n * cycle + i * slot_s``,
slots numbered in the scenario's vehicle order everywhere (`TdmaSchedule`); or a spatial
schedule in which vehicles far apart share slots (`SpatialSchedule`), computed from the fleet
plan every vehicle knows.

All processes share the mission clock (`fleet_bus.clock`), so slots need no negotiation and
the fleet's own frames never collide.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

EPS_S = 1e-9  # float slack on slot boundaries
MIN_SLOTS = 3  # the shortest cycle of a spatial schedule, in slots (see `_colour`)


@dataclass(frozen=True)
class TdmaSchedule:
    n_slots: int
    slot_s: float

    def __post_init__(self) -> None:
        if not (isinstance(self.n_slots, int) and self.n_slots >= 1):
            raise ValueError(f"a TDMA cycle needs at least one slot, got {self.n_slots!r}")
        if not (math.isfinite(self.slot_s) and self.slot_s > 0):
            raise ValueError(f"slot length must be positive, got {self.slot_s!r}")

    @property
    def cycle_s(self) -> float:
        return self.n_slots * self.slot_s

    def opens(self, slot: int, cycle: int, lead: float = 0.0) -> float:
        """When ``slot`` opens in cycle ``cycle``, plus ``lead`` (a share of the slot: senders
        start a little into their slot, room for clock skew)."""
        return cycle * self.cycle_s + (slot + lead) * self.slot_s

    def first_cycle(self, slot: int, t_s: float, lead: float = 0.0) -> int:
        """The first cycle in which ``opens(slot, cycle, lead)`` is at or after ``t_s``."""
        n = max(0, math.ceil((t_s - self.opens(slot, 0, lead)) / self.cycle_s))
        while self.opens(slot, n, lead) < t_s:
            n += 1
        return n

    def next_start(self, t_s: float, slot: int, airtime_s: float, guard_s: float) -> float:
        """Earliest time >= ``t_s`` at which a frame of ``airtime_s`` can start in ``slot`` and
        still end ``guard_s`` before the slot closes."""
        if airtime_s + guard_s > self.slot_s + EPS_S:
            raise ValueError(f"a {airtime_s:.3f} s frame never fits a {self.slot_s} s slot")
        cycle = math.floor(t_s / self.cycle_s)
        while True:
            opens = self.opens(slot, cycle)
            start = max(t_s, opens)
            if start + airtime_s <= opens + self.slot_s - guard_s + EPS_S:
                return start
            cycle += 1


@dataclass(frozen=True, eq=False)
class Track:
    """Where a vehicle is meant to be: ``xy`` (m, shape (m, 2)) at mission times ``t_s``
    (shape (m,), increasing), straight between, at the last point after the last time,
    parked (at its rendezvous, done) from ``done_s`` on."""

    t_s: np.ndarray
    xy: np.ndarray
    done_s: float

    def __post_init__(self) -> None:
        t, xy = np.asarray(self.t_s, dtype=float), np.asarray(self.xy, dtype=float)
        if t.ndim != 1 or len(t) < 1 or xy.shape != (len(t), 2) or np.any(np.diff(t) < 0):
            raise ValueError("a track needs increasing times and one (x, y) per time")
        object.__setattr__(self, "t_s", t)
        object.__setattr__(self, "xy", xy)

    def at(self, t_s: float) -> tuple[float, float]:
        return (float(np.interp(t_s, self.t_s, self.xy[:, 0])),
                float(np.interp(t_s, self.t_s, self.xy[:, 1])))


@dataclass(frozen=True)
class Epoch:
    """One stretch of the schedule: from ``start_s`` for ``cycles`` cycles of ``n_slots``
    slots; vehicle ``v`` owns slot ``slot[v]`` of every ``group[v]``-th cycle, starting with
    cycle ``rank[v]`` (a vehicle parked among many shares its slot in turn)."""

    start_s: float
    n_slots: int
    cycles: int
    slot: tuple[int, ...]
    group: tuple[int, ...]
    rank: tuple[int, ...]


class SpatialSchedule:
    """Spatial TDMA (Nelson and Kleinrock, "Spatial TDMA: a collision-free multihop channel
    access protocol", IEEE Trans. Commun. 33(9), 1985): vehicles far enough apart share a
    slot. Who may share is decided on what every vehicle knows before the first message,
    the fleet plan's tracks (`Track`), so the agents and the water's MAC compute the same
    schedule alone, and it stays valid as the vehicles move because it is recomputed for each
    *epoch* (about ``epoch_s``, a whole number of its cycles) from where the plan puts them
    then:

    - each vehicle's stretch of track in the epoch is bounded by a disk, widened by
      ``margin_m`` (how far a vehicle may stray from its plan's track: replans are local);
    - two vehicles conflict when their disks come within ``reuse_m``: the protocol model of
      Gupta and Kumar ("The capacity of wireless networks", IEEE Trans. Inf. Theory 46(2),
      2000): a frame from A decodes at a receiver R near it if every other sender in the slot
      is enough farther from R than A, so ``reuse_m`` is the range over which a frame must
      be heard plus the distance beyond it at which an interferer no longer matters
      (docs/membership.md works it out for the default modem);
    - the conflict graph is coloured greedily, largest degree first, ties by index (Welsh and
      Powell); a colour is a slot. Broadcast scheduling as graph colouring is Ramanathan and
      Lloyd's ("Scheduling algorithms for multihop radio networks", IEEE/ACM ToN 1(2), 1993);
    - vehicles parked at one place (home, done) beyond ``park_group`` of them share slots in
      groups of ``park_group``, taking turns: they only keep watch.

    With ``reuse_m`` None every vehicle conflicts with every other: slot ``i`` is vehicle
    ``i``'s in every cycle, the plain schedule of `TdmaSchedule`.
    """

    def __init__(self, tracks: Sequence[Track], slot_s: float, reuse_m: float | None = None,
                 margin_m: float = 300.0, epoch_s: float = 300.0, park_group: int = 4,
                 n_vehicles: int | None = None) -> None:
        n = len(tracks) if n_vehicles is None else n_vehicles
        if n < 1 or (tracks and len(tracks) != n) or (reuse_m is not None and not tracks):
            raise ValueError("a schedule needs one track per vehicle (tracks may be left out "
                             "only without reuse)")
        if not (math.isfinite(slot_s) and slot_s > 0):
            raise ValueError(f"slot length must be positive, got {slot_s!r}")
        if not (math.isfinite(epoch_s) and epoch_s > 0) or park_group < 1 or margin_m < 0:
            raise ValueError("need epoch_s > 0, park_group >= 1 and margin_m >= 0")
        self.tracks = tuple(tracks)
        self.n = n
        self.slot_s = float(slot_s)
        self.reuse_m = None if reuse_m is None else float(reuse_m)
        self.margin_m = float(margin_m)
        self.epoch_s = float(epoch_s)
        self.park_group = int(park_group)
        self._epochs: list[Epoch] = []
        self._starts: list[float] = []
        self._last: tuple[float, float, int] | None = None  # the epoch last asked for
        # Each vehicle's turns before each epoch (turns_before and nth_opening in O(log n))
        self._turns: list[tuple[int, ...]] = []

    # -- epochs ----------------------------------------------------------------------------

    def epoch(self, t_s: float) -> Epoch:
        """The epoch in force at mission time ``t_s`` (the first one before 0)."""
        return self._epochs[self._index(t_s)]

    def _index(self, t_s: float) -> int:
        last = self._last
        if last is not None and last[0] <= t_s < last[1]:
            return last[2]
        if not self._epochs:
            self._extend()
        while self._end(self._epochs[-1]) <= t_s:
            self._extend()
        i = max(0, bisect.bisect_right(self._starts, t_s) - 1)
        e = self._epochs[i]
        self._last = (e.start_s if i else -math.inf, self._end(e), i)
        return i

    def _end(self, e: Epoch) -> float:
        return e.start_s + e.cycles * e.n_slots * self.slot_s

    def _extend(self) -> None:
        if self._epochs:
            prev = self._epochs[-1]
            self._turns.append(tuple(t + _turns_in(prev, v)
                                     for v, t in enumerate(self._turns[-1])))
            start = self._end(prev)
        else:
            self._turns.append((0,) * self.n)
            start = 0.0
        e = self._colour(start)
        self._epochs.append(e)
        self._starts.append(e.start_s)

    def _colour(self, start_s: float) -> Epoch:
        n = self.n
        if self.reuse_m is None:
            cycle = n * self.slot_s
            return Epoch(start_s, n, max(1, math.ceil(self.epoch_s / cycle)), tuple(range(n)),
                         (1,) * n, (0,) * n)
        end = start_s + self.epoch_s
        centre = np.empty((n, 2))
        radius = np.empty(n)
        for v, tr in enumerate(self.tracks):
            times = [start_s, end, *[t for t in tr.t_s if start_s < t < end]]
            pts = np.array([tr.at(t) for t in times])
            lo, hi = pts.min(axis=0), pts.max(axis=0)
            centre[v] = (lo + hi) / 2.0
            radius[v] = float(np.linalg.norm(pts - centre[v], axis=1).max()) + self.margin_m
        nodes = self._nodes(start_s, centre)
        k = len(nodes)
        c = np.array([centre[g[0]] for g in nodes]).reshape(k, 2)
        r = np.array([max(radius[v] + float(np.linalg.norm(centre[v] - c[i]))
                          for v in g) for i, g in enumerate(nodes)])
        gap = np.linalg.norm(c[:, None, :] - c[None, :, :], axis=2)
        conflict = gap < r[:, None] + r[None, :] + self.reuse_m
        np.fill_diagonal(conflict, False)
        degree = conflict.sum(axis=1)
        colour = [-1] * k
        for i in sorted(range(k), key=lambda i: (-int(degree[i]), min(nodes[i]))):
            used = {colour[j] for j in np.flatnonzero(conflict[i])}
            colour[i] = next(x for x in range(k) if x not in used)
        # At least MIN_SLOTS a cycle: a frame must be heard before its sender discloses the
        # key of its turn at its next turn (`fleet_bus.tesla`; a second late, a second of travel)
        n_slots = max(max(colour) + 1, min(n, MIN_SLOTS))
        slot, group, rank = [0] * n, [1] * n, [0] * n
        for i, g in enumerate(nodes):
            for j, v in enumerate(g):
                slot[v], group[v], rank[v] = colour[i], len(g), j
        cycle = n_slots * self.slot_s
        cycles = max(1, math.ceil(self.epoch_s / cycle))
        cycles = math.ceil(cycles / math.lcm(*set(group))) * math.lcm(*set(group))
        return Epoch(start_s, n_slots, cycles, tuple(slot), tuple(group), tuple(rank))

    def _nodes(self, start_s: float, centre: np.ndarray) -> list[tuple[int, ...]]:
        """The conflict graph's nodes: one per vehicle, but vehicles parked at one place
        (within ``margin_m`` of each other) beyond ``park_group`` of them in groups."""
        parked = [v for v, tr in enumerate(self.tracks) if tr.done_s <= start_s]
        alone = [(v,) for v in range(self.n) if v not in set(parked)]
        places: list[list[int]] = []
        for v in parked:
            for place in places:
                if float(np.linalg.norm(centre[v] - centre[place[0]])) <= self.margin_m:
                    place.append(v)
                    break
            else:
                places.append([v])
        groups: list[tuple[int, ...]] = []
        for place in places:
            if len(place) <= self.park_group:
                groups += [(v,) for v in place]
            else:
                size = math.ceil(len(place) / math.ceil(len(place) / self.park_group))
                groups += [tuple(place[i:i + size]) for i in range(0, len(place), size)]
        return sorted(alone + groups)

    @classmethod
    def plain(cls, n_vehicles: int, slot_s: float) -> "SpatialSchedule":
        """One slot per vehicle, in index order, every cycle (`TdmaSchedule`'s)."""
        return cls((), slot_s, None, n_vehicles=n_vehicles)

    # -- one vehicle's turns -----------------------------------------------------------------

    def turns_before(self, v: int, t_s: float) -> int:
        """How many of ``v``'s slots opened before ``t_s`` (a count of its turns)."""
        i = self._index(t_s)
        e = self._epochs[i]
        cycle = e.n_slots * self.slot_s
        at = e.start_s + e.slot[v] * self.slot_s
        k = min(e.cycles, max(0, math.ceil((t_s - at) / cycle - EPS_S)))
        return self._turns[i][v] + max(0, math.ceil((k - e.rank[v]) / e.group[v]))

    def nth_opening(self, v: int, n: int, lead: float = 0.0) -> float:
        """The opening (plus ``lead`` slots) of ``v``'s slot of its turn ``n`` (0: its first):
        the inverse of `turns_before`."""
        if n < 0:
            raise ValueError(f"turn {n} before the first")
        while self._turns[-1][v] + _turns_in(self._epochs[-1], v) <= n:
            self._extend()
        lo, hi = 0, len(self._epochs) - 1  # the last epoch whose turns before it are <= n
        while lo < hi:
            mid = (lo + hi + 1) // 2
            lo, hi = (mid, hi) if self._turns[mid][v] <= n else (lo, mid - 1)
        e = self._epochs[lo]
        k = e.rank[v] + (n - self._turns[lo][v]) * e.group[v]
        return e.start_s + (e.slot[v] + lead) * self.slot_s + k * e.n_slots * self.slot_s

    def cycle_s(self, t_s: float) -> float:
        """The cycle (every vehicle not parked speaks once) in force at ``t_s``."""
        return self.epoch(t_s).n_slots * self.slot_s

    def turn_s(self, v: int, t_s: float) -> float:
        """How often vehicle ``v`` has a slot at ``t_s``."""
        e = self.epoch(t_s)
        return e.group[v] * e.n_slots * self.slot_s

    def opening(self, v: int, t_s: float, lead: float = 0.0) -> float:
        """The first opening (plus ``lead`` slots) of ``v``'s slots at or after ``t_s``."""
        t_s = max(t_s, 0.0)
        while True:
            e = self.epoch(t_s)
            cycle = e.n_slots * self.slot_s
            at = e.start_s + (e.slot[v] + lead) * self.slot_s
            k = max(0, math.ceil((t_s - at) / cycle - EPS_S))
            k += (e.rank[v] - k) % e.group[v]
            while at + k * cycle < t_s - EPS_S:
                k += e.group[v]
            if k < e.cycles:
                return at + k * cycle
            t_s = self._end(e)

    def latest(self, v: int, t_s: float, lead: float = 0.0) -> float | None:
        """The last opening (plus ``lead``) of ``v``'s slots at or before ``t_s`` (None if
        none yet)."""
        e = self.epoch(t_s)
        while True:
            cycle = e.n_slots * self.slot_s
            at = e.start_s + (e.slot[v] + lead) * self.slot_s
            k = min(e.cycles - 1, math.floor((t_s - at) / cycle + EPS_S))
            k -= (k - e.rank[v]) % e.group[v]
            if k >= 0 and at + k * cycle <= t_s + EPS_S:
                return at + k * cycle
            i = bisect.bisect_right(self._starts, e.start_s) - 2
            if i < 0:
                return None
            e = self._epochs[i]

    def next_start(self, v: int, t_s: float, airtime_s: float, guard_s: float) -> float:
        """Earliest time >= ``t_s`` at which a frame of ``airtime_s`` can start in one of
        ``v``'s slots and still end ``guard_s`` before the slot closes (the water's MAC)."""
        if airtime_s + guard_s > self.slot_s + EPS_S:
            raise ValueError(f"a {airtime_s:.3f} s frame never fits a {self.slot_s} s slot")
        last = self.slot_s - guard_s - airtime_s  # latest start within a slot, from its opening
        opened = self.latest(v, t_s)
        if opened is not None and t_s <= opened + last + EPS_S:
            return max(t_s, opened)
        return self.opening(v, t_s)


def _turns_in(e: Epoch, v: int) -> int:
    """How many turns ``v`` has in epoch ``e``: its cycles ``rank``, ``rank + group``, ..."""
    return max(0, math.ceil((e.cycles - e.rank[v]) / e.group[v]))
