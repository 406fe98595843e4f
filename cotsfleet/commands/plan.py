"""`cotsfleet plan`: plan a scenario (JSON or TOP text) with one of the planner modes."""

from __future__ import annotations

import argparse
import json
import math
import textwrap
from pathlib import Path
from typing import Any

import numpy as np

from cotsfleet.commands.checks import output_file, require_spots
from cotsfleet.errors import UsageError
from cotsfleet.io import read_scenario
from hfc_core.model.check import check_routes
from hfc_core.model.plan import plan_to_dict, vehicle_figures
from hfc_core.model.problem import Problem
from hfc_core.result import SolveResult
from hfc_core.solve import BUDGET_FREE_MODES, MODES, engine, solve

HELP = "plan a scenario: which AUV treats which COTS spots, in what order"

# Budgets when no --time-limit/--iterations is given: the paper's 150 iterations for HFC,
# a little more for the GA (it settles after ~170 in the paper's Fig. 14), seconds for `best`.
DEFAULT_ITERATIONS = {"hfc-ncm1": 150, "hfc-ncm2": 150, "hfc-cm": 150, "ga": 200}
DEFAULT_TIME_LIMIT_S = 5.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", metavar="SCENARIO.json|TOP.txt")
    parser.add_argument("--mode", default="best", choices=list(MODES),
                        help="planner (default: best)")
    parser.add_argument("--time-limit", type=float, metavar="S",
                        help=f"wall-clock budget (default: {DEFAULT_TIME_LIMIT_S:g} s for best, "
                             "else the mode's iteration budget)")
    parser.add_argument("--iterations", type=int, metavar="N",
                        help="iteration budget (default: 150 for HFC modes, 200 for ga)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--population", type=int, metavar="N", help="population size (HFC, ga)")
    parser.add_argument("--clustering", choices=["kmeans", "fcm-max", "fcm-roulette"],
                        help="HFC clustering (default kmeans)")
    parser.add_argument("--vehicles", metavar="ID[,ID...]",
                        help="plan for these vehicles only (e.g. the ones still at sea)")
    parser.add_argument("--json", metavar="OUT", help="write the plan as JSON")
    parser.add_argument("--geojson", metavar="OUT",
                        help="write the routes, spots and stations as GeoJSON in "
                             "longitude/latitude (scenarios made with --from-geojson)")
    parser.add_argument("--rrd", metavar="FILE", help="write a Rerun recording of the plan")


def budget(args: argparse.Namespace) -> dict[str, Any]:
    """``time_limit_s``/``max_iterations`` for `solve`, from the flags or the mode's default."""
    if args.time_limit is not None and not (math.isfinite(args.time_limit) and args.time_limit > 0):
        raise UsageError(f"--time-limit must be a positive number of seconds, "
                         f"got {args.time_limit}")
    if args.iterations is not None and args.iterations < 0:
        raise UsageError(f"--iterations must be >= 0, got {args.iterations}")
    if args.time_limit is None and args.iterations is None:
        if args.mode in DEFAULT_ITERATIONS:
            return {"time_limit_s": None, "max_iterations": DEFAULT_ITERATIONS[args.mode]}
        return {"time_limit_s": DEFAULT_TIME_LIMIT_S, "max_iterations": None}
    return {"time_limit_s": args.time_limit, "max_iterations": args.iterations}


def engine_params(args: argparse.Namespace) -> dict[str, Any]:
    params: dict[str, Any] = {}
    if args.population is not None:
        if args.population < 2:
            raise UsageError(f"--population must be >= 2, got {args.population}")
        params["population"] = args.population
    if args.clustering is not None:
        if not args.mode.startswith("hfc-"):
            raise UsageError("--clustering applies to the hfc-* modes only")
        params["clustering"] = args.clustering
    return params


def select_vehicles(problem: Problem, spec: str | None) -> Problem:
    """``problem`` restricted to the vehicles named in ``spec`` (comma-separated ids)."""
    if spec is None:
        return problem
    wanted = [s.strip() for s in spec.split(",") if s.strip()]
    unknown = [v for v in wanted if v not in problem.vehicle_index]
    if unknown or not wanted:
        known = ", ".join(problem.vehicle_index)
        raise UsageError(f"--vehicles: unknown vehicle id(s) {unknown or spec!r}; known: {known}")
    if len(set(wanted)) != len(wanted):
        raise UsageError(f"--vehicles: a vehicle is named twice in {spec!r}")
    vehicles = [problem.vehicles[problem.vehicle_index[v]] for v in wanted]
    return Problem.build(problem.name, vehicles, problem.tasks,
                         [p.tolist() for p in problem.forbidden])


def fits_alone(problem: Problem) -> int:
    """How many spots some vehicle could treat on its own (start, spot, rendezvous within its
    battery): the most any plan could hope for, and 0 when the batteries are too short."""
    fits = np.zeros(problem.n_tasks, dtype=bool)
    tasks = np.arange(problem.n_tasks)
    for v, vehicle in enumerate(problem.vehicles):
        there = problem.dist_m[problem.start_node(v), tasks]
        back = problem.dist_m[tasks, problem.end_node(v)]
        fits |= (there + back) / vehicle.speed_mps + problem.service_s <= vehicle.battery_s
    return int(fits.sum())


# Why a faithful mode can end with few spots, in a sentence (paper sections III-IV).
WHY_FEW = {
    "ga": "Mode ga splits the spots by k-means, then drops the far end of each route until it "
          "fits (paper IV-C), so spots a joint plan could take are lost.",
    "hfc-ncm2": "Mode hfc-ncm2 screens each k-means cluster until its route fits, and no "
                "vehicle helps another.",
    "hfc-cm": "Mode hfc-cm screens each k-means cluster until its route fits; cooperation only "
              "adds spots near a vehicle's route.",
}


def _note(text: str) -> str:
    return textwrap.fill(text, 92, initial_indent="note: ", subsequent_indent="      ")


def outcome_note(problem: Problem, result: SolveResult, tasks: int) -> str | None:
    """A few lines saying what a poor result means, or None when there is nothing to say."""
    if result.mode in BUDGET_FREE_MODES or problem.n_tasks == 0:
        return None
    alone = fits_alone(problem)
    if alone == 0:
        return _note("no spot can be treated within any battery, even alone between start and "
                     "rendezvous: the batteries are too short for this field.")
    if tasks >= alone // 2:
        return None
    why = WHY_FEW.get(result.mode, f"Mode {result.mode} stopped at its budget.")
    return (_note(f"{tasks} of {problem.n_tasks} spots planned; {alone} fit a battery on their "
                  f"own (though not all together). {why}")
            + "\n      for the most priority: --mode best (or more --iterations)")


def summary(problem: Problem, result: SolveResult) -> str:
    """The readable report: per vehicle tasks, priority, mission time, T_diff, violation."""
    figs = vehicle_figures(problem, result.plan)
    lines = [
        f"{problem.name}: mode {result.mode}, seed {result.seed}, {result.iterations} iterations "
        f"in {result.elapsed_s:.2f} s",
        f"{'vehicle':<10}{'tasks':>6}{'priority':>10}{'mission s':>11}{'T_diff s':>10}"
        f"{'violation s':>13}",
    ]
    for f in figs:
        lines.append(f"{f.id:<10}{f.tasks:>6}{f.priority:>10.1f}{f.mission_time_s:>11.1f}"
                     f"{f.t_diff_s:>+10.1f}{f.violation_s:>13.1f}")
    lines.append(
        f"{'total':<10}{sum(f.tasks for f in figs):>6}{sum(f.priority for f in figs):>10.1f}"
        f"{sum(f.mission_time_s for f in figs):>11.1f}{sum(f.t_diff_s for f in figs):>+10.1f}"
        f"{sum(f.violation_s for f in figs):>13.1f}"
    )
    tasks, priority = sum(f.tasks for f in figs), sum(f.priority for f in figs)
    total = float(problem.priority.sum())
    share = f" ({100.0 * priority / total:.0f} % of the scenario's total priority)" if total else ""
    lines.append(f"tasks completed {tasks}/{problem.n_tasks}, priority {priority:.1f}/{total:.1f}"
                 f"{share}")
    if result.mode in BUDGET_FREE_MODES:
        lines.append("note: NCM1 ignores the battery by design (paper IV-A); routes may overrun it")
    note = outcome_note(problem, result, tasks)
    if note:
        lines.append(note)
    return "\n".join(lines)


def plan_document(problem: Problem, result: SolveResult) -> dict[str, Any]:
    """`plan_to_dict` plus how the plan was made and its convergence history (Fig. 7-8)."""
    doc = plan_to_dict(problem, result.plan)
    doc.update({
        "scenario": problem.name,
        "mode": result.mode,
        "seed": result.seed,
        "iterations": result.iterations,
        "elapsed_s": result.elapsed_s,
        "history": [
            {"iteration": h.iteration, "elapsed_s": h.elapsed_s, "cost": list(h.cost),
             "violation_s": list(h.violation_s), "t_diff_s": list(h.t_diff_s),
             "priority": h.priority}
            for h in result.history
        ],
    })
    return doc


def write_json(path: str, doc: Any) -> None:
    try:
        Path(path).write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    except OSError as exc:
        raise UsageError(f"cannot write {path}: {exc}") from None


def run(args: argparse.Namespace) -> int:
    for path, flag in ((args.json, "--json"), (args.geojson, "--geojson"), (args.rrd, "--rrd")):
        output_file(path, flag)  # fail before planning, not after
    try:
        problem, doc = read_scenario(args.scenario)
        require_spots(problem, args.scenario)
        problem = select_vehicles(problem, args.vehicles)
    except NotImplementedError as exc:  # e.g. land polygons before the land metric exists
        raise UsageError(f"{args.scenario}: {exc}") from None
    frame = None
    if args.geojson:
        from cotsfleet.geo import LocalFrame

        frame = LocalFrame.of_scenario(doc)
        if frame is None:
            raise UsageError(f"--geojson: {args.scenario} has no 'geo' section (made by "
                             "'cotsfleet scenario --from-geojson'): it is not on the globe")
    stop = budget(args)
    params = engine_params(args)
    try:
        engine(args.mode)
    except (ImportError, AttributeError) as exc:
        raise UsageError(f"mode {args.mode!r} is not available in this build: {exc}") from None
    result = solve(problem, args.mode, seed=args.seed, **stop, **params)
    print(summary(problem, result))
    routes = {problem.vehicles[v].id: [problem.tasks[t].id for t in r]
              for v, r in enumerate(result.plan.routes)}
    errors = check_routes(problem, routes, enforce_budget=args.mode not in BUDGET_FREE_MODES)
    if errors:  # the planner broke its contract: say so loudly, never hand out the plan
        print(f"internal error: the independent checker rejects this plan: {errors}")
        return 1
    if args.json:
        write_json(args.json, plan_document(problem, result))
    if frame is not None:
        from cotsfleet.geo.export import plan_geojson

        write_json(args.geojson, plan_geojson(problem, result.plan.routes, frame, doc))
    if args.rrd:
        from ground_station.plan_recording import record_plan

        try:
            record_plan(problem, result, args.rrd, scenario=doc)
        except OSError as exc:
            raise UsageError(f"cannot write {args.rrd}: {exc}") from None
    return 0
