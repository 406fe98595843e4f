"""Tidal currents: a plan that knows the tide against a still-water plan, both flown in it.

Scenario i is `paper_preset_doc(1000 + i)` with a tidal stream (M2, 12.42 h) of peak 0.3 or
0.6 m/s; its direction and where the mission starts in the tidal cycle are drawn per scenario
(seeded: direction U(0, 2 pi), phase U(0, period)), the same for both peaks. Each scenario is
planned by `best` (same iteration budget and seed) for still water (the paper's Assumption 1:
the scenario without its current) and for each peak with the current. Every plan is then
flown, without replanning, on the vehicle model in the tide (`reef_sim.vehicle.fly`: the
in-process simulation of the plan's execution; no radio needed).

Figures per plan: priority of the spots cleared before the vehicle's battery ran out, and of
those cleared by vehicles that also reach the rendezvous in time (a late vehicle's battery is
empty before it is recovered: lost at sea); vehicles late and by how much; battery left on
arrival (unused time).

    python -m benchmarks.currents              # 30 scenarios, 1000 iterations per plan
    python -m benchmarks.currents --quick      # 4 scenarios, 200 iterations, no write
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from benchmarks.pinned import run_pinned
from benchmarks.results import markdown_table, write_section
from fleet_bus.vehicle_port import Arrived, Injected
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.model.current import M2_PERIOD_S
from hfc_core.model.problem import Problem
from hfc_core.solve import solve
from reef_sim.scenarios.field import paper_preset_doc
from reef_sim.vehicle import fly

PEAKS_MPS = (0.3, 0.6)


def tide(scenario: int, peak_mps: float) -> dict:
    """The scenario's tidal stream at ``peak_mps`` (direction and phase seeded by scenario)."""
    rng = np.random.default_rng([16, scenario])
    angle, phase = rng.uniform(0.0, 2.0 * math.pi), rng.uniform(0.0, M2_PERIOD_S)
    return {"kind": "tidal", "velocity_mps": [peak_mps * math.cos(angle),
                                              peak_mps * math.sin(angle)],
            "period_s": M2_PERIOD_S, "phase_s": phase}


def flown(problem: Problem, routes: list[list[int]]) -> list[dict]:
    """Each vehicle of ``problem`` flying its route in ``problem``'s water."""
    out = []
    for v, route in enumerate(routes):
        battery = problem.vehicles[v].battery_s
        events = fly(problem, v, route)
        arrived = next((e.t_s for e in events if isinstance(e, Arrived)), math.inf)
        cleared = sum(float(problem.priority[e.task]) for e in events
                      if isinstance(e, Injected) and e.t_s <= battery)
        out.append({"priority": cleared, "arrived_s": arrived, "battery_s": battery})
    return out


def worker(scenario: int, seed: int, iterations: int) -> None:
    still_doc = paper_preset_doc(scenario)
    still = problem_from_dict(still_doc)
    still_plan = [list(r) for r in solve(still, "best", max_iterations=iterations,
                                         seed=seed).plan.routes]
    result = {"still": {"still": flown(still, still_plan)}}
    for peak in PEAKS_MPS:
        wet = problem_from_dict({**still_doc, "current": tide(scenario, peak)})
        aware = [list(r) for r in solve(wet, "best", max_iterations=iterations,
                                        seed=seed).plan.routes]
        result[f"{peak:g}"] = {"still": flown(wet, still_plan), "aware": flown(wet, aware)}
    print(json.dumps(result))


def summary(runs: list[dict], water: str, plan: str, reference: np.ndarray) -> list[object]:
    flights = [r[water][plan] for r in runs]
    priority = np.array([sum(f["priority"] for f in fl) for fl in flights])
    home = np.array([sum(f["priority"] for f in fl if f["arrived_s"] <= f["battery_s"])
                     for fl in flights])
    late = [f["arrived_s"] - f["battery_s"] for fl in flights for f in fl
            if f["arrived_s"] > f["battery_s"]]
    left = [f["battery_s"] - f["arrived_s"] for fl in flights for f in fl
            if f["arrived_s"] <= f["battery_s"]]
    vehicles = sum(len(fl) for fl in flights)
    return [
        "still water" if water == "still" else f"tide, peak {water} m/s",
        "still-water" if plan == "still" else "tide-aware",
        f"{np.median(priority):.0f}",
        f"{np.median(priority / reference):.4f}",
        f"{np.median(home):.0f}",
        f"{len(late)}/{vehicles}",
        f"{np.median(late):.0f} / {max(late):.0f}" if late else "-",
        f"{np.median(left):.0f}" if left else "-",
    ]


def main(runs: int, iterations: int, parallel: int, write: bool) -> None:
    scenarios = [1000 + i for i in range(runs)]
    commands = [["benchmarks.currents", "--worker", str(s), str(i), str(iterations)]
                for i, s in enumerate(scenarios)]
    results = run_pinned(commands, parallel)
    reference = np.array([sum(f["priority"] for f in r["still"]["still"]) for r in results])
    rows = [summary(results, "still", "still", reference)]
    for peak in PEAKS_MPS:
        for plan in ("still", "aware"):
            rows.append(summary(results, f"{peak:g}", plan, reference))
    head = ["water", "plan", "priority cleared, median", "vs still water",
            "... by vehicles back in time", "vehicles late",
            "late by, median / max s", "battery left at rendezvous, median s"]
    table = markdown_table(head, rows)
    print(table)
    if write:
        body = (
            f"`python -m benchmarks.currents`: {runs} scenarios `paper_preset_doc(1000 + i)`, "
            "each with a tidal stream (M2) whose direction and phase are drawn per scenario, "
            f"at peaks {' and '.join(f'{p:g}' for p in PEAKS_MPS)} m/s. `best`, "
            f"{iterations} iterations, seed i, plans once for still water and once with the "
            "current; each plan is flown without replanning on the vehicle model in the tide "
            "(`reef_sim.vehicle.fly`). Priority cleared counts the spots finished before "
            "the vehicle's battery ran out; a late vehicle reaches the rendezvous after its "
            "battery is empty (lost at sea).\n\n" + table + "\n"
        )
        write_section("currents", "Tidal currents: tide-aware vs still-water plans, flown in "
                      "the tide", body)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--iterations", type=int, default=None, help="per plan (1000)")
    parser.add_argument("--jobs", type=int, default=1, help="scenarios at once, one core each")
    parser.add_argument("--quick", action="store_true", help="4 scenarios, 200 iterations")
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--worker", nargs=3, type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    iterations = args.iterations or (200 if args.quick else 1000)
    if args.worker:
        worker(*args.worker[:2], iterations=args.worker[2])
    else:
        main(4 if args.quick else args.runs, iterations, args.jobs,
             write=not (args.quick or args.no_write))
