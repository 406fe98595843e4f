"""`cotsfleet compare`: a scenario planned by every mode, summarised like the paper's Table I
(the paper's scenario by default)."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from cotsfleet.commands.checks import require_spots
from cotsfleet.errors import UsageError
from cotsfleet.io import read_scenario
from cotsfleet.reporting.progress import Progress
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.model.cost import CostWeights, RouteModel
from hfc_core.model.plan import vehicle_figures
from hfc_core.model.problem import Problem
from hfc_core.result import SolveResult
from hfc_core.solve import engine, solve
from reef_sim.scenarios.field import paper_preset_doc

HELP = ("compare the planners: NCM1, NCM2, CM, GA (and best) on the paper's scenario or "
        "yours: a Table I analog")

FAITHFUL_MODES = ("hfc-ncm1", "hfc-ncm2", "hfc-cm", "ga")
ITERATIONS = {"hfc-ncm1": 150, "hfc-ncm2": 150, "hfc-cm": 150, "ga": 200}
# The paper's Table I (and section IV-C for the GA): tasks completed out of 90.
PAPER_TASKS = {"hfc-ncm1": 90, "hfc-ncm2": 52, "hfc-cm": 61, "ga": 52}
TABLE_HEADER = ["mode", "vehicle", "cost (eq. 9)", "operation s", "T_diff s", "tasks",
                "violation s"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--seed", type=int, default=0, help="scenario and planner seed (default 0)")
    parser.add_argument("--scenario", type=Path, metavar="SCENARIO.json|TOP.txt",
                        help="plan this scenario instead of the paper's (drawn with --seed)")
    parser.add_argument("--quick", action="store_true", help="a few iterations only (smoke run)")
    parser.add_argument("--best-time-limit", type=float, default=5.0, metavar="S",
                        help="time for the best mode (default 5 s)")


def available_modes() -> list[str]:
    """The faithful modes, plus `best` when it is installed."""
    modes = list(FAITHFUL_MODES)
    try:
        engine("best")
        modes.append("best")
    except (ImportError, AttributeError):
        pass
    return modes


def run_modes(problem: Problem, modes: list[str], seed: int, *, quick: bool = False,
              best_time_limit_s: float = 5.0, progress: Progress | None = None
              ) -> dict[str, SolveResult]:
    """Every mode's plan; ``progress`` hears of each mode as it starts and finishes."""
    results = {}
    for mode in modes:
        if mode == "best":
            budget: dict[str, Any] = {"time_limit_s": 1.0 if quick else best_time_limit_s}
        else:
            budget = {"max_iterations": 20 if quick else ITERATIONS[mode]}
        if progress is not None:
            progress.start(mode)
        result = results[mode] = solve(problem, mode, seed=seed, **budget)
        if progress is not None:
            planned = sum(len(r) for r in result.plan.routes)
            progress.done(mode, f"{planned}/{problem.n_tasks} spots in {result.elapsed_s:.1f} s")
    return results


def table_rows(problem: Problem, results: dict[str, SolveResult]) -> list[list[Any]]:
    """Table I's columns per vehicle and in total, formatted. Every mode's plan is costed with
    the same eq. (9) weights, so costs compare across modes."""
    model = RouteModel(problem)
    weights = CostWeights().scaled_to(problem)
    rows: list[list[Any]] = []
    for mode, result in results.items():
        figs = vehicle_figures(problem, result.plan)
        costs = model.costs([list(r) for r in result.plan.routes], weights)
        for f, cost in zip(figs, costs):
            rows.append([mode, f.id, f"{cost:.0f}", f"{f.mission_time_s:.1f}",
                         f"{f.t_diff_s:+.1f}", f.tasks, f"{f.violation_s:.1f}"])
        rows.append([mode, "total", f"{costs.sum():.0f}",
                     f"{sum(f.mission_time_s for f in figs):.1f}",
                     f"{sum(f.t_diff_s for f in figs):+.1f}",
                     f"{sum(f.tasks for f in figs)}/{problem.n_tasks}",
                     f"{sum(f.violation_s for f in figs):.1f}"])
    return rows


def format_text(header: list[str], rows: list[list[Any]]) -> str:
    cells = [header, *[[str(c) for c in row] for row in rows]]
    widths = [max(len(r[i]) for r in cells) for i in range(len(header))]
    lines = ["  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    limit = args.best_time_limit
    if not (math.isfinite(limit) and limit > 0):
        raise UsageError(f"--best-time-limit must be a positive number of seconds, got {limit}")
    if args.scenario is not None:
        problem, _ = read_scenario(args.scenario)
        require_spots(problem, args.scenario)
        print(f"{problem.name}: {problem.n_tasks} COTS spots, {problem.n_vehicles} AUVs")
    else:
        problem = problem_from_dict(paper_preset_doc(args.seed))
        print(f"Paper scenario (seed {args.seed}): {problem.n_tasks} COTS spots, "
              f"{problem.n_vehicles} AUVs, 3600 s battery, 1 m/s, 90 s per injection",
              flush=True)
    modes = available_modes()
    with Progress(len(modes), "compare", "mode") as progress:
        results = run_modes(problem, modes, args.seed, quick=args.quick,
                            best_time_limit_s=limit, progress=progress)
    print(format_text(TABLE_HEADER, table_rows(problem, results)))
    if args.scenario is None:
        paper = ", ".join(f"{m} {n}/90" for m, n in PAPER_TASKS.items())
        print(f"paper (Table I, section IV-C): {paper}")
    return 0
