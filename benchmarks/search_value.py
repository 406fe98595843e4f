"""What finding the map's missed aggregations would be worth, and where they go (issue 30).

``python -m benchmarks.search_value [--quick] [--runs N] [--jobs K] [--settings S,..]``

For each scenario of a `benchmarks.dynamic` setting (same generator, seeds, agent
configuration and clairvoyant plan), three fleet missions in process with exact navigation,
scored by the world's book against the clairvoyant plan:

- ``main``: the map as generated (the dynamic benchmark's ``fleet``);
- ``search``: perfect, free search: the map also names every aggregation it missed, at its
  true place, rho and injection time, from t = 0 (`knowing_unmapped`); the empty predicted
  spots are still unknown. No search rule can find more for less, so this bounds what search
  could add;
- ``map``: a perfect map: the same, with the empty predicted spots left off it as well
  (`without_empty`). What is left between it and the clairvoyant is the cost of flying online.

And for ``main``, what became of each aggregation the map missed, from the simulator's books
(`reef_sim.vehicle.SimVehicle.sighted`, `reef_sim.camera.ReefCamera.passes`): treated; seen but
not treated, first seen late (after `LATE_SHARE` of the battery) or early; passed within the
camera's reach and not seen (each pass sees with ``p_detect``); never within reach.
"""

from __future__ import annotations

import argparse
import copy
import os
import statistics
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from benchmarks.dynamic import (CLAIRVOYANT_S, SETTINGS, clairvoyant_priority, config_of,
                                sim_vehicles)
from benchmarks.results import markdown_table, write_section
from cotsfleet.mission.inprocess import simulate
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.dynamic import generate_dynamic_doc
from reef_sim.score import world_tally
from reef_sim.truth import reef_from_doc

LATE_SHARE = 2.0 / 3.0  # a sighting after this share of the battery is "late"
MAPS = ("main", "search", "map")


def knowing_unmapped(doc: dict[str, Any]) -> dict[str, Any]:
    """``doc`` whose map also names every truth aggregation it missed, as it really is (a
    new task at its position with its rho and injection time; task ids after the last)."""
    out = copy.deepcopy(doc)
    next_id = max((int(t["id"]) for t in out["tasks"]), default=0) + 1
    for spot in out["truth"]["spots"]:
        if spot.get("task") is None:
            spot["task"] = len(out["tasks"])
            out["tasks"].append({"id": next_id, "pos": list(spot["pos"]),
                                 "priority": spot["priority"], "service_s": spot["service_s"]})
            next_id += 1
    return out


def without_empty(doc: dict[str, Any]) -> dict[str, Any]:
    """``doc`` whose map names only predicted spots that hold COTS (truth spots renumbered)."""
    out = copy.deepcopy(doc)
    keep = sorted({int(s["task"]) for s in out["truth"]["spots"] if s.get("task") is not None})
    index = {old: new for new, old in enumerate(keep)}
    out["tasks"] = [out["tasks"][t] for t in keep]
    for spot in out["truth"]["spots"]:
        if spot.get("task") is not None:
            spot["task"] = index[int(spot["task"])]
    return out


def fates(reef: Any, vehicles: dict[str, Any], treated: set[int], late_s: float
          ) -> dict[str, list[float]]:
    """The priorities of the map's missed aggregations by what became of them."""
    passes = sum((v.camera.passes() for v in vehicles.values() if v.camera is not None),
                 np.zeros(len(reef.spots), dtype=np.int64))
    first: dict[int, float] = {}
    for v in vehicles.values():
        for spot, t in v.sighted.items():
            first[spot] = min(t, first.get(spot, t))
    out: dict[str, list[float]] = {k: [] for k in FATES}
    for i in reef.unmapped():
        if i in treated:
            kind = "treated"
        elif i in first:
            kind = "seen late" if first[i] > late_s else "seen early"
        elif passes[i]:
            kind = "passed, unseen"
        else:
            kind = "never in reach"
        out[kind].append(float(reef.spots[i].priority))
    return out


FATES = ("treated", "seen late", "seen early", "passed, unseen", "never in reach")


def one(setting: str, seed: int, clairvoyant_s: float) -> dict[str, Any]:
    """The three maps' missions of scenario ``seed`` of ``setting``, and the fates."""
    params = SETTINGS[setting]
    doc = generate_dynamic_doc(params, np.random.default_rng(seed))
    config = config_of(params, search=True)
    out: dict[str, Any] = {"setting": setting, "seed": seed}
    for name, mapped in zip(MAPS, (doc, knowing_unmapped(doc),
                                   without_empty(knowing_unmapped(doc)))):
        problem = problem_from_dict(mapped)
        reef = reef_from_doc(mapped, problem)
        assert reef is not None
        result = simulate(problem, config, seed=seed, reef=reef)
        vehicles = sim_vehicles(result)
        world = world_tally(reef, {vid: v.treatments for vid, v in vehicles.items()})
        out[name] = {"priority": world["priority"], "dups": world["duplicates"]}
        if name == "main":
            treated = {i for spots in world["by_vehicle"].values() for i in spots}
            late_s = LATE_SHARE * min(v.battery_s for v in problem.vehicles)
            out["fates"] = fates(reef, vehicles, treated, late_s)
            out["clairvoyant"] = clairvoyant_priority(problem, reef, seed, clairvoyant_s)
    return out


def _section(setting: str, rows: list[dict[str, Any]]) -> str:
    ratio = {m: [r[m]["priority"] / r["clairvoyant"] for r in rows] for m in MAPS}
    total = {m: sum(r[m]["priority"] for r in rows) for m in MAPS}
    summary = [[m, f"{statistics.median(ratio[m]):.3f}",
                f"{min(ratio[m]):.3f}-{max(ratio[m]):.3f}", f"{total[m]:,.0f}",
                "" if m == "main" else sum(1 for a, b in zip(ratio[m], ratio["main"]) if a > b),
                sum(r[m]["dups"] for r in rows)] for m in MAPS]
    fate_rows = [[k, sum(len(r["fates"][k]) for r in rows),
                  f"{sum(sum(r['fates'][k]) for r in rows):,.0f}"] for k in FATES]
    per_seed = [[r["seed"], round(r["clairvoyant"])]
                + [f"{r[m]['priority']:.0f} ({r[m]['priority'] / r['clairvoyant']:.3f})"
                   for m in MAPS] for r in rows]
    return (f"### {setting}\n\n"
            + markdown_table(["map", "median fleet/clairvoyant", "range",
                              "priority, all scenarios", "scenarios above main",
                              "duplicates"], summary)
            + "\n\nThe map's missed aggregations in the `main` missions:\n\n"
            + markdown_table(["fate", "aggregations", "priority"], fate_rows)
            + "\n\n" + markdown_table(["seed", "clairvoyant", "main", "search", "map"],
                                      per_seed))


def main(runs: int, jobs: int, settings: list[str], quick: bool) -> None:
    t0, load0 = time.perf_counter(), os.getloadavg()
    clair_s = 1.0 if quick else CLAIRVOYANT_S
    todo = [(s, seed) for s in settings for seed in range(runs)]
    with ProcessPoolExecutor(jobs) as pool:
        rows = list(pool.map(one, [s for s, _ in todo], [seed for _, seed in todo],
                             [clair_s] * len(todo)))
    sections = []
    for setting in settings:
        mine = [r for r in rows if r["setting"] == setting]
        medians = {m: statistics.median(r[m]["priority"] / r["clairvoyant"] for r in mine)
                   for m in MAPS}
        print(f"{setting}:", {m: round(v, 3) for m, v in medians.items()}, flush=True)
        sections.append(_section(setting, mine))
    body = (f"{runs} scenario(s) per setting, as `benchmarks.dynamic` draws them (mission seed = "
            f"scenario seed), its agent configuration (`config_of`, search belief on), exact "
            f"navigation, in process; scored by the world's book against `best`, "
            f"{clair_s:g} s, on the truth. `main`: the map as generated. `search`: the map "
            f"also names every aggregation it missed, as it really is, from t = 0 (perfect, "
            f"free search). `map`: that, and the empty predicted spots left off the map. Fates: "
            f"'seen late' is first seen after {LATE_SHARE:.0%} of the battery. {jobs} worker "
            f"process(es), {time.perf_counter() - t0:.0f} s wall; load average "
            f"{' / '.join(f'{x:.1f}' for x in load0)} at the start, "
            f"{' / '.join(f'{x:.1f}' for x in os.getloadavg())} at the end.\n\n"
            + "\n\n".join(sections))
    if quick:
        print(body)
    else:
        write_section("search_value", "Dynamic missions: what search could add (issue 30)",
                      body)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--settings", default=",".join(SETTINGS),
                        help=f"comma-separated, of {', '.join(SETTINGS)}")
    parser.add_argument("--quick", action="store_true",
                        help="2 hard scenarios, no RESULTS.md update")
    args = parser.parse_args()
    chosen = [s for s in args.settings.split(",") if s]
    unknown = [s for s in chosen if s not in SETTINGS]
    if unknown:
        parser.error(f"unknown setting(s) {unknown}; known: {sorted(SETTINGS)}")
    main(2 if args.quick else args.runs, args.jobs, ["hard"] if args.quick else chosen,
         args.quick)
