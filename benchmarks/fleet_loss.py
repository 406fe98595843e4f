"""Fleet behaviour under extra link loss and a vehicle abort (in-process, many seeds).

``python -m benchmarks.fleet_loss [--quick] [--runs N]``

For each condition, ``runs`` missions of the paper preset (each seed draws its own scenario)
on the deterministic transport: spots cleared, priority collected, duplicate treatments,
detection delay of the lost vehicle (abort and kill rows), false alarms, radio bytes per
vehicle per minute.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

from benchmarks.results import markdown_table, write_section
from cotsfleet.commands.mission_args import scenario_doc
from cotsfleet.mission.faults import Fault
from cotsfleet.mission.inprocess import simulate
from fleet_agent.config import AgentConfig
from hfc_core.formats.scenario import problem_from_dict

CONDITIONS = [
    ("loss 0 %", 0.0, ()),
    ("loss 10 %", 0.1, ()),
    ("loss 30 %", 0.3, ()),
    ("loss 50 %", 0.5, ()),
    ("abort auv2 @ 1200 s", 0.0, (Fault("abort", 1200.0, "auv2"),)),
    ("abort auv2 @ 1200 s, loss 30 %", 0.3, (Fault("abort", 1200.0, "auv2"),)),
    ("kill auv2 @ 1200 s (silent)", 0.0, (Fault("kill", 1200.0, "auv2"),)),
    ("kill auv2 @ 1200 s, loss 30 %", 0.3, (Fault("kill", 1200.0, "auv2"),)),
]


def _mean(xs: list[float]) -> float:
    xs = [x for x in xs if x == x]
    return statistics.fmean(xs) if xs else math.nan


def main(runs: int, quick: bool) -> None:
    config = AgentConfig()
    cycle = config.slot_s * 3
    rows = []
    t0 = time.perf_counter()
    for name, loss, faults in CONDITIONS:
        cleared, prio, dups, treated, delays, worst, false, bpm, oracle = ([] for _ in range(9))
        for seed in range(runs):
            problem = problem_from_dict(scenario_doc(None, None, seed))
            r = simulate(problem, config, seed=seed, loss=loss, faults=faults).report.to_dict()
            f = r["fleet"]
            cleared.append(f["spots_cleared"])
            prio.append(f["priority"])
            dups.append(f["duplicate_treatments"])
            treated.append(f["treatments"])
            d = [x for row in f["detection_delay_s"].values() for x in row.values()]
            delays += [x for x in d if x is not None]
            worst.append(max((x for x in d if x is not None), default=math.nan)
                         if d and None not in d else (math.inf if d else math.nan))
            false.append(f["false_alarms"])
            bpm.append(r["messages"]["bytes_per_vehicle_minute"])
            if "oracle" in r:
                oracle.append(r["oracle"]["ratio"])
        rows.append([name, runs, round(_mean(cleared), 1), round(_mean(prio), 0),
                     sum(dups), f"{100 * sum(dups) / max(1, sum(treated)):.2f}",
                     f"{_mean(delays):.1f}" if delays else "-",
                     f"{max(worst):.1f}" if any(w == w for w in worst) else "-",
                     round(_mean(false), 2), round(_mean(bpm), 0),
                     f"{_mean(oracle):.3f} (min {min(oracle):.3f})" if oracle else "-"])
        print(" | ".join(str(c) for c in rows[-1]), flush=True)
    table = markdown_table(
        ["condition", "runs", "spots cleared", "priority", "duplicates", "dup % of treated",
         "detection mean s", "detection worst s", "false alarms/run", "B/vehicle/min",
         "vs perfect-info replan"], rows)
    body = ("In-process simulation (`cotsfleet.mission.inprocess`), paper preset drawn with "
            f"seeds 0..{runs - 1}"
            f" (one scenario per seed), default agent and channel (psk_1k) settings; extra loss "
            f"is uniform on top of the range model. Heartbeat period = TDMA cycle = "
            f"{cycle:g} s; detection target 5 periods = {5 * cycle:g} s. Detection: from the "
            f"fault to each survivor's 'lost' event. Last column (kill rows): priority the "
            f"survivors collected after the kill over what a centralized replan with perfect "
            f"information at the kill time plans (`hfc_core.replan`). Total "
            f"{time.perf_counter() - t0:.0f} s wall.\n\n{table}\n")
    print(table)
    if not quick:
        write_section("fleet_loss", "fleet_agent: extra loss and vehicle loss", body)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--quick", action="store_true", help="3 runs, no RESULTS.md update")
    args = parser.parse_args()
    main(3 if args.quick else args.runs, args.quick)
