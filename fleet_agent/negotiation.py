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
- cooperation and takeover never fight the initial plan of a live vehicle (time 0 wins).
"""

from __future__ import annotations

from typing import Callable, Iterable, Sequence

Alive = Callable[[int], bool]


class Holdings:
    def __init__(self, n_tasks: int, base_routes: Sequence[Sequence[int]]) -> None:
        self.n_tasks = n_tasks
        self.version = 0  # bumped by every change (what depends on holdings may be cached)
        # task -> vehicle -> (time, is_claim)
        self._events: dict[int, dict[int, tuple[int, bool]]] = {}
        # vehicle -> task -> claim time, for claims after the initial plan (an index of
        # `_events`: a vehicle's status reports its claims every few seconds)
        self._explicit: dict[int, dict[int, int]] = {}
        # vehicle -> spots whose newest record of it is a claim (what it may hold)
        self._claimed: dict[int, set[int]] = {}
        self._ranks: dict[int, int] = {}  # spot -> its place in `_events` (order of claims)
        for v, route in enumerate(base_routes):
            for task in route:
                self._events.setdefault(int(task), {})[v] = (0, True)
                self._claimed.setdefault(v, set()).add(int(task))

    def apply(self, v: int, t_s: int, tasks: Iterable[int], claim: bool) -> list[int]:
        """Record a claim (``claim``) or release by ``v`` at ``t_s``; returns the spots whose
        record changed."""
        changed = []
        for task in tasks:
            row = self._events.setdefault(int(task), {})
            old = row.get(v)
            new = (int(t_s), claim)
            # Newest wins; at equal times a release beats a claim (False < True).
            if old is None or (new[0], not new[1]) > (old[0], not old[1]):
                row[v] = new
                changed.append(int(task))
                mine = self._explicit.setdefault(v, {})
                if claim and new[0] > 0:
                    mine[int(task)] = new[0]
                else:
                    mine.pop(int(task), None)
                if claim:
                    self._claimed.setdefault(v, set()).add(int(task))
                else:
                    self._claimed.get(v, set()).discard(int(task))
        if changed:
            self.version += 1
        return changed

    def holder(self, task: int, alive: Alive) -> int | None:
        best: tuple[int, int] | None = None
        for v, (t, is_claim) in self._events.get(task, {}).items():
            if is_claim and alive(v) and (best is None or (t, v) < best):
                best = (t, v)
        return None if best is None else best[1]

    def claim_time(self, task: int, v: int) -> int | None:
        rec = self._events.get(task, {}).get(v)
        return rec[0] if rec is not None and rec[1] else None

    def holders(self, alive: Alive) -> dict[int, int]:
        """task -> holder, for every held spot."""
        out = {}
        for task in self._events:
            h = self.holder(task, alive)
            if h is not None:
                out[task] = h
        return out

    def claimed_by(self, v: int) -> list[int]:
        """Spots ``v`` claims (its newest record of each is a claim): those it may hold, in
        the order `holders` lists spots (the order they were first claimed)."""
        rank = self._rank
        return sorted(self._claimed.get(v, ()), key=lambda t: rank[t])

    @property
    def _rank(self) -> dict[int, int]:
        if len(self._ranks) != len(self._events):
            self._ranks = {t: i for i, t in enumerate(self._events)}
        return self._ranks

    def explicit_claims(self, v: int) -> dict[int, int]:
        """Spots ``v`` claimed after the initial plan: task -> claim time."""
        return dict(self._explicit.get(v, {}))

    def records(self) -> list[tuple[int, int, int, bool]]:
        """(task, vehicle, time, is_claim) of every non-initial record (for the journal)."""
        return [(task, v, t, c) for task, row in self._events.items()
                for v, (t, c) in row.items() if t > 0 or not c]
