"""Random faults under drift and loss: does anything crash, or treat a spot twice?

``python -m benchmarks.fault_fuzz [--quick] [--seeds A:B] [--jobs K]``

Each seed draws one in-process mission (`cotsfleet.mission.inprocess.simulate`) on Green Island
(`examples/green_island.json`), a hard or a preset dynamic reef (`benchmarks.dynamic.SETTINGS`,
in turn), with 1-3 random faults between 200 s and 2,500 s: an abort, a kill, a kill then a
restart 30-900 s later (on the journal), a stall of 30-400 s, extra uniform loss up to 60 %
from then on, or a 50 % loss; navigation drifting by 0.5, 1 or 2 % of the distance run, with
a USBL fix every 900 s or none; 0 or 20 % loss throughout. A fault list that cannot apply
(a stall of a vehicle dead by then, a second kill) is refused with `FaultError` and counted,
not run. Scored by the world's book (`reef_sim.score.world_tally`): duplicates are injections
of an aggregation already treated, by anyone, under any name. False alarms are the report's
(a 'lost' for a vehicle alive then: expected under heavy loss, `benchmarks.fleet_silence`).

Targets: no crash; no duplicate. What a run that misses names is the seed to replay. Seeds
0-239 by default (stop 49): the first 120 alone had no duplicate on main while 120-239 had
three, so 120 seeds said too little (docs/search.md, "The fault fuzz on 240 seeds").
"""

from __future__ import annotations

import argparse
import json
import time
import traceback
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np
import psutil

from benchmarks.dynamic import GREEN, SETTINGS, config_of
from benchmarks.results import markdown_table, misses_block, print_misses, write_section
from cotsfleet.mission.faults import Fault, FaultError
from cotsfleet.mission.inprocess import simulate
from fleet_agent.config import AgentConfig
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.navigation import NavigationParams
from reef_sim.scenarios.dynamic import generate_dynamic_doc
from reef_sim.score import world_tally
from reef_sim.truth import reef_from_doc

REEFS = ("green", "hard", "preset")
FAULT_STREAM = 1000  # the faults' generator is seeded 1000 + seed, apart from the reef's


def reef_mission(which: str, seed: int) -> tuple[dict[str, Any], AgentConfig]:
    """The scenario document and agent configuration of reef ``which`` ("green": Green
    Island at default settings; a `benchmarks.dynamic` setting: its reef ``seed``), as
    `benchmarks.dynamic` runs them."""
    if which == "green":
        return json.loads(GREEN.read_text()), AgentConfig()
    params = SETTINGS[which]
    return generate_dynamic_doc(params, np.random.default_rng(seed)), config_of(params,
                                                                             search=True)


def draw(seed: int) -> tuple[str, dict[str, Any], AgentConfig, list[Fault],
                              NavigationParams, float]:
    """Seed ``seed``'s mission: (reef name, scenario document, agent configuration, faults,
    navigation, loss throughout)."""
    rng = np.random.default_rng(FAULT_STREAM + seed)
    which = REEFS[seed % len(REEFS)]
    doc, config = reef_mission(which, seed)
    vids = [v["id"] for v in doc["vehicles"]]
    faults: list[Fault] = []
    for _ in range(int(rng.integers(1, 4))):
        kind = str(rng.choice(["abort", "kill", "restart", "stall", "half-loss", "loss"]))
        t = float(rng.uniform(200, 2500))
        if kind == "loss":
            faults.append(Fault("loss", t, "", float(rng.uniform(0, 0.6))))
        elif kind == "half-loss":  # every link loses half its frames from then on
            faults.append(Fault("loss", t, "", 0.5))
        elif kind == "stall":
            faults.append(Fault("stall", t, str(rng.choice(vids)), float(rng.uniform(30, 400))))
        elif kind == "restart":
            v = str(rng.choice(vids))
            faults += [Fault("kill", t, v), Fault("restart", t + float(rng.uniform(30, 900)), v)]
        else:
            faults.append(Fault(kind, t, str(rng.choice(vids))))
    navigation = NavigationParams(drift_pct=float(rng.choice([0.5, 1.0, 2.0])),
                                  fix_period_s=None if rng.random() < 0.5 else 900.0)
    return which, doc, config, faults, navigation, float(rng.choice([0.0, 0.2]))


def one(seed: int) -> dict[str, Any]:
    """Seed ``seed``'s mission and what became of it."""
    which, doc, config, faults, navigation, loss = draw(seed)
    out: dict[str, Any] = {
        "seed": seed, "reef": which, "faults": [f"{f.kind}@{f.t_s:.0f}"
                                                + (f":{f.vid}" if f.vid else "")
                                                + (f"={f.value:.2f}" if f.value else "")
                                                for f in faults],
        "drift": navigation.drift_pct, "fixes": navigation.fix_period_s, "loss": loss}
    problem = problem_from_dict(doc)
    reef = reef_from_doc(doc, problem)
    assert reef is not None  # every reef drawn has a truth
    try:
        result = simulate(problem, config, seed=seed, reef=reef, navigation=navigation,
                          loss=loss, faults=faults)
    except FaultError as e:
        return {**out, "outcome": "refused", "why": str(e)}
    except Exception as e:  # noqa: BLE001 - a crash is what this benchmark looks for
        return {**out, "outcome": "crash", "why": f"{e!r}: {traceback.format_exc(limit=-3)}"}
    books = {vid: seat.driver.vehicle.treatments for vid, seat in result.backend.seats.items()
             if seat.driver is not None}
    world = world_tally(reef, books)
    fleet = result.report.to_dict()["fleet"]
    return {**out, "outcome": "ran", "priority": world["priority"],
            "duplicates": world["duplicates"], "false_alarms": fleet["false_alarms"]}


def _lossy(row: dict[str, Any]) -> bool:
    return any(f.startswith("loss") for f in row["faults"])


def main(first: int, last: int, jobs: int) -> None:
    t0 = time.perf_counter()
    with ProcessPoolExecutor(jobs) as pool:
        rows = list(pool.map(one, range(first, last)))
    left = psutil.Process().children(recursive=True)  # the pool's workers, ended by now
    ran = [r for r in rows if r["outcome"] == "ran"]
    refused = [r for r in rows if r["outcome"] == "refused"]
    crashed = [r for r in rows if r["outcome"] == "crash"]
    duplicated = [r for r in ran if r["duplicates"]]
    alarmed = [r for r in ran if r["false_alarms"]]
    for r in crashed:
        print(f"crash: seed {r['seed']}: {r['why']}", flush=True)
    misses = [f"seed {r['seed']} crashed: {r['why'].splitlines()[0]}" for r in crashed]
    misses += [f"seed {r['seed']} ({r['reef']}, {', '.join(r['faults'])}, drift {r['drift']} %, "
               f"fixes {r['fixes']}, loss {r['loss']}): {r['duplicates']} duplicate(s)"
               for r in duplicated]
    summary: list[list[object]] = [
        ["missions drawn", len(rows)], ["refused with FaultError (not run)", len(refused)],
        ["ran", len(ran)], ["crashed (target 0)", len(crashed)],
        ["with a duplicate (target 0)", f"{len(duplicated)} "
         f"({sum(r['duplicates'] for r in duplicated)} duplicate treatments in all)"],
        ["with a false alarm", f"{len(alarmed)} ({sum(r['false_alarms'] for r in alarmed)} "
         f"in all; {sum(1 for r in alarmed if _lossy(r))} of them with a loss fault)"],
        ["processes left after the pool", len(left)]]
    listed = duplicated + alarmed
    detail = [[r["seed"], r["reef"], ", ".join(r["faults"]), r["drift"], r["fixes"] or "-",
               r["loss"], round(r["priority"]), r["duplicates"], r["false_alarms"]]
              for r in sorted({r["seed"]: r for r in listed}.values(), key=lambda r: r["seed"])]
    wall = time.perf_counter() - t0
    body = (f"Seeds {first}..{last - 1}, {jobs} worker process(es), {wall:.0f} s wall. "
            "`python -m benchmarks.fault_fuzz --seeds A:B` replays any of them.\n\n"
            + markdown_table(["figure", "value"], summary)
            + ("\n\nThe missions with a duplicate or a false alarm:\n\n"
               + markdown_table(["seed", "reef", "faults", "drift %", "fix every s", "loss",
                                 "priority", "duplicates", "false alarms"], detail)
               if detail else "")
            + "\n\n" + misses_block(misses))
    print(json.dumps({"ran": len(ran), "refused": len(refused), "crashed": len(crashed),
                      "duplicated": len(duplicated), "alarmed": len(alarmed)}), flush=True)
    write_section("fault_fuzz", "Random faults under drift and loss (in process)", body)
    print_misses(misses)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0:240", help="first:last (last excluded)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--quick", action="store_true", help="six seeds")
    args = ap.parse_args()
    a, b = (0, 6) if args.quick else tuple(int(x) for x in args.seeds.split(":"))
    main(a, b, args.jobs)
