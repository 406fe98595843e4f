"""Who holds which spot: claims, releases and the one conflict rule every vehicle applies.

The shared initial plan is everyone's claim at time 0 on the spots of its route. Later claims
carry their time. For each (spot, vehicle) the newest of its claim and release counts (a
release wins a tie). The holder of a spot is the live claimant with the earliest claim, ties
going to the lower vehicle index. So:

- no leader and no vote: every vehicle evaluates the same rule on what it has heard, and
  vehicles that have heard the same claims agree;
- a claim dies with its claimer: a lost or aborted vehicle holds nothing, so its spots fall
  to the next claimant or become free (the takeover), and come back to it if it revives
  (a false alarm costs a detour, not a duplicate);
- cooperation and takeover never fight the initial plan of a live vehicle (time 0 wins);
- a find is its finder's from its FOUND frame on, as if in the initial plan, until the
  finder claims it in its own time or gives it up (`Holdings.found`).
"""

from __future__ import annotations

from functools import lru_cache
from collections.abc import Callable, Iterable, Sequence

Alive = Callable[[int], bool]
Record = tuple[int, bool]  # (time, is_claim)
BASE: Record = (0, True)  # the initial plan's claim


class BaseClaims:
    """The initial plan's claims, the same for every vehicle of a fleet and never changed:
    shared by all the agents of one process (`base_claims`), so a vehicle's own memory holds
    only the claims and releases made since (a fleet of 100 kept 2500 records per agent,
    each in a dict of its own, before)."""

    def __init__(self, base_routes: tuple[tuple[int, ...], ...]) -> None:
        owners: dict[int, list[int]] = {}
        for v, route in enumerate(base_routes):
            for task in route:
                row = owners.setdefault(task, [])
                if v not in row:
                    row.append(v)
        # spot -> the vehicles whose initial route has it (one, in a plan); in route order
        self.owners: dict[int, tuple[int, ...]] = {t: tuple(vs) for t, vs in owners.items()}
        self.rank: dict[int, int] = {t: i for i, t in enumerate(owners)}
        self.routes = base_routes


@lru_cache(maxsize=4)
def base_claims(base_routes: tuple[tuple[int, ...], ...]) -> BaseClaims:
    """One `BaseClaims` per initial plan in a process (a few plans at most: tests)."""
    return BaseClaims(base_routes)


class Holdings:
    def __init__(self, n_tasks: int, base_routes: Sequence[Sequence[int]]) -> None:
        self.n_tasks = n_tasks
        self.version = 0  # bumped by every change (what depends on holdings may be cached)
        self.base = base_claims(tuple(tuple(int(t) for t in r) for r in base_routes))
        # task -> vehicle -> (time, is_claim): the records made since the initial plan (a
        # vehicle's record of a spot of its initial route replaces that claim)
        self._events: dict[int, dict[int, Record]] = {}
        # vehicle -> task -> claim time, for claims after the initial plan (reported in
        # every status)
        self._explicit: dict[int, dict[int, int]] = {}
        # vehicle -> spots outside its initial route whose newest record is a claim
        self._extra: dict[int, set[int]] = {}
        # spot outside the initial plan -> its place in the order spots were first claimed
        self._later: dict[int, int] = {}
        # spots whose record changed since `take_touched` last ran (its one reader keeps a
        # map of holders up to date from them; a set, so bounded by the spots)
        self._touched: set[int] = set()
        # find -> its finder, who holds it from its FOUND on (`found`)
        self._found: dict[int, int] = {}
        # vehicle -> the latest time it ever claimed a spot (`latest_claim_s`)
        self._latest: dict[int, int] = {}

    def _record(self, task: int, v: int) -> Record | None:
        rec = self._events.get(task, {}).get(v)
        if rec is None and (v in self.base.owners.get(task, ()) or self._found.get(task) == v):
            return BASE
        return rec

    def found(self, task: int, finder: int) -> None:
        """A find named by ``finder``: held by it from its FOUND on, a claim at time 0 (as the
        initial plan's), until its finder claims it in its own time or releases it. Why:
        without it a peer that heard the FOUND and not the finder's claim took the find for
        free, and both treated it (hard seed 15 at 1 % drift: named 3057 s, claimed 3080 s; a
        peer heard the FOUND at 3118 s, claimed at 3140 s)."""
        if task in self._found:
            return
        self._found[task] = int(finder)
        self._later.setdefault(task, len(self._later))
        self._touched.add(task)
        self.version += 1

    def reserved_by(self, v: int) -> list[int]:
        """Finds ``v`` holds by their FOUND alone: it has neither claimed nor released them."""
        return [t for t, f in self._found.items() if f == v and v not in self._events.get(t, {})]

    def apply(self, v: int, t_s: int, tasks: Iterable[int], claim: bool) -> list[int]:
        """Record a claim (``claim``) or release by ``v`` at ``t_s``; returns the spots whose
        record changed."""
        changed = []
        for task in tasks:
            task = int(task)
            old = self._record(task, v)
            new = (int(t_s), claim)
            # Newest wins; at equal times a release beats a claim (False < True).
            if old is None or (new[0], not new[1]) > (old[0], not old[1]):
                self._events.setdefault(task, {})[v] = new
                changed.append(task)
                mine = self._explicit.setdefault(v, {})
                if claim and new[0] > 0:
                    mine[task] = new[0]
                    self._latest[v] = max(self._latest.get(v, 0), new[0])
                else:
                    mine.pop(task, None)
                if v not in self.base.owners.get(task, ()):
                    extra = self._extra.setdefault(v, set())
                    (extra.add if claim else extra.discard)(task)
                if task not in self.base.rank:
                    self._later.setdefault(task, len(self._later))
        if changed:
            self.version += 1
            self._touched.update(changed)
        return changed

    def take_touched(self) -> set[int]:
        """The spots whose record changed since the last call (`Knowledge.held_map`)."""
        touched, self._touched = self._touched, set()
        return touched

    def holder(self, task: int, alive: Alive, found: bool = True) -> int | None:
        best = self.holding(task, alive, found)
        return None if best is None else best[1]

    def holding(self, task: int, alive: Alive, found: bool = True) -> tuple[int, int] | None:
        """The winning claim of ``task``: (its time, its claimer), the initial plan's and a
        finder's (`found`; not with ``found`` False) at 0; the earliest wins, ties to the
        lower index (None: nobody alive holds it)."""
        best: tuple[int, int] | None = None
        row = self._events.get(task, {})
        for v in self.base.owners.get(task, ()):
            if v not in row and alive(v) and (best is None or v < best[1]):
                best = (0, v)  # its initial plan's claim, not replaced since
        f = self._found.get(task) if found else None
        if f is not None and f not in row and alive(f) and (best is None or f < best[1]):
            best = (0, f)  # its finder's, neither claimed in its own time nor released
        for v, (t, is_claim) in row.items():
            if is_claim and alive(v) and (best is None or (t, v) < best):
                best = (t, v)
        return best

    def latest_claim_s(self, v: int) -> int:
        """No claim time of ``v`` is later than this (0: none since the initial plan); a
        release leaves it where it was, so it only bounds."""
        return self._latest.get(v, 0)

    def claim_time(self, task: int, v: int) -> int | None:
        rec = self._record(task, v)
        return rec[0] if rec is not None and rec[1] else None

    def _order(self, task: int) -> int:
        """A spot's place in `holders`: the initial plan's in route order, then the others in
        the order they were first claimed."""
        rank = self.base.rank.get(task)
        return rank if rank is not None else len(self.base.rank) + self._later[task]

    def holders(self, alive: Alive) -> dict[int, int]:
        """task -> holder, for every held spot."""
        out = {}
        for task in [*self.base.rank, *self._later]:
            h = self.holder(task, alive)
            if h is not None:
                out[task] = h
        return out

    def claimed_by(self, v: int) -> list[int]:
        """Spots ``v`` claims (its newest record of each is a claim): those it may hold, in
        the order `holders` lists spots."""
        routes = self.base.routes
        mine = {t for t in (routes[v] if 0 <= v < len(routes) else ())
                if self._record(t, v) == BASE or self._events[t][v][1]}
        return sorted(mine | self._extra.get(v, set()), key=self._order)

    def named_since_plan(self) -> list[int]:
        """Spots outside the initial plan that a claim, a release or a FOUND has named, in
        the order first named: each of them exists, whatever its holder now."""
        return list(self._later)

    def explicit_claims(self, v: int) -> dict[int, int]:
        """Spots ``v`` claimed after the initial plan: task -> claim time."""
        return dict(self._explicit.get(v, {}))

    def records(self) -> list[tuple[int, int, int, bool]]:
        """(task, vehicle, time, is_claim) of every non-initial record (for the journal)."""
        return [(task, v, t, c) for task, row in self._events.items()
                for v, (t, c) in row.items() if t > 0 or not c]
