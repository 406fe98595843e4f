"""Telemetry folded once: what the operator knows about the fleet from statuses and events,
and what the fleet collected.

The mission runner (either backend), the mission report and the ground station all read the
fleet through one `FleetLedger`: the newest status of each vehicle, the event log, and every
spot each vehicle reported treating (its statuses and its ``cleared`` events: a vehicle
killed between two statuses still announced its last treatment).

`FleetLedger.collected` is the one definition of the figures everybody shows (the terminal's
progress lines and summary, ``report.md``, its plots, the dashboard): spots treated, priority
collected and duplicate treatments, counted on the real reef when the mission has one (a
dynamic mission: `SpotValues.reef`) and on the map's predicted spots otherwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping, Sequence

from fleet_bus.states import FINAL_STATES, EventKind
from fleet_bus.telemetry import Event, Status, detail_position

MAX_EVENTS = 1_000_000  # a mission's whole log; beyond, the oldest are dropped and counted
# A find's position travels in its event detail in decimetres (`telemetry.position_detail`):
# it names the real spot this close.
FIND_MATCH_M = 1.0

Point = tuple[float, ...]


@dataclass(frozen=True)
class RealReef:
    """The hidden reef of a dynamic mission, as plain numbers (the simulated world's
    bookkeeping, `reef_sim.truth`): each real spot's priority and position, which predicted
    spot (scenario task id) each real spot is, and which ones the map missed."""

    priority: tuple[float, ...]
    positions: tuple[Point, ...]  # (x, y) or (x, y, z) metres
    of_task: Mapping[int, int]  # predicted spot id -> its real spot (those holding COTS)
    unmapped: frozenset[int] = frozenset()
    # positions already matched: the dashboard asks again at every status
    _matched: dict[tuple[Point, float], int | None] = field(
        default_factory=dict, compare=False, repr=False)

    @property
    def total(self) -> float:
        return float(sum(self.priority))

    def spot_at(self, pos: Point, within_m: float = FIND_MATCH_M) -> int | None:
        """The real spot nearest ``pos`` within ``within_m`` (a find's reported position);
        compared in as many dimensions as both have."""
        key = (tuple(pos), within_m)
        if key in self._matched:
            return self._matched[key]
        best, best_d = None, within_m
        for i, p in enumerate(self.positions):
            d = math.dist(p[:len(pos)], pos[:len(p)])
            if d <= best_d:
                best, best_d = i, d
        self._matched[key] = best
        return best


@dataclass(frozen=True)
class SpotValues:
    """What a treatment is worth: the map's priority per predicted spot (scenario task id)
    and, for a dynamic mission, the real reef, which then decides every figure."""

    predicted: Mapping[int, float]
    reef: RealReef | None = None

    @property
    def predicted_total(self) -> float:
        return float(sum(self.predicted.values()))


@dataclass(frozen=True)
class Treatment:
    """One vehicle's first report of treating one scenario id (a predicted spot or a find),
    and the spot it was: the real spot on a reef (None: nothing known there), else the id."""

    t_s: float
    vid: str
    task: int
    spot: int | None


@dataclass(frozen=True)
class Collected:
    """The figures of what the fleet collected, with what each is out of.

    ``on_reef``: counted on the real reef (spots are real spots, priorities real ones);
    otherwise on the scenario's predicted spots. A duplicate is a treatment of a spot some
    treatment had already treated (by any vehicle, under any id). ``by_vehicle``: per vehicle,
    the distinct spots it treated and their priority (a spot two vehicles treated counts for
    both, so these need not add up to the fleet's)."""

    on_reef: bool
    spots: int
    spots_of: int
    priority: float
    priority_of: float
    treatments: int
    duplicates: int
    by_vehicle: Mapping[str, tuple[int, float]] = field(default_factory=dict)

    @property
    def spot_word(self) -> str:
        """How the spots are named: ``real spots`` on a reef, ``spots`` otherwise."""
        return "real spots" if self.on_reef else "spots"


class FleetLedger:
    def __init__(self) -> None:
        self.statuses: dict[str, Status] = {}
        self.events: list[Event] = []
        self.treated_by: dict[str, set[int]] = {}
        self.cleared: set[int] = set()  # spots some vehicle treated (each once)
        self.treatments = 0
        self.events_dropped = 0
        # (vehicle, id) -> when it was treated: the earliest report (an event is stamped when
        # the injection ended; a status that lists it may come first, stamped later)
        self.treated_at: dict[tuple[str, int], tuple[float, int]] = {}
        self.positions: dict[int, Point] = {}  # find (or added spot) id -> where reported
        self.found: set[int] = set()  # find ids reported
        self.empty: set[int] = set()  # predicted spots inspected and found empty
        self._order = 0

    def add_status(self, s: Status) -> bool:
        """Fold ``s`` in (treatments are cumulative: safe in any order); True if it is the
        vehicle's newest status."""
        self.add_treated(s.id, s.treated, s.t_s)
        old = self.statuses.get(s.id)
        if old is not None and s.t_s < old.t_s:
            return False
        self.statuses[s.id] = s
        return True

    def add_event(self, e: Event) -> None:
        if len(self.events) >= MAX_EVENTS:
            self.events.pop(0)
            self.events_dropped += 1
        self.events.append(e)
        if e.kind in (EventKind.FOUND, EventKind.CLEARED, EventKind.ADDED) and \
                len(e.tasks) == 1:
            pos = detail_position(e.detail)
            if pos is not None:
                self.positions.setdefault(e.tasks[0], pos)
        if e.kind == EventKind.FOUND:
            self.found.update(e.tasks)
        elif e.kind == EventKind.EMPTY:
            self.empty.update(e.tasks)
        elif e.kind == EventKind.CLEARED:
            self.add_treated(e.id, e.tasks, e.t_s)

    def add_treated(self, vid: str, tasks: Sequence[int], t_s: float = math.inf) -> None:
        mine = self.treated_by.setdefault(vid, set())
        for t in tasks:
            key = (vid, t)
            if t not in mine:
                mine.add(t)
                self.cleared.add(t)
                self.treatments += 1
                self.treated_at[key] = (t_s, self._order)
                self._order += 1
            elif t_s < self.treated_at[key][0]:
                self.treated_at[key] = (t_s, self.treated_at[key][1])

    def state_of(self, vid: str) -> str | None:
        s = self.statuses.get(vid)
        return None if s is None else s.state

    def all_final(self, vehicles: list[str], dead: set[str]) -> bool:
        """Every vehicle home, aborted or dead."""
        return all(v in dead or self.state_of(v) in FINAL_STATES for v in vehicles)

    def duplicates(self) -> int:
        """Treatments beyond the first of each scenario id."""
        return self.treatments - len(self.cleared)

    # -- what the fleet collected ----------------------------------------------------------

    def spot_of(self, task: int, values: SpotValues) -> int | None:
        """The spot a treatment of scenario id ``task`` treated: on a reef, the real spot (a
        predicted spot by the reef's bookkeeping, a find by where it was reported; None if
        nothing real is known there); otherwise the id itself."""
        reef = values.reef
        if reef is None:
            return task
        if task in values.predicted:
            return reef.of_task.get(task)
        pos = self.positions.get(task)
        return None if pos is None else reef.spot_at(pos)

    def treatments_of(self, values: SpotValues) -> list[Treatment]:
        """Every treatment, in time order (reports of equal time in arrival order)."""
        order = sorted(self.treated_at.items(), key=lambda kv: kv[1])
        return [Treatment(t, vid, task, self.spot_of(task, values))
                for (vid, task), (t, _) in order]

    def collected(self, values: SpotValues) -> Collected:
        """The fleet's figures (see `Collected`) under ``values`` (in no particular order:
        linear in the treatments, as the dashboard asks at every status)."""
        reef = values.reef
        treatments = [Treatment(0.0, vid, task, self.spot_of(task, values))
                      for vid, task in self.treated_at]
        if reef is None:
            def worth(spot: int) -> float:
                return float(values.predicted.get(spot, 0.0))
            spots_of, priority_of = len(values.predicted), values.predicted_total
        else:
            def worth(spot: int) -> float:
                return float(reef.priority[spot])
            spots_of, priority_of = len(reef.priority), reef.total
        counted = [(t.vid, t.spot) for t in treatments if t.spot is not None]
        fleet = {spot for _, spot in counted}
        mine: dict[str, set[int]] = {}
        for vid, spot in counted:
            mine.setdefault(vid, set()).add(spot)
        return Collected(
            on_reef=reef is not None,
            spots=len(fleet), spots_of=spots_of,
            priority=sum(worth(s) for s in fleet if s is not None), priority_of=priority_of,
            treatments=len(counted), duplicates=len(counted) - len(fleet),
            by_vehicle={vid: (len(s), sum(worth(x) for x in s)) for vid, s in mine.items()})

    def found_spots(self, values: SpotValues) -> set[int]:
        """The real spots the fleet's finds are (empty without a reef)."""
        if values.reef is None:
            return set()
        spots = (values.reef.spot_at(self.positions[f]) for f in self.found
                 if f in self.positions)
        return {s for s in spots if s is not None}


def cumulative(treatments: Sequence[Treatment], values: SpotValues
               ) -> tuple[list[float], list[float], dict[str, tuple[list[float], list[float]]]]:
    """`Collected.priority` and each vehicle's priority over time, as step series: times and
    values of the fleet (each spot once), and per vehicle (each of its spots once). Their last
    values are `FleetLedger.collected`'s."""
    reef = values.reef

    def worth(spot: int) -> float:
        return float(reef.priority[spot]) if reef is not None else \
            float(values.predicted.get(spot, 0.0))

    t_s, total = [0.0], [0.0]
    per: dict[str, tuple[list[float], list[float]]] = {}
    fleet: set[int] = set()
    mine: dict[str, set[int]] = {}
    for tr in sorted(treatments, key=lambda t: t.t_s):
        if tr.spot is None:
            continue
        if tr.spot not in fleet:
            fleet.add(tr.spot)
            t_s.append(tr.t_s)
            total.append(total[-1] + worth(tr.spot))
        own = mine.setdefault(tr.vid, set())
        if tr.spot not in own:
            own.add(tr.spot)
            times, vals = per.setdefault(tr.vid, ([0.0], [0.0]))
            times.append(tr.t_s)
            vals.append(vals[-1] + worth(tr.spot))
    return t_s, total, per
