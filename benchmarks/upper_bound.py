"""How far could any planner still improve? A certified upper bound (`benchmarks.bound`) on the
paper preset and its Monte Carlo scenarios, beside `best`'s plan.

Scenario i of the Monte Carlo is `paper_preset_doc(base + i)` (as in `paper_best`), the single
preset is `paper_preset_doc(0)`. Each scenario is first planned by `best` (``--plan-s`` seconds,
seed 0 for the preset and i for run i); that plan seeds the bound's LP, and the bound then
gets ``--time-limit`` seconds (its own time is what the table reports). The per-scenario
figures go to ``benchmarks/bounds_paper.json``.

    python -m benchmarks.upper_bound                       # preset + 30 runs, 60 s each
    python -m benchmarks.upper_bound --runs 4 --time-limit 30 --no-write
    python -m benchmarks.upper_bound --quick                # 2 runs, 5 s each, writes nothing

It writes its section of RESULTS.md, with the ceiling those bounds put on any planner's ratio
to PyVRP run by run (`paper_best.bound_ceiling`, from `benchmarks/paper_best_runs.json`).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from benchmarks.bound import upper_bound
from benchmarks.paper_best import RUNS_OUT, bound_ceiling
from benchmarks.results import markdown_table, write_section
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.solve import solve
from reef_sim.scenarios.field import paper_preset_doc

OUT = Path(__file__).with_name("bounds_paper.json")


def one(scenario: int, seed: int, time_limit_s: float, plan_s: float) -> dict:
    problem = problem_from_dict(paper_preset_doc(scenario))
    routes = [list(r) for r in solve(problem, "best", seed=seed,
                                     time_limit_s=plan_s).plan.routes]
    plan = sum(problem.route_priority(r) for r in routes)
    bound = upper_bound(problem, time_limit_s=time_limit_s, plans=[routes])
    return {"scenario": scenario, "bound": bound.upper, "lp": bound.lp, "plan": plan,
            "gap_pct": 100.0 * (bound.upper - plan) / plan, "columns": bound.columns,
            "iterations": bound.iterations, "converged": bound.converged,
            "seconds": bound.seconds}


def main(runs: int, base: int, time_limit_s: float, plan_s: float, preset: bool,
         write: bool) -> None:
    scenarios = ([0] if preset else []) + [base + i for i in range(runs)]
    rows, results = [], []
    head = ["scenario", "bound", "LP", "best plan", "gap %", "columns", "iterations",
            "converged", "s"]
    for s in scenarios:
        r = one(s, 0 if s == 0 and preset else s - base, time_limit_s, plan_s)
        results.append(r)
        row = [s, f"{r['bound']:.2f}", f"{r['lp']:.2f}", f"{r['plan']:.2f}",
               f"{r['gap_pct']:.2f}", r["columns"], r["iterations"], r["converged"],
               f"{r['seconds']:.1f}"]
        rows.append(row)
        print(" | ".join(str(c) for c in row), flush=True)
    print()
    print(markdown_table(head, rows))
    mc = split(results, preset)[1]
    if mc:
        gap = np.array([r["gap_pct"] for r in mc])
        secs = np.array([r["seconds"] for r in mc])
        print(f"\nMonte Carlo ({len(mc)} scenarios): bound above best's {plan_s:g} s plan by "
              f"median {np.median(gap):.2f} %, max {gap.max():.2f} %; "
              f"{sum(r['converged'] for r in mc)}/{len(mc)} converged; "
              f"bound time median {np.median(secs):.0f} s, max {secs.max():.0f} s.")
    if write:
        doc = {str(r["scenario"]): {k: v for k, v in r.items() if k != "scenario"}
               for r in results}
        OUT.write_text(json.dumps(doc, indent=1) + "\n")
        print(f"wrote {OUT}")
        write_section("upper_bound", "Upper bound on the paper scenarios",
                      section(results, preset, base, runs, time_limit_s, plan_s))


def split(results: list[dict], preset: bool) -> tuple[list[dict], list[dict]]:
    """(the preset's result, if it ran; the Monte Carlo scenarios' results)."""
    alone = [r for r in results if preset and r["scenario"] == 0]
    return alone, [r for r in results if r not in alone]


def section(results: list[dict], preset: bool, base: int, runs: int, time_limit_s: float,
            plan_s: float) -> str:
    """The RESULTS.md body: the bounds beside `best`'s plans, and what they allow any planner
    against PyVRP's runs of `paper_best`."""
    converged = sum(r["converged"] for r in results)
    alone, mc = split(results, preset)
    rows = []
    for label, group in (("paper preset (`paper_preset_doc(0)`)", alone),
                         (f"Monte Carlo, {runs} (`paper_preset_doc({base} + i)`)", mc)):
        if not group:
            continue
        gap = np.array([r["gap_pct"] for r in group])
        bound = float(np.median([r["bound"] for r in group]))
        gaps = (f"{gap[0]:.2f} % (plan {group[0]['plan']:.1f})" if len(group) == 1
                else f"{np.median(gap):.2f} % / {gap.max():.2f} %")
        secs = float(np.median([r["seconds"] for r in group]))
        rows.append([label, f"{bound:.1f}", gaps, f"{secs:.0f}"])
    text = (f"`python -m benchmarks.upper_bound` (`benchmarks.bound`): an admissible upper "
            f"bound on the priority any plan can collect, by column generation on the "
            f"set-packing LP with ng-route pricing; every figure is a Lagrangian certificate, "
            f"valid even when the column generation stops early ({time_limit_s:g} s per "
            f"scenario, {converged} of {len(results)} converged). Per-scenario figures in "
            f"`benchmarks/{OUT.name}`.\n\n")
    text += markdown_table(["scenarios", "bound median",
                            f"gap of the bound over `best`'s {plan_s:g} s plan: median / max",
                            "s per scenario"], rows)
    if mc:
        worst = max(mc, key=lambda r: r["gap_pct"])
        text += (f"\n\nSo no planner can collect more than "
                 f"{np.median([r['gap_pct'] for r in mc]):.2f} % (median; "
                 f"{worst['gap_pct']:.2f} % at worst, scenario {worst['scenario']}) above "
                 f"`best`'s {plan_s:g} s plans.")
    if RUNS_OUT.exists():
        ceiling = bound_ceiling(json.loads(RUNS_OUT.read_text()),
                                [str(r["scenario"]) for r in mc])
        if ceiling:
            text += (f" PyVRP's 2 s plans of the latest `paper_best` (`{RUNS_OUT.name}`) "
                     "against these bounds: " + ceiling)
    return text


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--base", type=int, default=1000, help="scenario seeds base + i")
    parser.add_argument("--time-limit", type=float, default=60.0, help="bound seconds")
    parser.add_argument("--plan-s", type=float, default=2.0, help="best's seconds")
    parser.add_argument("--no-preset", action="store_true", help="Monte Carlo runs only")
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--quick", action="store_true", help="2 runs, 5 s each, writes nothing")
    args = parser.parse_args()
    if args.quick:
        args.runs, args.time_limit, args.no_write = 2, 5.0, True
    main(args.runs, args.base, args.time_limit, args.plan_s, not args.no_preset,
         not args.no_write)
