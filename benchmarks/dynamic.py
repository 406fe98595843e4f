"""Dynamic missions: what discovery, search and cooperation gain on a reef that differs from
its map, against one planner that knows everything at once and one that knows the truth.

``python -m benchmarks.dynamic [--quick] [--runs N] [--green N] [--jobs K] [--settings S,..]``

Settings (`SETTINGS`), each over ``runs`` scenarios drawn by the dynamic generator
(`reef_sim.scenarios.dynamic`, seed s = mission seed):

- ``preset``: `cotsfleet scenario --paper --dynamic` (the paper's prior, 23 empty predicted
  spots, 12 aggregations the map missed at a 50 m Gaussian offset);
- ``hard``: the issue's reef: the paper's prior of 90 spots, 28 % of them empty (25), missed
  aggregations numbering 45 % of the predicted spots (41), 10-70 m from predicted ones.

Ways of working each reef, all scored by the world's own book of what was really treated
(`reef_sim.score.world_tally`: the priority of the distinct truth spots the vehicles' injections
reached, duplicates, injections of bare seabed):

- ``fleet``: `cotsfleet sim` (in-process, exact navigation), the agent told what the
  benchmark knows of the generator (`config_of`): its map is exact (`EXACT_MAP`'s figures)
  and its search belief is the setting's (`belief_of`);
- ``central``: the centralized online baseline (`cotsfleet.mission.central`: the same vehicles
  and camera, perfect instant communication; the association rule for a map that is exact,
  `fleet_agent.association.EXACT_MAP`, as the generator's are; with ``--central-search`` also
  its orbits, valued by the search belief fitted to the setting);
- ``clairvoyant``: `best`, 10 s, on the truth as if every spot were known at t = 0;
- ``no_discovery``: the fleet with ``--no-discovery``;
- ``loss``: the fleet at 30 % extra loss;
- ``drift``: the fleet with navigation drifting by 1 % of the distance run (no fixes).

And ``green`` seeds of `examples/green_island.json` (a hand-made truth whose aggregations lie
up to 11 m from their predicted spots): the fleet with exact navigation and with 1 % drift,
duplicates per run.

Targets (issue 30, medians over scenarios of a setting): fleet >= 0.88 of the clairvoyant,
>= 0.97 of the centralized online baseline, >= 1.15 x no-discovery, >= 0.85 of the clairvoyant
at 30 % loss and with 1 % drift; 0 duplicate treatments in every run, and in every Green
Island seed. The ``hard`` setting is the one the issue's figures are about; ``preset`` is
reported beside it.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.results import markdown_table, misses_block, print_misses, write_section
from cotsfleet.mission.central import CentralParams, run_central
from cotsfleet.mission.inprocess import simulate
from fleet_agent.association import EXACT_MAP
from fleet_agent.config import AgentConfig
from fleet_agent.search import BeliefParams
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.solve import solve
from reef_sim.navigation import NavigationParams
from reef_sim.scenarios.dynamic import DynamicParams, generate_dynamic_doc
from reef_sim.score import world_tally
from reef_sim.truth import reef_from_doc, truth_problem

CLAIRVOYANT_S = 10.0
LOSS = 0.3
DRIFT = NavigationParams(drift_pct=1.0)
# Drifting vehicles climb for a GPS fix past this sigma (`AgentConfig.surface_sigma_m`, off by
# default until the loss rules its fault-fuzz duplicates met are fixed: docs/search.md).
CLIMB_SIGMA_M = 3.0
GREEN = Path(__file__).resolve().parents[1] / "examples" / "green_island.json"
SETTINGS: dict[str, DynamicParams] = {
    "preset": DynamicParams(),
    "hard": DynamicParams(empty_share=0.28, unmapped_share=0.45, unmapped_min_m=10.0,
                          unmapped_max_m=70.0),
}
TARGETS = {"fleet/clairvoyant": 0.88, "fleet/central": 0.97, "fleet/no-discovery": 1.15,
           "loss/clairvoyant": 0.85, "drift/clairvoyant": 0.85}
VARIANTS = ("fleet", "no_discovery", "loss", "drift")


def belief_of(params: DynamicParams) -> BeliefParams:
    """The search belief that is the setting's generator (`BeliefParams.for_generator`)."""
    ring = None if params.unmapped_min_m is None else (params.unmapped_min_m,
                                                       params.unmapped_max_m)
    return BeliefParams.for_generator(
        params.base.n_tasks, params.unmapped_count, empty_share=params.empty_share,
        spread_m=params.unmapped_spread_m, ring=ring,  # type: ignore[arg-type]
        empty_anchor_weight=params.empty_anchor_weight,
        priority_range=params.base.priority_range,
        service_range_s=params.service_range_s or (60.0, 90.0))


def config_of(params: DynamicParams, search: bool = False) -> AgentConfig:
    """The agent's configuration for a generated reef: its map is exact (`EXACT_MAP`), and
    with ``search`` its belief is the setting's generator (`belief_of`)."""
    config = AgentConfig(map_sigma_m=EXACT_MAP.map_sigma_m,
                         aggregation_extent_m=EXACT_MAP.extent_m)
    if not search:
        return config
    b = belief_of(params)
    return replace(config, search_per_spot=b.per_spot, search_ring_min_m=b.ring_min_m or 0.0,
                   search_ring_max_m=b.ring_max_m or 0.0, search_spread_m=b.spread_m,
                   search_empty_weight=b.empty_weight)


def sim_vehicles(result: Any) -> dict[str, Any]:
    """The simulated vehicles of an in-process mission, by id (their world's books)."""
    return {vid: seat.driver.vehicle for vid, seat in result.backend.seats.items()
            if seat.driver is not None}


def clairvoyant_priority(problem, reef, seed: int, time_s: float) -> float:
    """The priority of `best`, ``time_s``, on the truth as if every spot were known at t = 0."""
    result = solve(truth_problem(problem, reef), "best", time_limit_s=time_s, seed=seed)
    return float(sum(reef.spots[t].priority for r in result.plan.routes for t in r))


def _fleet(problem, reef, seed: int, config: AgentConfig, loss: float = 0.0,
           navigation: NavigationParams | None = None) -> dict[str, Any]:
    result = simulate(problem, config, seed=seed, loss=loss, reef=reef, navigation=navigation)
    world = world_tally(reef, {vid: v.treatments for vid, v in sim_vehicles(result).items()})
    r = result.report.to_dict()
    return {"priority": world["priority"], "dups": world["duplicates"],
            "missed": world["missed"], "report_priority": r["fleet"]["priority"],
            "report_dups": r["fleet"]["duplicate_treatments"],
            "found": r["dynamic"]["spots_discovered"], "unmapped": world["unmapped_treated"],
            "searches": sum(v.get("counters", {}).get("searches", 0) for v in r["vehicles"]),
            "judged": sum(v.get("counters", {}).get("spots_judged_treated", 0)
                          for v in r["vehicles"]),
            "wall_s": round(result.wall_s, 1)}


def one(setting: str, seed: int, clairvoyant_s: float, search: bool = False) -> dict[str, Any]:
    """Every figure of scenario ``seed`` of ``setting``."""
    params = SETTINGS[setting]
    doc = generate_dynamic_doc(params, np.random.default_rng(seed))
    doc["name"] = f"{setting}-dynamic-seed{seed}"
    problem = problem_from_dict(doc)
    reef = reef_from_doc(doc, problem)
    assert reef is not None
    config = config_of(params, search=True)
    out: dict[str, Any] = {"setting": setting, "seed": seed, "truth": reef.total_priority(),
                           "unmapped_total": len(reef.unmapped())}
    out["fleet"] = _fleet(problem, reef, seed, config)
    out["no_discovery"] = _fleet(problem, reef, seed, replace(config, discovery=False))
    out["loss"] = _fleet(problem, reef, seed, config, loss=LOSS)
    out["drift"] = _fleet(problem, reef, seed, replace(config, surface_sigma_m=CLIMB_SIGMA_M),
                          navigation=DRIFT)
    central = run_central(problem, reef, seed=seed, params=CentralParams(
        p_cots=config.p_cots, plan_iterations=config.plan_iterations,
        replan_iterations=config.replan_iterations, reserve_s=config.battery_reserve_s,
        association=EXACT_MAP, belief=belief_of(params) if search else None))
    world = central.report["world"]
    out["central"] = {"priority": world["priority"], "dups": world["duplicates"],
                      "missed": world["missed"], "unmapped": world["unmapped_treated"],
                      "found": central.report["dynamic"]["spots_discovered"],
                      "searches": central.report["central"]["searches_flown"],
                      "wall_s": round(central.wall_s, 1)}
    out["clairvoyant"] = clairvoyant_priority(problem, reef, seed, clairvoyant_s)
    return out


def green(seed: int) -> dict[str, Any]:
    """The fleet on the example reef, mission seed ``seed``, exact and with 1 % drift."""
    doc = json.loads(GREEN.read_text())
    problem = problem_from_dict(doc)
    reef = reef_from_doc(doc, problem)
    return {"seed": seed, "exact": _fleet(problem, reef, seed, AgentConfig()),
            "drift": _fleet(problem, reef, seed, AgentConfig(surface_sigma_m=CLIMB_SIGMA_M),
                            navigation=DRIFT)}


def _ratio(a: float, b: float) -> float:
    return a / b if b > 0 else 1.0


def summarise(rows: list[dict[str, Any]]) -> dict[str, float]:
    med = statistics.median
    return {"fleet/clairvoyant": med(_ratio(r["fleet"]["priority"], r["clairvoyant"])
                                     for r in rows),
            "fleet/central": med(_ratio(r["fleet"]["priority"], r["central"]["priority"])
                                 for r in rows),
            "fleet/no-discovery": med(_ratio(r["fleet"]["priority"],
                                             r["no_discovery"]["priority"]) for r in rows),
            "loss/clairvoyant": med(_ratio(r["loss"]["priority"], r["clairvoyant"])
                                    for r in rows),
            "drift/clairvoyant": med(_ratio(r["drift"]["priority"], r["clairvoyant"])
                                     for r in rows),
            "central/clairvoyant": med(_ratio(r["central"]["priority"], r["clairvoyant"])
                                       for r in rows)}


def _dups(r: dict[str, Any]) -> int:
    return sum(r[k]["dups"] for k in (*VARIANTS, "central"))


def _dups_by_way(r: dict[str, Any]) -> str:
    return "/".join(str(r[k]["dups"]) for k in (*VARIANTS, "central"))


def main(runs: int, greens: int, jobs: int, settings: list[str], quick: bool,
         search: bool = False) -> None:
    t0 = time.perf_counter()
    load0 = os.getloadavg()
    clair_s = 1.0 if quick else CLAIRVOYANT_S
    jobs_list = [(s, seed) for s in settings for seed in range(runs)]
    with ProcessPoolExecutor(jobs) as pool:
        rows = list(pool.map(one, [s for s, _ in jobs_list], [seed for _, seed in jobs_list],
                             [clair_s] * len(jobs_list), [search] * len(jobs_list)))
        green_rows = list(pool.map(green, range(greens)))
    sections, misses = [], []
    for setting in settings:
        mine = [r for r in rows if r["setting"] == setting]
        figures = summarise(mine)
        dups = sum(_dups(r) for r in mine)
        runs_with = sum(1 for r in mine if _dups(r))
        summary_rows = []
        for name, value in figures.items():
            target = TARGETS.get(name)
            ok = target is None or value >= target
            if not ok and setting == "hard":
                misses.append(f"{setting}: {name} {value:.3f} < {target}")
            summary_rows.append([name, f"{value:.3f}", "" if target is None else f">= {target}",
                                 "" if target is None else ("met" if ok else "**missed**")])
        if dups:  # 0 in every run, of every setting (the medians' targets are hard's)
            misses.append(f"{setting}: {dups} duplicate treatment(s) in {runs_with} run(s)")
        summary_rows.append(["duplicate treatments (all runs, all ways)",
                             f"{dups} ({runs_with} runs)", "0", "met" if not dups else
                             "**missed**"])
        table = [[r["seed"], round(r["truth"]), round(r["clairvoyant"]),
                  round(r["central"]["priority"]), round(r["fleet"]["priority"]),
                  round(r["no_discovery"]["priority"]), round(r["loss"]["priority"]),
                  round(r["drift"]["priority"]),
                  f"{_ratio(r['fleet']['priority'], r['clairvoyant']):.3f}",
                  f"{_ratio(r['fleet']['priority'], r['central']['priority']):.3f}",
                  f"{r['fleet']['unmapped']}/{r['central']['unmapped']}/{r['unmapped_total']}",
                  f"{r['fleet']['searches']}/{r['central']['searches']}", r["drift"]["missed"],
                  _dups_by_way(r)]
                 for r in mine]
        print(f"{setting}:", json.dumps(figures), flush=True)
        sections.append(
            f"### {setting}\n\n" + markdown_table(["figure (median over scenarios)", "value",
                                                   "target", ""], summary_rows) + "\n\n"
            + markdown_table(["seed", "truth", "clairvoyant", "central", "fleet",
                              "no-discovery", "loss 30 %", "drift 1 %", "fleet/clairv.",
                              "fleet/central", "unmapped treated fleet/central/all",
                              "searches fleet/central", "drift bare injections",
                              "duplicates fleet/no-disc./loss/drift/central"],
                             table))
    if green_rows:
        g_dups = sum(g["exact"]["dups"] + g["drift"]["dups"] for g in green_rows)
        g_report = sum(g["exact"]["report_dups"] for g in green_rows)
        if g_dups:
            misses.append(f"green island: {g_dups} duplicate treatment(s)")
        g_table = [[g["seed"], g["exact"]["priority"], g["exact"]["dups"],
                    g["exact"]["report_dups"], g["drift"]["priority"], g["drift"]["dups"],
                    g["drift"]["missed"]] for g in green_rows]
        sections.append(
            f"### examples/green_island.json, {len(green_rows)} seeds\n\n"
            f"Duplicate treatments in all: {g_dups} by the world's book ({g_report} as the "
            "report reads the exact-navigation runs).\n\n"
            + markdown_table(["seed", "priority", "duplicates", "report duplicates",
                              "priority, 1 % drift", "duplicates, 1 % drift",
                              "bare injections, 1 % drift"], g_table))
    wall = time.perf_counter() - t0
    body = (f"{runs} scenario(s) per setting (mission seed = scenario seed), in-process "
            f"simulation; the agent told the generator's map is exact and given the "
            f"setting's search belief (`config_of`), Green Island at default settings. "
            f"Scored by the world's book of what the injections really reached "
            f"(`reef_sim.score.world_tally`). Clairvoyant: `best`, "
            f"{clair_s:g} s, on the truth as if every spot were known at t = 0. Central: "
            f"`cotsfleet.mission.central` (association `EXACT_MAP`"
            f"{', orbits by the setting' + chr(39) + 's belief' if search else ', no search'}). "
            f"Loss: "
            f"{LOSS:.0%} extra uniform loss. Drift: navigation drifting by "
            f"{DRIFT.drift_pct:g} % of the distance run, no USBL fixes; the vehicles climb for a "
            f"GPS fix past a sigma of {CLIMB_SIGMA_M:g} m (`surface_sigma_m`). {jobs} worker "
            f"process(es), "
            f"{wall:.0f} s wall in all; load average (1, 5, 15 min) "
            f"{' / '.join(f'{x:.1f}' for x in load0)} at the start, "
            f"{' / '.join(f'{x:.1f}' for x in os.getloadavg())} at the end (the clairvoyant's "
            f"{clair_s:g} s are a time limit: a loaded machine favours the fleet's ratio to "
            f"it; every other figure is the seeded missions' own).\n\n"
            + "\n\n".join(sections) + "\n\n" + misses_block(misses))
    print_misses(misses)
    if not quick:
        write_section("dynamic", "Dynamic missions: discovery, search and cooperation "
                      "against the map and the truth", body)
    else:
        print(body)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--green", type=int, default=20, help="seeds of the example reef")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--settings", default=",".join(SETTINGS),
                        help=f"comma-separated, of {', '.join(SETTINGS)}")
    parser.add_argument("--central-search", action="store_true",
                        help="the central baseline also flies orbits its belief values")
    parser.add_argument("--quick", action="store_true",
                        help="2 hard scenarios, 2 Green Island seeds, no RESULTS.md update")
    args = parser.parse_args()
    chosen = [s for s in args.settings.split(",") if s]
    unknown = [s for s in chosen if s not in SETTINGS]
    if unknown:
        parser.error(f"unknown setting(s) {unknown}; known: {sorted(SETTINGS)}")
    if args.quick:
        main(2, 2, args.jobs, ["hard"], True, args.central_search)
    else:
        main(args.runs, args.green, args.jobs, chosen, False, args.central_search)
