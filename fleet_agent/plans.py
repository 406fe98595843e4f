"""The agent's planner: `hfc_core` behind task indices, with iteration budgets only.

Everything the fleet must agree on is computed with an iteration budget and a shared seed,
never a time limit, so every agent gets the same answer from the same inputs. Results are
memoised on their inputs: the in-process simulation runs many agents on one interpreter, and
a pure function computed once serves them all (the multi-process fleet computes it in each
process, as the vehicles would).
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Iterator, Mapping, Sequence

from hfc_core.model.problem import Problem

if TYPE_CHECKING:
    from fleet_agent.config import AgentConfig

Point3 = tuple[float, float, float]

# Told when this process starts and ends a replanner run (True, then False). The deployment
# sets it (`fleet_agent.node`: one agent per process) so that the launcher holds the shared
# clock while an agent plans: a planner burst of b wall seconds would otherwise be b x warp
# mission seconds of silence, enough for a false alarm at high warp (docs/fleet_agent.md).
# The in-process simulation leaves it unset: there planning takes no mission time anyway.
_on_planning: Callable[[bool], None] | None = None


def set_planning_hook(hook: Callable[[bool], None] | None) -> None:
    """Call ``hook(True)`` before and ``hook(False)`` after every replanner run."""
    global _on_planning
    _on_planning = hook


@contextmanager
def _planning() -> Iterator[None]:
    hook = _on_planning
    if hook is not None:
        hook(True)
    try:
        yield
    finally:
        if hook is not None:
            hook(False)


@dataclass(frozen=True)
class Live:
    """A vehicle as the replanner sees it (task indices)."""

    index: int
    pos: Point3
    battery_s: float
    route: tuple[int, ...] = ()
    locked: tuple[int, ...] = ()  # spots that must stay first (being injected)


class Planner:
    """Plans for the battery less ``reserve_s`` (the agent's `battery_reserve_s`): every route
    it returns reaches the rendezvous with that margin, so fitting a fresh plan to the battery
    (`fleet_agent.routing.fit_route`) drops nothing."""

    def __init__(self, problem: Problem, seed: int, plan_iterations: int,
                 replan_iterations: int, reserve_s: float = 0.0, polish: bool = True) -> None:
        self.problem = problem
        self.reserve_s = float(reserve_s)
        self.polish = polish  # polish the initial plan (`AgentConfig.plan_polish`)
        self.seed = seed
        self.plan_iterations = plan_iterations
        self.replan_iterations = replan_iterations
        self._initial: tuple[tuple[int, ...], ...] | None = None
        self._memo: dict[tuple, dict[int, list[int]]] = {}
        self.calls = 0  # replanner runs (not memo hits), for benchmarks

    @classmethod
    def from_config(cls, problem: Problem, seed: int, config: "AgentConfig") -> "Planner":
        """The planner an agent with ``config`` uses (its budgets, reserve and polishing)."""
        return cls(problem, seed, config.plan_iterations, config.replan_iterations,
                   config.battery_reserve_s, config.plan_polish)

    def initial_routes(self) -> tuple[tuple[int, ...], ...]:
        """The fleet plan every agent computes alone at start: solve("best") on the shared
        scenario with the shared seed and an iteration budget."""
        if self._initial is None:
            from hfc_core.solve import solve

            result = solve(self.problem.with_reserve(self.reserve_s), "best",
                           max_iterations=self.plan_iterations, seed=self.seed,
                           **({} if self.polish else {"polish": None}))
            self._initial = tuple(tuple(int(t) for t in r) for r in result.plan.routes)
        return self._initial

    def replan(self, vehicles: Sequence[Live], unavailable: frozenset[int],
               held: Mapping[int, int], seed: int) -> dict[int, list[int]]:
        """Routes (task indices) for ``vehicles`` over the spots not ``unavailable``; a spot in
        ``held`` goes to its holder only. Vehicles not listed are gone."""
        key = (tuple(vehicles), unavailable, tuple(sorted(held.items())), seed)
        hit = self._memo.get(key)
        if hit is not None:
            return {v: list(r) for v, r in hit.items()}
        from hfc_core.model.live import IndexedVehicle
        from hfc_core.replan import replan_indexed

        live = [IndexedVehicle(v.index, tuple(v.pos), max(0.0, v.battery_s - self.reserve_s),
                               route=v.route, locked=v.locked) for v in vehicles]
        with _planning():
            out = replan_indexed(self.problem, live, cleared=unavailable, held=held,
                                 max_iterations=self.replan_iterations, seed=seed)
        self.calls += 1
        if len(self._memo) > 256:
            self._memo.clear()
        self._memo[key] = out
        return {v: list(r) for v, r in out.items()}
