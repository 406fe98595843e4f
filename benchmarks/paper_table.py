"""The paper's Table I analog: NCM1, NCM2, CM and the GA on the `--paper` preset.

Per vehicle and in total: eq. (9) cost, operation time, T_diff, spots treated, violation; then
the convergence of the best individual (the paper's Fig. 7-8) and CM under the three
clusterings of Fig. 4. Run: ``python -m benchmarks.paper_table [--seed N] [--quick]``.
"""

from __future__ import annotations

import argparse
import statistics
import time

from benchmarks.results import markdown_table, write_section
from cotsfleet.commands.compare import (
    FAITHFUL_MODES, PAPER_TASKS, TABLE_HEADER, format_text, run_modes, table_rows,
)
from reef_sim.scenarios.field import paper_preset_doc
from hfc_core.model.plan import vehicle_figures
from hfc_core.model.problem import Problem
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.result import SolveResult
from hfc_core.solve import solve

CHECKPOINTS = (1, 10, 25, 50, 100, 150)


def convergence_rows(results: dict[str, SolveResult]) -> list[list[object]]:
    """Total cost of the best individual at a few iterations, and when its violation ended."""
    rows = []
    for mode, result in results.items():
        by_iteration = {h.iteration: h for h in result.history}
        costs = [round(sum(by_iteration[i].cost)) if i in by_iteration else "" for i in CHECKPOINTS]
        zero = next((h.iteration for h in result.history if max(h.violation_s) == 0.0), None)
        rows.append([mode, *costs, "never" if zero is None else zero])
    return rows


def clustering_rows(problem: Problem, seeds: range, iterations: int) -> list[list[object]]:
    """CM with each clustering of Fig. 4: spots treated over several planner seeds."""
    rows = []
    for clustering in ("kmeans", "fcm-max", "fcm-roulette"):
        tasks = []
        for seed in seeds:
            plan = solve(problem, "hfc-cm", seed=seed, max_iterations=iterations,
                         clustering=clustering).plan
            tasks.append(sum(f.tasks for f in vehicle_figures(problem, plan)))
        rows.append([clustering, statistics.median(tasks), min(tasks), max(tasks)])
    return rows


def main(seed: int = 0, quick: bool = False) -> str:
    problem = problem_from_dict(paper_preset_doc(seed))
    started = time.perf_counter()
    results = run_modes(problem, list(FAITHFUL_MODES), seed, quick=quick)
    elapsed = {m: r.elapsed_s for m, r in results.items()}
    rows = table_rows(problem, results)
    print(format_text(TABLE_HEADER, rows))
    conv_header = ["mode", *[f"cost @ it {i}" for i in CHECKPOINTS], "violation 0 from it"]
    conv = convergence_rows(results)
    print(format_text(conv_header, conv))
    seeds = range(2) if quick else range(5)
    clus = clustering_rows(problem, seeds, 20 if quick else 150)
    clus_header = ["CM clustering", "tasks median", "min", "max"]
    print(format_text(clus_header, clus))
    paper = ", ".join(f"{m} {n}/90" for m, n in PAPER_TASKS.items())
    body = "\n\n".join([
        f"`python -m benchmarks.paper_table` (seed {seed}{', quick' if quick else ''}): the "
        "`--paper` preset (90 spots, 3 AUVs, 3600 s, 1 m/s, 90 s injections, one small "
        "cluster), 150 iterations for HFC (population 100, nSc = 1), 200 generations for the GA. "
        "Costs are eq. (9) with the same weights for every mode (`hfc_core/model/cost.py`). "
        f"Paper: {paper}; total cost NCM1 2.273e5, NCM2 0.714e5, CM 0.386e5; "
        "total T_diff NCM2 +838 s, CM +125 s, GA +1103 s.",
        markdown_table(TABLE_HEADER, rows),
        "Planner time: " + ", ".join(f"{m} {s:.1f} s" for m, s in elapsed.items()) + ".",
        "Convergence of the best individual (the paper's Fig. 7-8: total cost, and the first "
        "iteration whose best plan has no violation):",
        markdown_table(conv_header, conv),
        f"CM with the clusterings of Fig. 4 (planner seeds {seeds.start}..{seeds.stop - 1}):",
        markdown_table(clus_header, clus),
    ])
    if not quick:  # a smoke run never overwrites the recorded figures
        write_section("paper_table",
                      "Paper Table I analog: HFC modes and GA on the paper preset", body)
    print(f"done in {time.perf_counter() - started:.0f} s")
    return body


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true", help="a smoke run of a few iterations")
    args = parser.parse_args()
    main(args.seed, args.quick)
