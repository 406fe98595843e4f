"""What every run of a sweep shares, small enough to ship to a worker on another machine.

The parent reads the files (scenario, agent config) and checks the faults once, with the same
`mission_args` a single `cotsfleet sim` uses; a worker never opens a path of the machine that
started the sweep. Each worker then builds its seed's mission with `build_mission`, the same
steps as `mission_args(args, seed=...)` (tests/cotsfleet/test_sweep.py holds them equal).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping

if TYPE_CHECKING:
    from cotsfleet.commands.mission_args import MissionArgs
    from cotsfleet.mission.faults import Fault
    from fleet_agent.config import AgentConfig


@dataclass(frozen=True)
class SweepSpec:
    """A sweep's missions but for the seed.

    ``scenario`` is the document of ``--scenario`` (the same for every seed), or None for the
    paper preset, drawn anew for each seed with ``vehicles`` AUVs (None: the paper's three).
    """

    scenario: Mapping[str, Any] | None
    vehicles: int | None
    loss: float
    config: "AgentConfig"
    faults: tuple["Fault", ...]

    @classmethod
    def from_args(cls, args: argparse.Namespace) -> "SweepSpec":
        """The spec of ``cotsfleet sim`` arguments; raises `UsageError`/`ScenarioError` as a
        single run would (files read, faults checked against the first seed's mission)."""
        from cotsfleet.commands.mission_args import mission_args

        first = mission_args(args)
        return cls(scenario=first.scenario if args.scenario is not None else None,
                   vehicles=args.vehicles, loss=first.loss, config=first.config,
                   faults=first.faults)


def build_mission(spec: SweepSpec, seed: int) -> "MissionArgs":
    """The mission of ``seed``: what ``mission_args(args, seed=seed)`` gives for the arguments
    the spec was made from. Raises `FaultError` if a fault cannot happen in this seed's
    mission (checked per seed: a preset's fleet is the same for every seed, a file's too,
    but the check is cheap and a worker trusts nothing)."""
    from cotsfleet.commands.mission_args import MissionArgs, scenario_doc
    from cotsfleet.mission.faults import check_schedule
    from cotsfleet.mission.runner import horizon_of
    from hfc_core.formats.scenario import problem_from_dict
    from reef_sim.truth import reef_from_doc

    doc = dict(spec.scenario) if spec.scenario is not None else scenario_doc(
        None, spec.vehicles, seed)
    problem = problem_from_dict(doc)
    check_schedule(spec.faults, [v.id for v in problem.vehicles], horizon_of(problem))
    return MissionArgs(problem, doc, seed, spec.config, spec.faults, spec.loss,
                       reef_from_doc(doc, problem))
