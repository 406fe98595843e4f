"""What a vehicle believes about the reef: the map is a prior (an exact map is the degenerate
case: every predicted spot known, no finds).

Each predicted spot is *unknown* until the camera shows it (`fleet_agent.sensor`): *present*
(with its real priority rho and injection time t, eq. 2) or *empty*. Aggregations the map
missed become *finds*, task indices beyond the scenario's: ``n + finder * find_slots +
counter``, so two finders never name two finds alike and the fleet's bitmaps (cleared set,
claims) cover them as they cover predicted spots. Every position is an estimate
(`fleet_agent.association`): a predicted spot uncertain by the map's error, a find by its
finder's navigation sigma (it travels with the find). Finds whose estimates pass the gates are
one aggregation seen twice (`same_aggregation`: near enough, and of a rho alike; grouped as
connected components over all the finds, so every vehicle folds the same aliases from the
same finds whatever their order): the lowest index of a group is the spot, the others
aliases nobody plans.

After the finds' slots come the operator's (``operator_slots``, also on an exact map): the
spot of the operator's add-spot number ``a`` (`fleet_bus.orders.Order.added`) is task index
``n + k * cap + a`` on every vehicle, from the signed order alone (never gossiped: a vehicle's
word cannot add one). It is planned like a find at the operator's figures (the depth of the
nearest predicted spot, the map's mean injection time) and injected without a look: the
operator saw it.

The planner works on a *working problem* of fixed size (n predicted + every slot, the
operator's included): a predicted
spot at its expected value (eq. 9's priority term taken in expectation: p * rho, and time
inspect_s + p * t), a present one at its real figures, a find at its figures, an unused slot a
placeholder at the first station that is never offered to the planner (`blocked`). The problem
is rebuilt when beliefs change (distances only when a find or an added spot adds a position).
On an exact map without operator slots the working problem is the scenario itself.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass

import numpy as np

from fleet_agent.association import Estimate, aliases, found, predicted, resolve
from fleet_agent.config import AgentConfig
from fleet_agent.plans import Planner
from fleet_agent.sensor import Camera
from fleet_agent.wire import Digest
from hfc_core.model.problem import Problem, Task

Point3 = tuple[float, float, float]
UNKNOWN, PRESENT, EMPTY = "unknown", "present", "empty"
SIGHTINGS_KEPT = 4  # a sighted spot's latest sightings kept (`Beliefs.sighted`)
FIND_MARGIN_M = 1000.0  # the wire's grid reaches this far beyond the map (finds off it)


def _slot_hash(slot: int) -> int:
    return int.from_bytes(hashlib.blake2b(slot.to_bytes(4, "little"), digest_size=2,
                                          person=b"finds").digest(), "little")


@dataclass(frozen=True)
class Find:
    """An aggregation the map missed: its slot, where, rho and t, when this vehicle learned
    of it (mission time: a find is planned `settle_s` later), and how uncertain its finder's
    navigation made ``pos`` (per axis, 1 sigma, as the wire carries it)."""

    slot: int
    pos: Point3
    priority: float
    service_s: float
    learned_s: float
    sigma_m: float = 0.0

    @property
    def estimate(self) -> Estimate:
        return Estimate(self.pos, self.sigma_m)


def expected_problem(scenario: Problem, camera: Camera, p_cots: float) -> Problem:
    """The scenario at its expected value: every predicted spot worth p * rho and costing
    the look plus p * t. The initial plan every vehicle computes alone is made on it."""
    tasks = [Task(t.id, t.pos, p_cots * t.priority, camera.inspect_s + p_cots * t.service_s)
             for t in scenario.tasks]
    return Problem.build(f"{scenario.name}-expected", scenario.vehicles, tasks,
                         [poly.tolist() for poly in scenario.forbidden],
                         dist_m=scenario.dist_m, current=scenario.current)


def find_ids(scenario: Problem, config: AgentConfig) -> range:
    """The task ids finds go by in telemetry (after the scenario's largest id), so a report
    or an operator can tell them from predicted spots."""
    base = max((t.id for t in scenario.tasks), default=-1) + 1
    return range(base, base + scenario.n_vehicles * config.find_slots)


def operator_ids(scenario: Problem, config: AgentConfig) -> range:
    """The task ids the operator's added spots go by in telemetry (after the finds' ids, also
    on an exact map)."""
    base = find_ids(scenario, config).stop
    return range(base, base + config.operator_slots)


def spot_depth(scenario: Problem, xy: tuple[float, float]) -> float:
    """The depth of the predicted spot nearest ``xy`` (an added spot's, which the operator
    gives as X Y only; 0 on a map without spots)."""
    if not scenario.n_tasks:
        return 0.0
    xyz = scenario.xyz[:scenario.n_tasks]
    d = (xyz[:, 0] - xy[0]) ** 2 + (xyz[:, 1] - xy[1]) ** 2
    return float(xyz[int(np.argmin(d)), 2])


class Beliefs:
    """Predicted spots' states, finds and aliases, and the working problem they make.

    Without a ``camera`` the map is exact (a mission without a hidden reef): every predicted
    spot is known as the map gives it, nothing is looked at or found, and the working problem
    is the scenario and the operator's slots (``working``, the fleet's, planned by its own
    ``planner`` until the operator adds a spot)."""

    def __init__(self, scenario: Problem, camera: Camera | None, config: AgentConfig,
                 index: int, seed: int, cycle_s: float, planner: Planner | None = None,
                 working: Problem | None = None) -> None:
        self.scenario, self.camera, self.config = scenario, camera, config
        self.params = config.association
        self.index, self.seed = index, seed
        self.exact = camera is None
        self.n = scenario.n_tasks
        self.cap = 0 if self.exact else config.find_slots
        self.op_from = self.n + scenario.n_vehicles * self.cap  # the operator's first slot
        self.size = self.op_from + config.operator_slots
        self.settle_s = config.find_settle_cycles * cycle_s
        self.state = [PRESENT if self.exact else UNKNOWN] * self.n
        self.real: dict[int, tuple[float, float]] = {}  # present predicted: (rho, t)
        # Predicted spots known present from a sighting along the track, not a look, with
        # where the camera saw what it took for them (map frame; the latest few): which
        # aggregation a sighting is rests on the frame, and an injection near either place
        # may have treated that very aggregation (`doubt`).
        self.sighted: dict[int, tuple[Estimate, ...]] = {}
        # ... of which those seen with a navigation sigma above `look_first_sigma_m`: the
        # vehicle may be a look's footprint off where it thinks, and inject a neighbour or
        # bare seabed; it looks first (the look is also a landmark for its frame).
        self.look_first: set[int] = set()
        self.finds: dict[int, Find] = {}
        self.added: dict[int, Find] = {}  # the operator's spots, by slot
        self.alias: dict[int, int] = {}  # slot -> the slot it is an alias of
        self.own_found = 0
        self.finds_dropped = 0  # own finds beyond find_slots (memory stays bounded)
        self.conflicts = 0  # a slot announced twice with different figures
        self.refused = 0  # finds on land or off the map's grid: no vehicle could treat them
        self._count = 0
        self._hash = 0
        self._base_id = find_ids(scenario, config).start
        self._op_base_id = operator_ids(scenario, config).start
        self._service_s = float(np.mean(scenario.service_s)) if self.n else 60.0
        self._pred_xyz = np.array([t.pos for t in scenario.tasks], dtype=float).reshape(-1, 3)
        if self.exact and working is None and self.size == self.n:
            working = scenario  # nothing beyond the map: the scenario is the working problem
        self._problem: Problem | None = working if self.exact else None
        self._planner: Planner | None = planner if self._problem is not None else None
        self._dist: np.ndarray | None = None
        self._dist_key = (-1, -1)  # finds and added spots the cached distances include
        self.version = 0

    # -- queries ---------------------------------------------------------------------------

    def unknown(self, task: int) -> bool:
        """Must the vehicle look before injecting ``task``? Unknown, or known present only
        from a sighting its navigation was too unsure of (`look_first`)."""
        return task < self.n and (self.state[task] == UNKNOWN or task in self.look_first)

    def task_id(self, slot: int) -> int:
        if slot >= self.op_from:
            return self._op_base_id + slot - self.op_from
        return self._base_id + slot - self.n

    def is_find_id(self, task_id: int) -> bool:
        return task_id >= self._base_id

    def is_find_slot(self, slot: int) -> bool:
        """Is ``slot`` one of the finds' (not a predicted spot, not the operator's)?"""
        return self.n <= slot < self.op_from

    def weighs_without_slack(self) -> bool:
        """Has this vehicle spots to weigh even with no spare battery: a find of its own (its
        finder weighs it against its route) or an operator's spot (`policies.cooperate`)?"""
        return self.own_found > 0 or bool(self.added)

    def known(self, task: int) -> bool:
        """A predicted spot, a find or an added spot this vehicle knows of."""
        return task < self.n or task in self.finds or task in self.added

    def canonical(self, task: int) -> int:
        return self.alias.get(task, task)

    def blocked(self, now: float) -> frozenset[int]:
        """Spots the planner must not offer: unused slots, aliases, finds still settling."""
        out = [s for s in range(self.n, self.op_from) if s not in self.finds or s in self.alias
               or self.finds[s].learned_s + self.settle_s > now]
        out += [s for s in range(self.op_from, self.size) if s not in self.added]
        return frozenset(out)

    def next_settle_s(self, now: float) -> float | None:
        """When the next find still settling may be planned."""
        due = [f.learned_s + self.settle_s for f in self.finds.values()
               if f.learned_s + self.settle_s > now]
        return min(due) if due else None

    def digest(self) -> Digest:
        """Size mod 128 and an order-free 16-bit hash of the slots known: equal digests,
        (almost surely) equal sets."""
        return Digest(self._count & 0x7F, self._hash)

    def estimate(self, task: int) -> Estimate:
        """Where spot ``task`` is, as an estimate: a predicted spot's map position (and the
        map's rho: `association.predicted`), a find's finder's with the rho its camera
        measured; an operator's added spot by position alone (its rho is the operator's
        figure, not a measurement)."""
        if task < self.n:
            t = self.scenario.tasks[task]
            return predicted(t.pos, self.params, t.priority)
        if task in self.added:
            return self.added[task].estimate
        return self.find_estimate(self.finds[task])

    def find_estimate(self, f: Find) -> Estimate:
        """A find as an estimate: its finder's position and sigma, and the rho its camera
        measured (uncertain by the camera's error, `AssociationParams`)."""
        return found(f.pos, f.sigma_m, self.params, f.priority)

    def resolve(self, seen: Estimate, but: int | None = None
                ) -> tuple[tuple[str, int] | None, bool]:
        """What a sighting ``seen`` is (`association.resolve`): ("task", t) a predicted spot
        not known empty, ("find", s) a known find (its group's head), or None (news); and
        whether that is sure (several alike: only a look can tell which). ``but``: a spot
        it is known not to be."""
        cands: list[tuple[tuple[str, int], Estimate]] = [
            (("task", t), self.estimate(t)) for t in self._near(seen, self.n)
            if self.state[t] != EMPTY and t != but]
        cands += [(("find", s), self.find_estimate(f)) for s, f in sorted(self.finds.items())
                  if s not in self.alias and s != but]
        cands += [(("find", s), f.estimate) for s, f in sorted(self.added.items()) if s != but]
        return resolve(seen, cands, self.params)

    def _near(self, seen: Estimate, n: int) -> list[int]:
        """Predicted spots that could pass a gate with ``seen`` (a cheap box before the
        gate itself: the gate's radius is under 5 sigma of the widest estimate)."""
        if not n:
            return []
        p = self.params
        reach = 5.0 * (seen.sigma_m + p.map_sigma_m + p.extent_m) + 1.0
        d = np.abs(self._pred_xyz[:, :2] - np.asarray(seen.xy, float)).max(axis=1)
        return [int(t) for t in np.flatnonzero(d <= reach)]

    # -- learning --------------------------------------------------------------------------

    def learn(self, task: int, present: bool, priority: float = 0.0,
              service_s: float = 0.0, sighted: Estimate | None = None) -> bool:
        """A predicted spot seen (present, with rho and t) or inspected empty; True if news
        (never on an exact map: nothing to learn). ``sighted``: the estimate of a sighting
        along the track, not a look where the vehicle was sent, so which aggregation it was
        rests on the frame (`doubt`); a look settles it. Neither is journalled: a restarted
        agent looks again."""
        if self.exact or not 0 <= task < self.n:
            return False
        if sighted is not None and present:
            self.sighted[task] = (*self.sighted.get(task, ())[-(SIGHTINGS_KEPT - 1):], sighted)
        else:
            self.sighted.pop(task, None)
            self.look_first.discard(task)
        new = PRESENT if present else EMPTY
        if self.state[task] == new and (not present
                                        or self.real.get(task) == (priority, service_s)):
            return False
        self.state[task] = new
        if present:
            self.real[task] = (float(priority), float(service_s))
        self._changed()
        return True

    def doubt(self, task: int) -> None:
        """A spot known present from a sighting alone may have been another aggregation:
        unknown again, so the vehicle looks before it injects there."""
        self.sighted.pop(task, None)
        self.look_first.discard(task)
        if self.state[task] == PRESENT:
            self.state[task] = UNKNOWN
            self.real.pop(task, None)
            self._changed()

    def finder(self, slot: int) -> int:
        """The vehicle that named find ``slot`` (slots are handed out per finder)."""
        return (slot - self.n) // self.cap

    def own_slot(self) -> int | None:
        """The next slot this vehicle may name, or None (all used: counted)."""
        if self.own_found >= self.cap:
            self.finds_dropped += 1
            return None
        slot = self.n + self.index * self.cap + self.own_found
        self.own_found += 1
        return slot

    def add_find(self, slot: int, pos: Point3, priority: float, service_s: float,
                 now: float, sigma_m: float = 0.0) -> bool:
        """A find (own or heard); True if news. A slot already known with other figures is a
        conflict (counted, the first kept): finds never change once named."""
        if not self.is_find_slot(slot):
            return False
        if not self._wet(pos):
            self.refused += 1  # a planner fed a spot on land would fail: keep it out
            return False
        old = self.finds.get(slot)
        if old is not None:
            if old.pos != tuple(pos) or old.priority != priority or \
                    old.service_s != service_s or old.sigma_m != sigma_m:
                self.conflicts += 1
            return False
        finder, counter = divmod(slot - self.n, self.cap)
        if finder == self.index:  # our own slot, heard back (e.g. after a restart)
            self.own_found = max(self.own_found, counter + 1)
        self.finds[slot] = Find(slot, (float(pos[0]), float(pos[1]), float(pos[2])),
                                float(priority), float(service_s), float(now),
                                float(sigma_m))
        self._count += 1
        self._hash = (self._hash + _slot_hash(slot)) & 0xFFFF
        self._merge()
        self._changed()
        return True

    def op_slot(self, added: int) -> int | None:
        """The slot of the operator's add-spot number ``added``, or None (beyond the slots)."""
        return self.op_from + added if 0 <= added < self.size - self.op_from else None

    def add_spot(self, slot: int, pos: Point3, priority: float, now: float,
                 service_s: float | None = None) -> str | None:
        """The operator's spot at ``pos`` in operator slot ``slot``: None if added (or
        known already, alike), else why not: ``no_room`` (not an operator slot, or one taken
        by other figures) or ``on_land`` (no vehicle could go there)."""
        if not self.op_from <= slot < self.size:
            return "no_room"
        if not self._wet(pos):
            return "on_land"
        spot = Find(slot, (float(pos[0]), float(pos[1]), float(pos[2])), float(priority),
                    self._service_s if service_s is None else float(service_s), float(now))
        old = self.added.get(slot)
        if old is not None:
            return None if (old.pos, old.priority, old.service_s) == (
                spot.pos, spot.priority, spot.service_s) else "no_room"
        self.added[slot] = spot
        self._changed()
        return None

    def added_at(self, x: float, y: float) -> Point3:
        """Where an added spot at ``x, y`` is (the nearest predicted spot's depth)."""
        return (float(x), float(y), spot_depth(self.scenario, (x, y)))

    def _wet(self, pos: Point3) -> bool:
        """Finite and in the water (the working problem must stay plannable)."""
        if not all(math.isfinite(c) for c in pos):
            return False
        land = self.scenario.land
        return land is None or not bool(land.inside(np.array([pos], dtype=float))[0])

    def _merge(self) -> None:
        """Group the finds that are one aggregation (`association.aliases`): the lowest
        index of a group is the spot, the rest its aliases; the same finds give the same
        aliases on every vehicle."""
        self.alias = aliases([(s, self.find_estimate(self.finds[s])) for s in self.finds],
                             self.params)

    def _changed(self) -> None:
        self.version += 1
        self._problem = None
        self._planner = None

    # -- the working problem ---------------------------------------------------------------

    def p_of(self, task: int) -> float:
        """The chance predicted spot ``task`` holds COTS: the prior, raised near a find or a
        spot seen present (COTS aggregate)."""
        cfg = self.config
        pos = self.scenario.tasks[task].pos
        r = cfg.aggregation_radius_m
        near = any(math.dist(self.scenario.tasks[t].pos, pos) <= r for t in self.real) or \
            any(math.dist(f.pos, pos) <= r for s, f in self.finds.items() if s not in self.alias)
        return max(cfg.p_cots, cfg.p_cots_near_find) if near else cfg.p_cots

    def _tasks(self) -> list[Task]:
        out = []
        for i, t in enumerate(self.scenario.tasks):
            if self.exact:
                rho, service = t.priority, t.service_s
            elif self.state[i] == PRESENT:
                rho, service = self.real[i]
            elif self.state[i] == EMPTY:
                rho, service = 0.0, 0.0
            else:
                # The value follows the neighbourhood; the time stays at the prior's: raising
                # it near every find would overfill the routes and drop spots that would have
                # fit (COTS are dense: most spots are near some find).
                rho = self.p_of(i) * t.priority
                assert self.camera is not None  # an exact map has no unknown spot
                service = self.camera.inspect_s + self.config.p_cots * t.service_s
            out.append(Task(t.id, t.pos, rho, service))
        station = self.scenario.vehicles[0].start
        for s in range(self.n, self.size):
            f = self.finds.get(s) or self.added.get(s)
            if f is None or s in self.alias:
                out.append(Task(self.task_id(s), f.pos if f else station, 0.0, 0.0))
            else:
                out.append(Task(self.task_id(s), f.pos, f.priority, f.service_s))
        return out

    @property
    def problem(self) -> Problem:
        if self._problem is None:
            self._problem = self._build()
        return self._problem

    @property
    def planner(self) -> Planner:
        if self._planner is None:
            self._planner = Planner.from_config(self.problem, self.seed, self.config)
        return self._planner

    def _build(self) -> Problem:
        sc = self.scenario
        tasks = self._tasks()
        key = (len(self.finds), len(self.added))
        if self._dist is None or self._dist_key != key:
            xyz = np.zeros((len(tasks) + 2 * sc.n_vehicles, 3))
            xyz[:len(tasks)] = [t.pos for t in tasks]
            xyz[len(tasks):] = sc.xyz[sc.n_tasks:]
            if sc.land is not None:
                self._dist = sc.land.distance_matrix(xyz)
            else:
                from hfc_core.model.geometry import distance_matrix

                self._dist = distance_matrix(xyz)
            if self.exact:  # the map's own metric between its points, whatever it was
                keep = [*range(self.n), *range(len(tasks), len(xyz))]
                self._dist[np.ix_(keep, keep)] = sc.dist_m
            self._dist_key = key
        return Problem.build(f"{sc.name}-believed", sc.vehicles, tasks,
                             [poly.tolist() for poly in sc.forbidden], dist_m=self._dist,
                             current=sc.current)


def initial_working_problem(scenario: Problem, camera: Camera | None,
                            config: AgentConfig) -> Problem:
    """The working problem before anything is seen or added (what every vehicle starts
    from; without a ``camera``, the scenario and the operator's slots)."""
    return Beliefs(scenario, camera, config, 0, 0, 1.0).problem


__all__ = [
    "EMPTY",
    "FIND_MARGIN_M",
    "PRESENT",
    "UNKNOWN",
    "Beliefs",
    "Find",
    "expected_problem",
    "initial_working_problem",
    "operator_ids",
    "spot_depth",
]
