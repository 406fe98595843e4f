"""What one vehicle knows: where it is and what it is doing, the cleared spots, who holds
what, who is alive, where the others were last heard, what it believes of the reef, and
which frames it has already taken. One object with a version.

State and queries, and the changes that bump `version`; what to do about it is decided by the
policies (`fleet_agent.policies`), which read this and return intents. Every query that
depends on membership uses the same view (`Membership.alive`), so the holder of a spot, the
free spots and the peers to plan for always agree within a step. The beliefs are always
present: on an exact map (no hidden reef) every predicted spot is known and nothing is found.
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Iterable
from dataclasses import dataclass

from fleet_agent import membership as mb
from fleet_agent.association import Estimate
from fleet_agent.beliefs import Beliefs
from fleet_agent.cleared import ClearedSet
from fleet_agent.config import AgentConfig
from fleet_agent.fleet import Fleet
from fleet_agent.membership import Membership
from fleet_agent.motion import OwnVehicle
from fleet_agent.negotiation import Holdings
from fleet_agent.plans import Planner
from fleet_agent.reckoning import position_along
from fleet_agent.replay import ReplayWindow
from fleet_agent.search import SearchBelief
from fleet_agent.wire import Digest
from fleet_agent.witness import Track, Witness, position_on
from fleet_bus.states import VehicleState
from hfc_core.model.problem import Problem

MAX_INJECTIONS = 4096  # own injections' measured positions kept (Knowledge.injections)

Point3 = tuple[float, float, float]


@dataclass(frozen=True)
class PeerPose:
    """A peer's last pose: where it said it was, when (its sequence number), in what state."""

    pos: Point3
    t_s: float
    state: str


class Knowledge:
    def __init__(self, fleet: Fleet, index: int, config: AgentConfig, cycle_s: float,
                 beliefs: Beliefs, own: OwnVehicle) -> None:
        p = fleet.problem
        self.fleet, self.index, self.beliefs, self.own = fleet, index, beliefs, own
        self.k = p.n_vehicles
        self.cleared = ClearedSet(p.n_tasks, fleet.codec.segment_bits)
        self.holdings = Holdings(p.n_tasks, fleet.base_routes)
        # Whom this vehicle expects to hear, and when the others speak (`membership`).
        self.hear_range_m = config.hear_range_m
        self.members = Membership(self.k, index, config.lost_after_cycles * cycle_s, cycle_s,
                                  timing=fleet.schedule, reach=self)
        self._routes: dict[int, tuple[float, list[int]]] = {}  # peer -> (when, believed route)
        # `held_map` and what it was last brought up to date with
        self._held: dict[int, int] = {}
        self._held_alive = -1  # the membership's alive_version
        self._held_alias: dict[int, int] | None = None  # the aliases (a merge makes anew)
        self._held_cleared = 0  # spots of the cleared set seen
        self._names: dict[int, tuple[int, ...]] = {}
        self._names_seen = -1
        # A claim has settled once any earlier claim of its spot has been heard and proven its
        # claimer's (`settled_s`; proving takes a cycle, `fleet_bus.tesla`).
        self.claim_settle_s = (config.claim_settle_cycles + 1.0) * cycle_s + config.slot_s + 1.0
        self.replay = ReplayWindow()
        self.treated: list[tuple[int, float]] = []  # own treatments: (task, time), in order
        self.peer_pose: dict[int, PeerPose] = {}
        # Spots left out of every plan of this vehicle, not cleared (others may work them):
        # those a peer that fell silent had probably treated before (its clear may have died
        # with it, `policies.takeover`), and those whose look showed a find a peer holds
        # (`policies.discovery`).
        self.doubtful: set[int] = set()
        # Finds left out of plans while a find some peer has cleared is unknown here and that
        # peer may have been at them (`policies.discovery.await_gaps`): its FOUND was lost,
        # and it may be the same aggregation under the other's name.
        self.awaiting: frozenset[int] = frozenset()
        self.peer_digest: dict[int, Digest] = {}
        # What waits for a second peer's word, each peer's recent track, and how often each
        # peer said what could not be (`policies.plausible`).
        self.witness = Witness()
        self.tracks: dict[int, Track] = {}
        self.suspicion: Counter[int] = Counter()
        # Spots this vehicle judged treated by someone (`policies.discovery.fold_treated`),
        # and what the cleared set and the finds were when it last judged.
        self.folded: set[int] = set()
        # Where this vehicle's camera measured what it injected (map frame, its sigma then):
        # held against later sightings, so a drifted vehicle that injected a neighbour of its
        # spot never injects that neighbour again (bounded: the oldest go first).
        self.injections: deque[Estimate] = deque(maxlen=MAX_INJECTIONS)
        self.fold_key: tuple[int, ...] = ()
        self.await_key: tuple[int, int, int] = (-1, -1, -1)  # what `awaiting` was judged on
        # Where missed aggregations are likely (`fleet_agent.search`; None: no search), the
        # spots this vehicle has weighed an orbit around, and its track since its last arrival.
        self.search: SearchBelief | None = None
        self.searched: set[int] = set()
        self.leg_track: list[Point3] = []
        # Bumped by every change a decision may depend on: the route is checked against the
        # knowledge again whenever it moved (`policies.route.sync`).
        self.version = 0
        self._beliefs_seen = beliefs.version

    # -- changes ---------------------------------------------------------------------------

    def touch(self) -> None:
        """Something changed that the route may depend on (the vehicle's own state, time)."""
        self.version += 1

    def clear(self, tasks: Iterable[int]) -> list[int]:
        """Spots known cleared (heard, looked at empty, an alias's aggregation); the new."""
        new = self.cleared.update(tasks)
        if new:
            self.touch()
        return new

    def merge_segment(self, segment: int, bits: bytes) -> list[int]:
        new = self.cleared.merge_segment(segment, bits)
        if new:
            self.touch()
        return new

    def treat(self, task: int, t_s: float) -> None:
        """This vehicle injected ``task`` at ``t_s``."""
        self.treated.append((task, t_s))
        self.cleared.add(task)
        self.touch()

    def hold(self, v: int, t_s: int, tasks: Iterable[int], claim: bool) -> list[int]:
        """A claim (or release) by ``v`` at ``t_s``; the spots whose record changed."""
        changed = self.holdings.apply(v, t_s, list(tasks), claim)
        if changed:
            self.touch()
        return changed

    def add_find(self, slot: int, pos: Point3, priority: float, service_s: float, now: float,
                 sigma_m: float = 0.0) -> bool:
        """A find, own or heard (`Beliefs.add_find`), held by its finder from now on
        (`Holdings.found`); True if news."""
        if not self.beliefs.add_find(slot, pos, priority, service_s, now, sigma_m):
            return False
        self.holdings.found(slot, self.beliefs.finder(slot))
        self.touch()
        return True

    def rebind(self) -> bool:
        """The beliefs changed (a find, a look): the vehicle times its route on the new
        working problem. True if they had."""
        if self.beliefs.version == self._beliefs_seen:
            return False
        self._beliefs_seen = self.beliefs.version
        self.own.rebind(self.beliefs.problem)
        self.touch()
        return True

    # -- the working problem ---------------------------------------------------------------

    @property
    def problem(self) -> Problem:
        return self.beliefs.problem

    @property
    def planner(self) -> Planner:
        return self.beliefs.planner

    def blocked(self, now: float) -> frozenset[int]:
        """Spots the planner must not be offered (`Beliefs.blocked`)."""
        return self.beliefs.blocked(now)

    def unavailable(self, now: float) -> frozenset[int]:
        """Cleared, blocked, doubtful, awaiting a lost find or held by a peer gone home: what
        a replan must leave out."""
        cleared = self.cleared
        out = frozenset(cleared) | self.blocked(now) | frozenset(self.doubtful) | self.awaiting
        return out | self.held_home(t for t in range(self.problem.n_tasks)
                                    if t not in out and t not in cleared)

    # -- holdings under the current membership view ----------------------------------------

    def holder(self, task: int) -> int | None:
        """Who holds ``task``: of a find that others were merged into, the earliest claim
        under any of its names (`names`)."""
        names = self.names(task)
        if len(names) == 1:
            return self.holdings.holder(task, self.members.alive)
        claims = [c for c in (self.holdings.holding(t, self.members.alive) for t in names)
                  if c is not None]
        return min(claims)[1] if claims else None

    def names(self, task: int) -> tuple[int, ...]:
        """``task`` and the finds merged into it (its aliases, `Beliefs.alias`): the names
        one aggregation goes by. Two vehicles that each named it claim it under their own
        names, and the one that claimed first holds it: under loss the later finder heard
        the other's claim long before its FOUND (hard seed 15 at 30 % loss: a claim at 383 s
        heard at 418 s, the FOUND at 538 s, and the aggregation treated again at 644 s)."""
        b = self.beliefs
        if not b.alias:
            return (task,)
        if self._names_seen != b.version:
            merged: dict[int, list[int]] = {}
            for a, h in sorted(b.alias.items()):
                merged.setdefault(h, [h]).append(a)
            self._names = {h: tuple(n) for h, n in merged.items()}
            self._names_seen = b.version
        return self._names.get(task, (task,))

    def held_map(self) -> dict[int, int]:
        """Spot -> holder, for every held spot nobody has cleared (an alias of a find is not
        a spot: its aggregation is held under the find's own slot). Do not change the dict
        returned. Walked whole only when a peer's status or the aliases change; otherwise
        brought up to date from the spots whose claims changed or that were cleared since
        (a fleet of 100 rebuilt it over 2500 spots at every claim heard)."""
        alias = self.beliefs.alias
        touched = self.holdings.take_touched()
        cleared = self.cleared.added_since(self._held_cleared)
        self._held_cleared += len(cleared)
        if self.members.alive_version != self._held_alive or alias is not self._held_alias:
            held = {t: h for t, h in self.holdings.holders(self.members.alive).items()
                    if t not in self.cleared and t not in alias}
            for head in {h for h in alias.values() if h not in self.cleared}:
                self._set_holder(held, head)
            self._held, self._held_alive = held, self.members.alive_version
            self._held_alias = alias
            return held
        held = self._held
        for t in cleared:
            held.pop(t, None)
        for t in touched:
            self._set_holder(held, alias.get(t, t))
        return held

    def _set_holder(self, held: dict[int, int], spot: int) -> None:
        """``held[spot]`` from the claims under any of its names (`holder`), or no entry if
        it is cleared or nobody holds it."""
        v = None if spot in self.cleared else self.holder(spot)
        if v is None:
            held.pop(spot, None)
        else:
            held[spot] = v

    def held_by(self, v: int) -> list[int]:
        """The spots ``v`` holds (nobody cleared them), in `held_map`'s order: from ``v``'s
        own claims, not a walk over every spot (the route is checked against it at every
        change)."""
        alias, alive = self.beliefs.alias, self.members.alive
        if not alias:
            return [t for t in self.holdings.claimed_by(v) if t not in self.cleared
                    and self.holdings.holder(t, alive) == v]
        out: dict[int, None] = {}  # a claim under an alias holds the find it was merged into
        for t in self.holdings.claimed_by(v):
            head = alias.get(t, t)
            if head not in self.cleared and self.holder(head) == v:
                out[head] = None
        return list(out)

    def free_spots(self, now: float = 0.0) -> set[int]:
        """Spots nobody holds, nobody is known to have cleared and no plan may take. A spot
        still claimed by a peer that has gone home is not free: the peer treated it or
        released it before it left, and no release was heard, so its clear is on its way
        (in a large fleet the cleared set spreads hop by hop: a vehicle once took such a spot
        700 s after it was treated)."""
        held = self.held_map()
        blocked = self.blocked(now)
        free = {t for t in range(self.problem.n_tasks) if t not in self.cleared
                and t not in held and t not in blocked and t not in self.doubtful
                and t not in self.awaiting}
        return free - self.held_home(free)

    def held_home(self, tasks: Iterable[int]) -> set[int]:
        """Those of ``tasks`` still claimed by a peer that has gone home (`free_spots`)."""
        home = {v for v in range(self.k) if v != self.index
                and self.members.status(v) == mb.HOME}
        if not home:
            return set()
        # A find held by its FOUND alone was never taken on: it went home without it.
        return {t for t in tasks
                if self.holdings.holder(t, home.__contains__, found=False) is not None}

    def settled_s(self, task: int) -> float:
        """When this vehicle may start work at ``task``: at once (0) on its initial plan,
        else ``claim_settle_s`` after its own claim. Why: the holder is the earliest claimant,
        and a claim goes out in the claimer's next slot (`fleet_agent.outbox`), so a peer's
        claim made before ours (whole seconds) is on the air within a cycle and heard within a
        slot more, and proven its claimer's a cycle later; by then, on a working link, we know
        we lost the spot. Without the wait, two vehicles near a find that both claimed it
        seconds apart each treat it."""
        c = own_claim_s(self, task)
        return c + self.claim_settle_s if c else 0.0

    def standing_claims(self) -> dict[int, int]:
        """Spots this vehicle claimed after the initial plan and still holds: spot -> time."""
        return {t: c for t, c in self.holdings.explicit_claims(self.index).items()
                if t not in self.cleared and self.holder(t) == self.index}

    # -- peers ------------------------------------------------------------------------------

    def expects(self, listener: int, speaker: int, t_s: float, slack_s: float = 0.0) -> bool:
        """Should ``listener`` have heard ``speaker`` around ``t_s`` were it alive: both where
        they are believed to be then (`whereabouts`), within ``hear_range_m`` (`membership`
        counts silences only where a frame was to be expected), plus how far the speaker
        travels in ``slack_s`` (its believed position is a reckoning over that long)."""
        a, b = self.whereabouts(listener, t_s), self.whereabouts(speaker, t_s)
        reach = self.hear_range_m + slack_s * self.problem.vehicles[speaker].speed_mps
        return (a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 <= reach ** 2

    def whereabouts(self, v: int, t_s: float) -> Point3:
        """Where vehicle ``v`` is believed to be at ``t_s`` if alive: this vehicle where it
        was then (`OwnVehicle.position_at`: a silence is judged where it began, and a judge
        that has moved on since was within reach then); a peer heard since ``t_s`` where its
        poses put it then; a peer dead-reckoned from its last pose along the route it is
        believed to fly (`replans.live_peer`'s estimate), or where the fleet plan puts it
        when none was heard (`fleet.tracks`)."""
        if v == self.index:
            return self.own.position_at(t_s)
        pose = self.peer_pose.get(v)
        if pose is None:
            tracks = self.fleet.tracks
            if not tracks:
                return self.problem.vehicles[v].start
            x, y = tracks[v].at(t_s)
            return (x, y, 0.0)
        if t_s < pose.t_s:  # heard since: where its poses put it then (`witness.Track`)
            track = self.tracks.get(v)
            at = position_on(track, t_s) if track else None
            if at is not None:
                return at
        dt = max(0.0, t_s - pose.t_s)
        # Cheap bound first: a vehicle moves at most its speed; most peers are far away.
        far = self.hear_range_m + self.problem.vehicles[v].speed_mps * dt
        here = self.own.pos
        if (pose.pos[0] - here[0]) ** 2 + (pose.pos[1] - here[1]) ** 2 > (2 * far) ** 2:
            return pose.pos
        # Its last pose said it was done with its route: straight home, whatever spots of it
        # we still believe it holds (their clears may not have reached us yet).
        done = (VehicleState.RETURNING, VehicleState.HOME, VehicleState.ABORTED)
        route = [] if pose.state in done else self._believed_route(v, t_s)
        service_left = 0.5 * float(self.problem.service_s[route[0]]) \
            if pose.state == VehicleState.INJECTING and route else 0.0
        return position_along(self.problem, v, pose.pos, route, dt, service_left)

    def _believed_route(self, v: int, t_s: float) -> list[int]:
        """`peer_route`, kept a minute (it walks every spot's holder): dead reckoning needs
        the route's shape, not its last claim."""
        hit = self._routes.get(v)
        if hit is None or abs(t_s - hit[0]) > 60.0:
            hit = self._routes[v] = (t_s, self.peer_route(v))
        return hit[1]

    def active_peers(self) -> list[int]:
        return [v for v in range(self.k)
                if v != self.index and self.members.status(v) in mb.WORKING]

    def peer_route(self, v: int) -> list[int]:
        """What peer ``v`` is believed to do: its initial route's spots it still holds, then
        the spots it claimed since, in claim order."""
        held = self.held_map()
        base = [t for t in self.fleet.base_routes[v] if held.get(t) == v]
        extra = sorted((t for t, h in held.items() if h == v and t not in base),
                       key=lambda t: (self.holdings.claim_time(t, v) or 0, t))
        return base + extra

    def freed_route(self, v: int) -> list[int]:
        """What a peer just declared gone was believed to do and nobody holds now: its
        initial route's spots, then its own claims in claim order."""
        free = self.free_spots()
        claims = self.holdings.explicit_claims(v)
        base = [t for t in self.fleet.base_routes[v] if t in free]
        return base + sorted((t for t in claims if t in free and t not in base),
                             key=lambda t: (claims[t], t))

    # -- ids at the edges --------------------------------------------------------------------

    def vid(self, v: int) -> str:
        return self.problem.vehicles[v].id

    def tids(self, tasks: Iterable[int]) -> list[int]:
        spots = self.problem.tasks  # once: a property per spot cost the fleet's status lines
        return [spots[t].id for t in tasks]

    def priority_of(self, tasks: Iterable[int]) -> float:
        priority = self.problem.priority
        return float(sum(priority[t] for t in tasks))


def settled_by_s(know: Knowledge) -> float:
    """No spot's `Knowledge.settled_s` is later than this: the latest claim this vehicle
    made, plus the settle. What lets a route's projection skip asking past it (it asked for
    every spot of the route at every step: 5 million lookups in a 100-vehicle mission)."""
    c = know.holdings.latest_claim_s(know.index)
    return c + know.claim_settle_s if c else 0.0


def own_claim_s(know: Knowledge, task: int) -> float:
    """When this vehicle's claim of ``task`` counts from (0: its initial plan's, or none):
    what `Knowledge.settled_s` waits from, and what `policies.unproven` compares a rival
    claim with."""
    names = know.names(task)
    c: float | None
    if len(names) == 1:  # asked for every spot of the route at every step: kept short
        c = know.holdings.claim_time(task, know.index)
    else:
        c = max((t for t in (know.holdings.claim_time(n, know.index) for n in names) if t),
                default=None)
        if c:
            # One aggregation under several names: the claims under a name learned after
            # ours were in flight before we knew to look for them; they get a cycle.
            finds = know.beliefs.finds
            c = max([c, *(finds[t].learned_s for t in names if t in finds)])
    return float(c) if c else 0.0
