"""What every agent of a mission knows before the first message: the shared context."""

from __future__ import annotations

from dataclasses import dataclass

from fleet_agent.config import AgentConfig
from fleet_agent.plans import Planner
from fleet_agent.vehicle import PathFn, path_function
from fleet_agent.wire import Codec
from hfc_core.problem import Problem


@dataclass(frozen=True)
class Fleet:
    """The scenario, the wire codec under the fleet key, the planner, the land metric, the
    mission seed, and the initial fleet plan every agent computes alone (no messages)."""

    problem: Problem
    codec: Codec
    planner: Planner
    paths: PathFn
    seed: int
    base_routes: tuple[tuple[int, ...], ...]

    @staticmethod
    def build(problem: Problem, key: bytes, seed: int, config: AgentConfig,
              planner: Planner | None = None) -> "Fleet":
        planner = planner or Planner(problem, seed, config.plan_iterations,
                                     config.replan_iterations)
        return Fleet(problem, Codec.for_problem(problem, key), planner, path_function(problem),
                     seed, planner.initial_routes())
