"""Dynamic missions: what discovery gains on a reef that differs from its map.

``python -m benchmarks.dynamic [--quick] [--runs N] [--jobs K]``

Over ``runs`` scenarios of `cotsfleet scenario --paper --dynamic` (seed s: the paper's prior,
23 empty predicted spots, 12 unmapped aggregations, the default camera), four ways of working
the same reef, all scored on the truth (priority of the distinct truth spots treated):

- the fleet (`cotsfleet sim --scenario S --seed s`);
- the clairvoyant plan: `best`, 10 s, planned on the truth as if every spot were known at
  t = 0 (`reef_sim.truth.truth_problem`), the upper reference;
- the fleet with ``--no-discovery`` (ignores sightings, does not reallocate freed time);
- the fleet at 30 % extra loss.

Targets (medians): fleet >= 0.85 of the clairvoyant, >= 1.10 x no-discovery, >= 0.75 of the
clairvoyant at 30 % loss; 0 duplicate treatments in every run.
"""

from __future__ import annotations

import argparse
import statistics
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from benchmarks.results import markdown_table, write_section
from cotsfleet.mission.inprocess import simulate
from fleet_agent.config import AgentConfig
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.solve import solve
from reef_sim.scenarios.dynamic import dynamic_preset_doc
from reef_sim.truth import reef_from_doc, truth_problem

CLAIRVOYANT_S = 10.0
LOSS = 0.3


def one(seed: int, clairvoyant_s: float) -> dict[str, Any]:
    """The four figures of scenario ``seed`` (mission seed = scenario seed)."""
    doc = dynamic_preset_doc(seed)
    problem = problem_from_dict(doc)
    reef = reef_from_doc(doc, problem)
    assert reef is not None
    out: dict[str, Any] = {"seed": seed, "truth": reef.total_priority()}
    t0 = time.perf_counter()
    for name, config, loss in (("fleet", AgentConfig(), 0.0),
                               ("no_discovery", AgentConfig(discovery=False), 0.0),
                               ("loss", AgentConfig(), LOSS)):
        r = simulate(problem, config, seed=seed, loss=loss, reef=reef).report.to_dict()
        out[name] = r["fleet"]["priority"]
        out[f"{name}_dups"] = r["fleet"]["duplicate_treatments"]
        out[f"{name}_found"] = r["dynamic"]["spots_discovered"]
        out[f"{name}_unmapped"] = r["dynamic"]["unmapped_treated"]
    out["fleet_wall_s"] = (time.perf_counter() - t0) / 3
    result = solve(truth_problem(problem, reef), "best", time_limit_s=clairvoyant_s, seed=seed)
    out["clairvoyant"] = float(sum(reef.spots[t].priority for r in result.plan.routes
                                   for t in r))
    return out


def main(runs: int, jobs: int, quick: bool) -> None:
    t0 = time.perf_counter()
    clair_s = 1.0 if quick else CLAIRVOYANT_S
    with ProcessPoolExecutor(jobs) as pool:
        rows = list(pool.map(one, range(runs), [clair_s] * runs))
    table_rows = []
    for r in rows:
        table_rows.append([r["seed"], round(r["truth"]), round(r["clairvoyant"]), round(r["fleet"]),
                           round(r["no_discovery"]), round(r["loss"]),
                           f"{r['fleet'] / r['clairvoyant']:.3f}",
                           f"{r['fleet'] / r['no_discovery']:.3f}",
                           f"{r['loss'] / r['clairvoyant']:.3f}",
                           f"{r['fleet_found']}/{r['fleet_unmapped']}",
                           r["fleet_dups"] + r["no_discovery_dups"] + r["loss_dups"]])
        print(" | ".join(str(c) for c in table_rows[-1]), flush=True)
    med = statistics.median
    vs_clair = med(r["fleet"] / r["clairvoyant"] for r in rows)
    vs_nodisc = med(r["fleet"] / r["no_discovery"] for r in rows)
    loss_clair = med(r["loss"] / r["clairvoyant"] for r in rows)
    dups = sum(r["fleet_dups"] + r["no_discovery_dups"] + r["loss_dups"] for r in rows)
    runs_with_dups = sum(1 for r in rows
                         if r["fleet_dups"] + r["no_discovery_dups"] + r["loss_dups"])

    def verdict(ok: bool) -> str:
        return "met" if ok else "**missed**"

    summary = markdown_table(
        ["figure (median over scenarios)", "value", "target", ""],
        [["fleet / clairvoyant", f"{vs_clair:.3f}", ">= 0.85", verdict(vs_clair >= 0.85)],
         ["fleet / no-discovery", f"{vs_nodisc:.3f}", ">= 1.10", verdict(vs_nodisc >= 1.10)],
         ["fleet at 30 % loss / clairvoyant", f"{loss_clair:.3f}", ">= 0.75",
          verdict(loss_clair >= 0.75)],
         ["duplicate treatments (all runs)", f"{dups} ({runs_with_dups} runs)", "0",
          verdict(dups == 0)]])
    table = markdown_table(
        ["seed", "truth", "clairvoyant", "fleet", "no-discovery", "fleet 30 % loss",
         "fleet/clairv.", "fleet/no-disc.", "loss/clairv.", "found/unmapped treated",
         "duplicates"], table_rows)
    wall = time.perf_counter() - t0
    body = (f"`cotsfleet scenario --paper --dynamic --seed s` for s = 0..{runs - 1} (the paper's "
            f"prior: 90 predicted spots, 3 AUVs, 3600 s; about 23 of them empty, 12 "
            f"aggregations the map missed, camera 25 m / 0.9 / 20 s), mission seed = s, in-process "
            f"simulation (`cotsfleet sim`), default agent settings (prior p_cots 0.75). Scored on "
            f"the truth: priority of the distinct truth spots treated. Clairvoyant: `best`, "
            f"{clair_s:g} s, on the truth as if every spot were known at t = 0. No-discovery: "
            f"`--no-discovery`. Loss: 30 % extra uniform loss. found/unmapped treated: unmapped "
            f"aggregations the fleet reported / treated. {jobs} worker process(es), {wall:.0f} s "
            f"wall in all; the machine was shared with other work, so wall times are rough.\n\n"
            f"{summary}\n\n{table}\n")
    print(summary)
    if not quick:
        write_section("dynamic", "Dynamic missions: discovery against the map and the truth",
                      body)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--quick", action="store_true", help="3 runs, no RESULTS.md update")
    args = parser.parse_args()
    main(3 if args.quick else args.runs, args.jobs, args.quick)
