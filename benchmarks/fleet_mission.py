"""A 3-AUV one-hour mission (the paper preset): multi-process at warp 60 vs in-process.

``python -m benchmarks.fleet_mission [--quick] [--seed N] [--warp W]``

Multi-process: `cotsfleet run`'s launcher with router, relay and three agent processes (no
viewer), timed from the first process spawned to the report written (target <= 90 s wall on
2 cores). In-process: the same agents on the deterministic transport (target <= 5 s wall).
"""

from __future__ import annotations

import argparse
import time

from benchmarks.results import markdown_table, write_section
from cotsfleet.commands.mission_args import scenario_doc
from cotsfleet.mission.inprocess import simulate
from cotsfleet.mission.processes import ProcessBackend, ProcessOptions
from cotsfleet.mission.runner import run_mission
from fleet_agent.config import AgentConfig
from hfc_core.formats.scenario import problem_from_dict


def main(seed: int, warp: float, quick: bool) -> None:
    doc = scenario_doc(None, None, seed)
    problem = problem_from_dict(doc)
    rows = []
    sims = []
    for _ in range(1 if quick else 3):
        sim = simulate(problem, AgentConfig(), seed=seed)
        sims.append(sim)
    wall_sim = min(s.wall_s for s in sims)
    f = sims[0].report.to_dict()["fleet"]
    rows.append(["in-process (DES)", "-", f"{wall_sim:.2f}", f["spots_cleared"],
                 round(f["priority"], 1), f["duplicate_treatments"], f["vehicles_home"],
                 sims[0].report.to_dict()["messages"]["frames_sent"], "<= 5"])
    print(f"in-process: {wall_sim:.2f} s wall, {f['spots_cleared']} spots, "
          f"priority {f['priority']:.0f}")
    t0 = time.perf_counter()
    backend = ProcessBackend(problem, doc, seed, ProcessOptions(warp=warp, progress_every_s=0),
                             out=lambda s: None)
    report = run_mission(problem, backend, (), seed=seed, step_s=warp * 0.25).report.to_dict()
    wall_run = time.perf_counter() - t0
    f = report["fleet"]
    rows.append([f"multi-process (Zenoh, {len(problem.vehicles) + 2} processes)", f"{warp:g}",
                 f"{wall_run:.1f}", f["spots_cleared"], round(f["priority"], 1),
                 f["duplicate_treatments"], f["vehicles_home"],
                 report["messages"]["frames_sent"], "<= 90"])
    print(f"multi-process at warp {warp:g}: {wall_run:.1f} s wall, {f['spots_cleared']} spots, "
          f"priority {f['priority']:.0f}, mission end t={report['end_s']:.0f} s")
    table = markdown_table(["run", "warp", "wall s", "spots cleared", "priority",
                            "duplicates", "vehicles home", "frames sent", "target wall s"], rows)
    body = (f"Paper preset drawn with seed {seed} (3 AUVs, 90 spots, 3600 s battery), default "
            f"agent and channel settings, no faults. Multi-process: router, relay and one agent "
            f"per AUV as OS processes, no viewer; wall time from the first spawn to the report "
            f"(startup, initial plans, the {report['end_s']:.0f} s mission at warp {warp:g}, "
            f"shutdown). In-process: best of {len(sims)} runs of the same mission on the "
            f"discrete-event transport.\n\n{table}\n")
    if not quick:
        write_section("fleet_mission", "fleet_agent: one-hour 3-AUV mission, wall time", body)
    print(table)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--warp", type=float, default=60.0)
    parser.add_argument("--quick", action="store_true",
                        help="one in-process run, warp 240, no RESULTS.md update")
    args = parser.parse_args()
    main(args.seed, 240.0 if args.quick else args.warp, args.quick)
