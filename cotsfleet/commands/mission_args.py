"""What `cotsfleet run` and `cotsfleet sim` share: the mission's arguments (scenario, seed,
agent config, faults) and how they become a mission, whether the fleet runs as processes or
in one process."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

from cotsfleet.commands.checks import require_spots
from cotsfleet.errors import UsageError
from cotsfleet.mission.faults import Fault, FaultError, check_schedule, parse_faults
from cotsfleet.mission.runner import horizon_of
from fleet_agent.config import AgentConfig
from fleet_agent.wire import MAX_TASKS, MAX_VEHICLES
from fleet_bus.telemetry import Event
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.model.errors import ScenarioError
from hfc_core.model.problem import Problem
from reef_sim.truth import Reef, reef_from_doc

if TYPE_CHECKING:
    from cotsfleet.mission.report_model import MissionReport

# The acoustic wire's limit (one byte of sender index) is the only cap on a fleet's size.
MAX_PRESET_VEHICLES = MAX_VEHICLES


def add_mission_arguments(p: argparse.ArgumentParser, scenario_default: str) -> None:
    p.add_argument("--scenario", type=Path,
                   help=f"scenario JSON or TOP file (default: {scenario_default})")
    p.add_argument("--vehicles", type=int, help="fleet size of the default scenario (a "
                   "scenario file fixes its own: not with --scenario)")
    p.add_argument("--seed", type=int, default=0, help="mission seed (plans, channel)")
    p.add_argument("--loss", type=float, default=0.0, help="extra uniform link loss 0..1")
    p.add_argument("--config", type=Path, help="agent settings TOML (fleet_agent.config)")
    p.add_argument("--no-discovery", action="store_true",
                   help="dynamic scenarios (with a truth section): ignore sightings and do not "
                        "reallocate the time empty spots free; execute the plan and treat what "
                        "is found at predicted spots (the baseline)")
    faults = p.add_argument_group("faults (simulation times in seconds)")
    faults.add_argument("--abort", action="append", default=[], metavar="ID@S",
                        help="vehicle announces an abort at S (repeatable)")
    faults.add_argument("--kill", action="append", default=[], metavar="ID@S",
                        help="the vehicle's agent dies silently at S (repeatable)")
    faults.add_argument("--restart", action="append", default=[], metavar="ID@S",
                        help="start a killed agent again from its journal at S (repeatable)")
    faults.add_argument("--partition", action="append", default=[], metavar="ID@S+D",
                        help="cut the vehicle off from everyone from S for D seconds")
    faults.add_argument("--stall", action="append", default=[], metavar="ID@S+D",
                        help="starve the vehicle's host of CPU from S for D seconds (its agent "
                             "frozen half of every 8 s): a slow computer, not a silent vehicle")
    faults.add_argument("--loss-at", action="append", default=[], metavar="P@S",
                        help="extra uniform link loss P (0..1) from S on")
    faults.add_argument("--attack", action="append", default=[], metavar="KIND@S[*N]",
                        help="an intruder's modem sends N (default 10) forge|replay|garbage "
                             "frames from S; with --insider, the insider attacks N times "
                             "(all-cleared|claim-own|claim-all|abort-as|phantom|busy-hold; "
                             "docs/security.md)")
    faults.add_argument("--insider", metavar="ID",
                        help="the vehicle whose credentials leaked, for the insider attacks")
    faults.add_argument("--ctl", action="append", default=[], metavar="ORDER@S",
                        help="the operator's live order from the topside modem at S, words "
                             "joined by ':' (recall:auv2@1200, pause:all@600, resume:all@900, "
                             "drop-spot:17@300; unsigned:recall:auv2@1200 is an insider's "
                             "forgery): docs/operator.md")


@dataclass(frozen=True)
class MissionArgs:
    problem: Problem
    scenario: dict[str, Any]
    seed: int
    config: AgentConfig
    faults: tuple[Fault, ...]
    loss: float
    reef: Reef | None = None  # the scenario's hidden reef (None: the map is exact)


def scenario_doc(path: Path | None, vehicles: int | None, seed: int) -> dict[str, Any]:
    """The mission's scenario document: a file (JSON scenario or TOP instance), else the
    paper preset drawn with ``seed`` (``vehicles`` changes its fleet size; a file's fleet is
    the file's, so ``vehicles`` with a file is refused rather than silently ignored)."""
    if path is not None and vehicles is not None:
        raise UsageError(f"--vehicles {vehicles}: not with --scenario {path} (a scenario file "
                         f"names its own vehicles; make one with cotsfleet scenario "
                         f"--vehicles {vehicles})")
    if path is not None:
        from cotsfleet.io import read_scenario
        from hfc_core.formats.scenario import problem_to_dict

        problem, doc = read_scenario(path)  # validates, with a clear message
        return doc if doc is not None else problem_to_dict(problem)

    import numpy as np

    from reef_sim.scenarios.field import PAPER_PRESET, generate_doc, paper_preset_doc

    if vehicles is None or vehicles == PAPER_PRESET.n_vehicles:
        return paper_preset_doc(seed)
    if not 1 <= vehicles <= MAX_PRESET_VEHICLES:
        raise UsageError(f"--vehicles must be 1..{MAX_PRESET_VEHICLES}, got {vehicles}")
    doc = generate_doc(dataclasses.replace(PAPER_PRESET, n_vehicles=vehicles),
                       np.random.default_rng(seed))
    doc["name"] = f"paper-{vehicles}auv-seed{seed}"
    return doc


def check_wire_limits(problem: Problem) -> None:
    """A fleet the acoustic wire cannot carry stops here with a usage error (exit 2), not in
    every agent at start."""
    if problem.n_vehicles > MAX_VEHICLES:
        raise UsageError(f"the scenario has {problem.n_vehicles} vehicles; the acoustic wire "
                         f"carries at most {MAX_VEHICLES}")
    if problem.n_tasks > MAX_TASKS:
        raise UsageError(f"the scenario has {problem.n_tasks} spots; the acoustic wire "
                         f"carries at most {MAX_TASKS}")


def agent_config(path: Path | None) -> AgentConfig:
    """The agent settings file (schema-checked, a clean usage error if bad), or the defaults."""
    if path is None:
        return AgentConfig()
    from cotsfleet.io import read_agent_config

    return read_agent_config(path)


def config_sets(path: Path | None, name: str) -> bool:
    """Whether the agent config file sets ``name`` (else the default or a derived value
    stands: ``slot_s`` from the modem, `cotsfleet run --modem micromodem`)."""
    if path is None:
        return False
    from cotsfleet.io import read_toml

    doc = read_toml(path)
    return name in doc.get("agent", doc)


def mission_args(args: argparse.Namespace, seed: int | None = None) -> MissionArgs:
    """The mission the arguments describe (``seed`` overrides ``--seed``, for Monte Carlo);
    every fault is checked against the scenario before anything starts."""
    seed = args.seed if seed is None else seed
    if not 0.0 <= args.loss <= 1.0:
        raise UsageError(f"--loss must be in [0, 1], got {args.loss}")
    try:
        doc = scenario_doc(args.scenario, args.vehicles, seed)
        problem = problem_from_dict(doc)
        require_spots(problem, args.scenario or "the scenario")
        reef = reef_from_doc(doc, problem)
        check_wire_limits(problem)
        faults = parse_faults(aborts=args.abort, kills=args.kill, restarts=args.restart,
                              partitions=args.partition, losses=args.loss_at,
                              attacks=args.attack, stalls=args.stall, insider=args.insider,
                              ctls=args.ctl)
        check_schedule(faults, [v.id for v in problem.vehicles], horizon_of(problem))
    except FaultError as exc:
        raise UsageError(str(exc)) from None
    except ScenarioError:
        raise
    config = agent_config(args.config)
    if getattr(args, "no_discovery", False):
        config = dataclasses.replace(config, discovery=False)
        if reef is None:
            print("note: --no-discovery changes nothing here: the scenario has no truth "
                  "section, so its map is exact", file=sys.stderr)
    return MissionArgs(problem, doc, seed, config, tuple(faults), args.loss, reef)


def write_reports(report: "MissionReport", path: Path, events: Sequence[Event],
                  scenario: dict[str, Any] | None) -> None:
    """``report.json`` at ``path`` and, beside it, its Markdown and figures named after it
    (``r.json``: ``r.md``, ``r-*.png``); the summary, its notable events and its warnings
    on the terminal."""
    from cotsfleet.reporting import write_report_bundle
    from cotsfleet.reporting.markdown import warnings
    from cotsfleet.reporting.terminal import format_report

    print(format_report(report, list(events)))  # first: the terminal keeps it whatever
    for line in warnings(report):  # the disk does
        print(f"warning: {line}")
    try:  # a full disk: report.json first (the whole record), the figures after
        path.parent.mkdir(parents=True, exist_ok=True)  # checked by the command, or ours
        path.write_text(json.dumps(report.to_dict(), indent=2), encoding="utf-8")
    except OSError as exc:
        print(f"report: {path} could not be written ({exc}); the summary above is what was "
              "saved", file=sys.stderr)
        return
    try:
        bundle = write_report_bundle(report, path.parent, list(events), scenario,
                                     stem=path.stem)
    except OSError as exc:
        print(f"report: {path}; report.md and its figures could not be written ({exc})",
              file=sys.stderr)
        return
    print(f"report: {path} and {bundle[0]}")
