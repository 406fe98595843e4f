"""Where the fleet's battery goes on a dynamic reef, against the clairvoyant plan (issue 30).

``python -m benchmarks.dynamic_budget [--quick] [--runs N] [--jobs K] [--setting S]``

For each scenario of a `benchmarks.dynamic` setting (same generator, seeds, agent
configuration and clairvoyant plan as its ``fleet`` and ``clairvoyant`` columns), one fleet
mission in process with exact navigation. The simulator's books say what each vehicle did with
every second of its battery (`reef_sim.timebook`: transit, homing, looks that found COTS or
bare seabed, injecting, holding, recovered before the battery's end) and what it really
treated (`reef_sim.score.world_tally`). The clairvoyant plan (`best` on the truth) is split the
same way from its routes: injecting is the sum of its spots' injection times (eq. 2), transit
the rest of its route times, unused the battery beyond them. Figures are vehicle-seconds per
mission summed over the fleet; the table gives their medians over the scenarios.

What it answers: whether the fleet falls short of the clairvoyant because it flies more, looks,
waits, or treats less priority per second injected.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from benchmarks.dynamic import (CLAIRVOYANT_S, SETTINGS, config_of, problem_from_dict,
                                sim_vehicles)
from benchmarks.results import markdown_table, write_section
from cotsfleet.mission.inprocess import simulate
from hfc_core.solve import solve
from reef_sim.scenarios.dynamic import generate_dynamic_doc
from reef_sim.score import world_tally
from reef_sim.timebook import ACTIVITIES
from reef_sim.truth import reef_from_doc, truth_problem

CLAIRVOYANT_ROWS = ("transit", "injecting", "unused")


def one(setting: str, seed: int, clairvoyant_s: float) -> dict[str, Any]:
    """The fleet's and the clairvoyant's battery, by activity, on scenario ``seed``."""
    params = SETTINGS[setting]
    doc = generate_dynamic_doc(params, np.random.default_rng(seed))
    problem = problem_from_dict(doc)
    reef = reef_from_doc(doc, problem)
    assert reef is not None
    result = simulate(problem, config_of(params, search=True), seed=seed, reef=reef)
    vehicles = sim_vehicles(result)
    world = world_tally(reef, {vid: v.treatments for vid, v in vehicles.items()})
    battery = {spec.id: spec.battery_s for spec in problem.vehicles}
    fleet = dict.fromkeys(ACTIVITIES, 0.0)
    for vid, v in vehicles.items():
        for k, s in v.time.totals(battery[vid]).items():
            fleet[k] += s
    treated = {i for spots in world["by_vehicle"].values() for i in spots}
    truth = truth_problem(problem, reef)
    plan = solve(truth, "best", time_limit_s=clairvoyant_s, seed=seed).plan
    clair = dict.fromkeys(CLAIRVOYANT_ROWS, 0.0)
    for k, route in enumerate(plan.routes):
        route_s = truth.route_time_s(k, list(route)) if route else 0.0
        inject_s = float(sum(reef.spots[t].service_s for t in route))
        clair["injecting"] += inject_s
        clair["transit"] += route_s - inject_s
        clair["unused"] += truth.vehicles[k].battery_s - route_s
    spots = [t for r in plan.routes for t in r]
    return {"seed": seed, "fleet": fleet, "clairvoyant": clair,
            "fleet_priority": world["priority"], "fleet_treated": len(treated),
            "clair_priority": float(sum(reef.spots[t].priority for t in spots)),
            "clair_treated": len(spots)}


def rate(row: dict[str, Any], who: str) -> float:
    """Priority treated per second injecting by ``who`` ('fleet' or 'clair') in ``row``."""
    seconds = row["fleet" if who == "fleet" else "clairvoyant"]["injecting"]
    return row[f"{who}_priority"] / seconds if seconds > 0 else 0.0


# (row, the fleet's activities summed, the clairvoyant's split): one row per use of battery
ROWS = (("flying (transit and home)", ("transit", "homing"), "transit"),
        ("looking, found COTS", ("look_cots",), None),
        ("looking, found bare seabed", ("look_empty",), None),
        ("injecting", ("injecting",), "injecting"),
        ("holding station", ("holding",), None),
        ("unused (at the rendezvous early)", ("recovered",), "unused"))


def section(rows: list[dict[str, Any]]) -> str:
    """The medians over scenarios, a row per use of battery, and the per-scenario figures."""
    med = statistics.median
    table: list[list[object]] = [
        [name, f"{med(sum(r['fleet'][k] for k in mine) for r in rows):,.0f}",
         f"{med(r['clairvoyant'][theirs] for r in rows):,.0f}" if theirs else "0"]
        for name, mine, theirs in ROWS]
    table += [["aggregations treated", f"{med(r['fleet_treated'] for r in rows):.0f}",
               f"{med(r['clair_treated'] for r in rows):.0f}"],
              ["priority per second injecting", f"{med(rate(r, 'fleet') for r in rows):.3f}",
               f"{med(rate(r, 'clair') for r in rows):.3f}"],
              ["priority", f"{med(r['fleet_priority'] for r in rows):,.0f}",
               f"{med(r['clair_priority'] for r in rows):,.0f}"]]
    per_seed = [[r["seed"], f"{r['fleet_priority']:.0f}", f"{r['clair_priority']:.0f}",
                 f"{r['fleet']['transit'] + r['fleet']['homing']:.0f}",
                 f"{r['clairvoyant']['transit']:.0f}",
                 f"{r['fleet']['look_cots']:.0f} / {r['fleet']['look_empty']:.0f}",
                 f"{r['fleet']['injecting']:.0f}", f"{r['clairvoyant']['injecting']:.0f}",
                 f"{r['fleet']['holding']:.0f}", f"{r['fleet']['recovered']:.0f}",
                 f"{r['clairvoyant']['unused']:.0f}"] for r in rows]
    return (markdown_table(["vehicle-seconds per mission (median)", "fleet", "clairvoyant"],
                           table)
            + "\n\n" + markdown_table(
                ["seed", "fleet priority", "clairvoyant", "fleet flying", "clairvoyant flying",
                 "looks: COTS / empty", "fleet injecting", "clairvoyant injecting",
                 "holding", "fleet unused", "clairvoyant unused"], per_seed))


def main(runs: int, jobs: int, setting: str, quick: bool) -> None:
    t0, load0 = time.perf_counter(), os.getloadavg()
    clair_s = 1.0 if quick else CLAIRVOYANT_S
    with ProcessPoolExecutor(jobs) as pool:
        rows = list(pool.map(one, [setting] * runs, range(runs), [clair_s] * runs))
    body = (f"Setting `{setting}`, {runs} scenario(s) as `benchmarks.dynamic` draws them "
            f"(mission seed = scenario seed), its agent configuration (`config_of`, search "
            f"belief on), exact navigation, in process. The fleet's seconds are the "
            f"simulator's books (`reef_sim.timebook`); the clairvoyant's are split from the "
            f"routes of `best`, {clair_s:g} s, on the truth (transit includes the flight "
            f"home). 'Flying' per seed is transit plus homing. {jobs} worker process(es), "
            f"{time.perf_counter() - t0:.0f} s wall; load average "
            f"{' / '.join(f'{x:.1f}' for x in load0)} at the start, "
            f"{' / '.join(f'{x:.1f}' for x in os.getloadavg())} at the end.\n\n"
            + section(rows))
    print(body)
    if not quick:
        write_section("dynamic_budget",
                      "Dynamic missions: where the battery goes (issue 30)", body)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--setting", default="hard", choices=sorted(SETTINGS))
    parser.add_argument("--quick", action="store_true",
                        help="2 scenarios, no RESULTS.md update")
    args = parser.parse_args()
    main(2 if args.quick else args.runs, args.jobs, args.setting, args.quick)
