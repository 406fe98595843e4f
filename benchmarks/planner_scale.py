"""`best` against PyVRP on larger areas: 200 spots x 4 AUVs, 400 x 6, 1000 x 10, 10 s each.

Issue 14's check (d): the planner keeps at least PyVRP's priority at equal wall time on
scenarios of the large-area generator (`reef_sim.scenarios.area.generate_area_doc`, the one behind
`cotsfleet scenario --vehicles K --spots N --area-m A --battery-s B`): median ratio >= 1.00,
every ratio >= 0.98. Each solver run is a separate process pinned to one core (two at a time),
every plan checked by the exact-float checker (PyVRP's after its integer rounding, repaired if
needed and counted).

    python -m benchmarks.planner_scale            # 3 sizes x 3 scenario seeds, 10 s
    python -m benchmarks.planner_scale --quick    # 1 seed, 2 s, no write
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from benchmarks.pinned import run_pinned
from benchmarks.results import markdown_table, write_section
from benchmarks.top_bench import score, warm_up
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.model.problem import Problem
from reef_sim.scenarios.area import AreaParams, generate_area_doc

# (spots, vehicles, area side m, battery s): service alone (60-90 s a spot) exceeds the
# fleet's battery in each, so the planners must choose.
SIZES = [(200, 4, 1500.0, 3600.0), (400, 6, 2000.0, 5400.0), (1000, 10, 3000.0, 7200.0)]


def scenario(n: int, k: int, area: float, battery: float, seed: int) -> Problem:
    params = AreaParams(name=f"area{n}x{k}", n_tasks=n, n_vehicles=k, area_m=area,
                        battery_s=battery)
    return problem_from_dict(generate_area_doc(params, np.random.default_rng(seed)))


def worker(mode: str, size: int, seed: int, time_limit_s: float) -> None:
    problem = scenario(*SIZES[size], seed)
    warm_up(mode)
    started = time.perf_counter()
    if mode == "pyvrp":
        from benchmarks.reference_solvers import solve_pyvrp

        routes = solve_pyvrp(problem, time_limit_s, 0)
    else:
        from hfc_core.solve import solve

        routes = [list(r) for r in solve(problem, "best", time_limit_s=time_limit_s,
                                         seed=0).plan.routes]
    print(json.dumps({"routes": routes, "elapsed_s": time.perf_counter() - started}))


def main(seeds: int, time_limit_s: float, write: bool) -> None:
    jobs = [(mode, size, seed) for size in range(len(SIZES)) for seed in range(seeds)
            for mode in ("best", "pyvrp")]
    outputs = run_pinned([["benchmarks.planner_scale", "--worker", mode, str(size), str(seed),
                           "--time-limit", str(time_limit_s)] for mode, size, seed in jobs], 2)
    raw = dict(zip(jobs, outputs))
    rows, ratios = [], []
    for size, (n, k, area, battery) in enumerate(SIZES):
        for seed in range(seeds):
            problem = scenario(n, k, area, battery, seed)
            got = {m: score(problem, raw[(m, size, seed)]["routes"]) for m in ("best", "pyvrp")}
            ratio = got["best"][0] / got["pyvrp"][0] if got["pyvrp"][0] > 0 else float("inf")
            ratios.append(ratio)
            spots = {m: sum(len(r) for r in raw[(m, size, seed)]["routes"]) for m in got}
            rows.append([f"{n} x {k}", seed, f"{got['best'][0]:.0f}", f"{got['pyvrp'][0]:.0f}",
                         f"{ratio:.4f}", f"{spots['best']} / {spots['pyvrp']}",
                         f"{raw[('best', size, seed)]['elapsed_s']:.1f} / "
                         f"{raw[('pyvrp', size, seed)]['elapsed_s']:.1f}",
                         int(got["pyvrp"][1])])
    head = ["spots x AUVs", "seed", "best priority", "PyVRP priority", "ratio",
            "spots best / PyVRP", "wall s best / PyVRP", "PyVRP repaired"]
    med, worst = float(np.median(ratios)), float(min(ratios))
    verdict = (f"Median ratio best / PyVRP {med:.4f} (target >= 1.00), worst {worst:.4f} "
               f"(target >= 0.98): {'met' if med >= 1.0 and worst >= 0.98 else 'NOT met'}.")
    table = markdown_table(head, rows)
    print(table)
    print(verdict)
    if write:
        body = (f"`python -m benchmarks.planner_scale`: scenarios of the large-area generator "
                f"(`generate_area_doc`, areas 1.5-3 km, batteries 1-2 h, scenario seeds "
                f"0..{seeds - 1}), `best` and PyVRP {time_limit_s:g} s each, one pinned process "
                "per run (2 at a time), every plan checked with the exact-float checker.\n\n"
                + table + "\n\n" + verdict + "\n")
        write_section("planner_scale", "Planner at scale: best vs PyVRP on 200-1000 spots",
                      body)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--time-limit", type=float, default=10.0)
    parser.add_argument("--quick", action="store_true", help="1 seed, 2 s, no write")
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--worker", nargs=3, metavar=("MODE", "SIZE", "SEED"),
                        help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args.worker[0], int(args.worker[1]), int(args.worker[2]), args.time_limit)
    elif args.quick:
        main(1, 2.0, False)
    else:
        main(args.seeds, args.time_limit, not args.no_write)
