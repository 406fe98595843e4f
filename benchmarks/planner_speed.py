"""Speed of `best` and of the replanner: the three onboard targets.

1. `best` on the paper preset: priority collected against the time limit (0.25..8 s), over
   scenarios `paper_preset_doc(1000 + i)`; target: the 2 s plan is (nearly) converged.
2. A replan after one vehicle is lost: each scenario is planned, the fleet advances along the
   plan for 1200 s, one vehicle is lost and the survivors replan with the default budget;
   target: median well under 0.3 s (wall clock of `hfc_core.replan.replan`, warm interpreter).
3. 1000 spots x 10 vehicles (3 km square, 4 h batteries): `best` with a 30 s limit; target:
   within 30 s and under 1 GB peak resident memory (`resource.getrusage` in the worker).

Each part runs in its own process pinned to one core.

    python -m benchmarks.planner_speed            # full
    python -m benchmarks.planner_speed --quick    # fewer scenarios, shorter limits, no write
"""

from __future__ import annotations

import argparse
import json
import resource
import time

import numpy as np

from benchmarks.pinned import run_pinned
from benchmarks.results import markdown_table, write_section
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.model.check import check_routes
from hfc_core.model.problem import Problem
from hfc_core.replan import LiveVehicle, replan
from hfc_core.solve import solve
from reef_sim.scenarios.field import GeneratorParams, generate_doc, paper_preset_doc

LIMITS_S = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0)
LARGE = GeneratorParams(name="large", n_tasks=1000, n_vehicles=10, size_m=3000.0,
                        battery_s=14_400.0, n_centres=12, resolution_m=10.0)


def checked(problem: Problem, routes: list[list[int]]) -> float:
    ids = {problem.vehicles[v].id: [problem.tasks[u].id for u in r] for v, r in enumerate(routes)}
    errors = check_routes(problem, ids)
    if errors:
        raise RuntimeError(f"{problem.name}: infeasible plan: {errors[:2]}")
    return sum(problem.route_priority(r) for r in routes)


# --- workers (each in its own pinned process) ---------------------------------------------
def quality_worker(scenario: int, limit_s: float) -> dict:
    problem = problem_from_dict(paper_preset_doc(scenario))
    result = solve(problem, "best", time_limit_s=limit_s, seed=0)
    return {"priority": checked(problem, [list(r) for r in result.plan.routes]),
            "elapsed_s": result.elapsed_s, "iterations": result.iterations}


def advance(
    problem: Problem, routes: list[list[int]], t_s: float
) -> tuple[list[LiveVehicle], list[int]]:
    """Where each vehicle is after ``t_s`` seconds of its plan: at the last spot it finished
    (or its start), with the battery that leaves; and the spots cleared by then."""
    live, cleared = [], []
    for v, route in enumerate(routes):
        vehicle = problem.vehicles[v]
        at, pos, used, done = problem.start_node(v), vehicle.start, 0.0, 0
        for u in route:
            leg = problem.dist_m[at, u] / vehicle.speed_mps + problem.service_s[u]
            if used + leg > t_s:
                break
            used, at, pos, done = used + leg, u, problem.tasks[u].pos, done + 1
        cleared += [problem.tasks[u].id for u in route[:done]]
        live.append(LiveVehicle(vehicle.id, pos, vehicle.battery_s - used,
                                route=tuple(problem.tasks[u].id for u in route[done:])))
    return live, cleared


def replan_worker(scenarios: list[int]) -> dict:
    times, kept, gained = [], [], []
    for i, scenario in enumerate(scenarios):
        problem = problem_from_dict(paper_preset_doc(scenario))
        plan = solve(problem, "best", max_iterations=600, seed=i).plan
        live, cleared = advance(problem, [list(r) for r in plan.routes], 1200.0)
        lost = live.pop(i % len(live))
        started = time.perf_counter()
        routes = replan(problem, live, cleared=cleared, seed=i)
        times.append(time.perf_counter() - started)
        before = sum(problem.route_priority([problem.task_index[t] for t in v.route]) for v in live)
        after = sum(problem.route_priority([problem.task_index[t] for t in r])
                    for r in routes.values())
        taken = {t for r in routes.values() for t in r} & set(lost.route)
        gained.append(after - before)
        kept.append(len(taken) / max(1, len(lost.route)))
    return {"times_s": times, "gained": gained, "taken_share": kept}


def large_worker(limit_s: float) -> dict:
    started = time.perf_counter()
    problem = problem_from_dict(generate_doc(LARGE, np.random.default_rng(7)))
    built_s = time.perf_counter() - started
    result = solve(problem, "best", time_limit_s=limit_s, seed=0)
    priority = checked(problem, [list(r) for r in result.plan.routes])
    return {"priority": priority, "priority_total": float(problem.priority.sum()),
            "construction": result.extra["construction_priority"],
            "spots": sum(len(r) for r in result.plan.routes), "elapsed_s": result.elapsed_s,
            "iterations": result.iterations, "build_s": built_s,
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


# --- driver --------------------------------------------------------------------------------
def main(scenarios: int, limits: tuple[float, ...], large_limit_s: float, parallel: int,
         write: bool) -> None:
    seeds = [1000 + i for i in range(scenarios)]
    jobs = [["benchmarks.planner_speed", "--worker", "quality", str(s), str(t)]
            for t in limits for s in seeds]
    jobs.append(["benchmarks.planner_speed", "--worker", "replan", ",".join(map(str, seeds)), "0"])
    jobs.append(["benchmarks.planner_speed", "--worker", "large", "0", str(large_limit_s)])
    out = run_pinned(jobs, parallel)
    quality, rep, large = out[: len(limits) * len(seeds)], out[-2], out[-1]
    longest = np.array([q["priority"] for q in quality[-len(seeds):]])
    q_rows = []
    for j, t in enumerate(limits):
        block = quality[j * len(seeds): (j + 1) * len(seeds)]
        pr = np.array([q["priority"] for q in block])
        q_rows.append([f"{t:g}", f"{np.median(pr):.0f}", f"{np.median(pr / longest):.4f}",
                       f"{np.min(pr / longest):.4f}",
                       f"{np.median([q['iterations'] for q in block]):.0f}",
                       f"{np.median([q['elapsed_s'] for q in block]):.2f}"])
    times = np.array(rep["times_s"])
    r_rows = [[len(times), f"{np.median(times):.3f}", f"{np.percentile(times, 90):.3f}",
               f"{times.max():.3f}", f"{np.median(rep['gained']):+.0f}",
               f"{np.median(rep['taken_share']):.2f}"]]
    l_rows = [[f"{large['elapsed_s']:.1f}", f"{large['build_s']:.1f}", large["iterations"],
               f"{large['construction']:.0f}", f"{large['priority']:.0f}",
               f"{large['priority_total']:.0f}", large["spots"], f"{large['peak_rss_mb']:.0f}"]]
    heads = (
        ["limit s", "priority median", f"vs {limits[-1]:g} s: median", f"vs {limits[-1]:g} s: min",
         "iterations", "planner s"],
        ["replans", "median s", "p90 s", "max s", "survivors' priority gained", "lost spots taken"],
        ["planner s", "scenario build s", "iterations", "construction priority", "priority",
         "priority of all spots", "spots", "peak RSS MB"],
    )
    tables = [markdown_table(h, r) for h, r in zip(heads, (q_rows, r_rows, l_rows))]
    for table in tables:
        print(table)
    if write:
        body = (
            f"`python -m benchmarks.planner_speed`; every part in its own process pinned to one "
            f"core ({parallel} at a time).\n\n"
            f"**`best` on the paper preset** ({len(seeds)} scenarios `paper_preset_doc(1000 + i)`, "
            "seed 0; priority relative to the same scenario at the longest limit):\n\n"
            + tables[0]
            + f"\n\n**Replan after a loss** ({len(seeds)} scenarios: `best` plan of 600 "
            "iterations, "
            "the fleet advances 1200 s, vehicle i mod 3 is lost, the survivors call `replan` with "
            "its default budget; wall clock of the call):\n\n"
            + tables[1]
            + f"\n\n**1000 spots x 10 vehicles** (3 km square, 12 COTS centres, 4 h batteries, "
            f"{large_limit_s:g} s limit; peak RSS of the whole worker process):\n\n"
            + tables[2] + "\n"
        )
        write_section("planner_speed", "Planner speed: best, replan, 1000 spots", body)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", type=int, default=None, help="paper scenarios (30)")
    parser.add_argument("--jobs", type=int, default=1, help="workers at once, one core each")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--worker", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        kind, a, b = args.worker
        result = {"quality": lambda: quality_worker(int(a), float(b)),
                  "replan": lambda: replan_worker([int(s) for s in a.split(",")]),
                  "large": lambda: large_worker(float(b))}[kind]()
        print(json.dumps(result))
    else:
        quick = args.quick
        main(args.scenarios or (4 if quick else 30),
             (0.25, 0.5, 1.0, 2.0) if quick else LIMITS_S, 10.0 if quick else 30.0, args.jobs,
             write=not (quick or args.no_write))
