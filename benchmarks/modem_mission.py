"""A mission on emulated Micro-Modems against the same mission on the default water.

    python -m benchmarks.modem_mission [--seed N] [--warp W] [--rate R] [--quick]

The paper preset drawn with ``--seed`` (3 AUVs, 90 spots, 3600 s battery), flown twice by
`cotsfleet run` at the same warp: on the default water (the Zenoh relay, 64-byte frames,
slot 2.5 s) and with ``--modem micromodem`` (each agent's NMEA driver on its emulated
Micro-Modem over TCP, the slot derived from the modem's packet,
`cotsfleet.mission.modem_launch.micromodem_slot_s`). Recorded: priority and its share of the
water's, duplicates, vehicles home, frames sent and delivered and what was dropped, wall
time, and CPU: the water's process (the relay or the emulated modems) per frame delivered,
and every process of the mission per frame delivered (agents, water, router), whose
difference between the two runs is what the NMEA path costs. `benchmarks.modem_bench`
adds the NMEA path alone (two drivers, their sockets and the water in one process).
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from typing import Any

from benchmarks import modem_bench
from benchmarks.helms import run_measured
from benchmarks.results import markdown_table, write_section
from cotsfleet.commands.mission_args import scenario_doc
from cotsfleet.mission.modem_launch import micromodem_slot_s
from fleet_agent.config import AgentConfig
from fleet_agent.modems.micromodem import micromodem_spec
from hfc_core.formats.scenario import problem_from_dict

DROPS = ("half_duplex", "collision", "range", "sinr", "random", "partition")


def row(label: str, report: dict[str, Any], wall: float, cpu: dict[str, float],
        water: str, reference: float) -> tuple[list[Any], dict[str, float]]:
    f, link = report["fleet"], report["messages"]["link"]
    delivered = max(1, link["delivered"])
    total_cpu = sum(cpu.values())
    water_cpu = cpu.get(water, 0.0)
    drops = {k: link[k] for k in DROPS if link.get(k)}
    g = {"water_us": 1e6 * water_cpu / delivered, "all_us": 1e6 * total_cpu / delivered,
         "priority": f["priority"]}
    return [label, report["modem"]["slot_s"], round(f["priority"], 1),
            f"{f['priority'] / reference:.3f}", f["duplicate_treatments"], f["vehicles_home"],
            report["messages"]["frames_sent"], link["delivered"], drops or "-", f"{wall:.0f}",
            f"{water_cpu:.1f}", f"{g['water_us']:.0f}", f"{total_cpu:.1f}",
            f"{g['all_us']:.0f}"], g


def main(seed: int, warp: float, rate: int, write: bool) -> None:
    doc = scenario_doc(None, None, seed)
    problem = problem_from_dict(doc)
    slot = micromodem_slot_s(micromodem_spec(rate), problem)
    water, wall_w, cpu_w = run_measured(doc, seed, warp=warp)
    ref = water["fleet"]["priority"]
    r1, g1 = row("water (relay)", water, wall_w, cpu_w, "relay", ref)
    print(f"water: {r1}", flush=True)
    mm, wall_m, cpu_m = run_measured(doc, seed, warp=warp, modem="micromodem", modem_rate=rate,
                                     agent_config=replace(AgentConfig(), slot_s=slot),
                                     slot_from_modem=True)
    r2, g2 = row(f"micromodem rate {rate}", mm, wall_m, cpu_m, "water", ref)
    print(f"micromodem: {r2}", flush=True)
    bench = modem_bench.main(200, 1000.0)
    table = markdown_table(
        ["water", "slot s", "priority", "of water's", "duplicates", "home", "frames sent",
         "receptions delivered", "dropped", "wall s", "water CPU s", "water CPU us / frame",
         "mission CPU s", "mission CPU us / frame"], [r1, r2])
    extra = g2["all_us"] - g1["all_us"]
    body = (f"Paper preset drawn with seed {seed} (3 AUVs, 90 spots, 3600 s battery), "
            f"`cotsfleet run` at warp {warp:g}, no faults, default agent settings but the slot: "
            f"the Micro-Modem mission's is derived from a rate-{rate} packet across the "
            f"scenario ({slot:g} s; the relay's 2.5 s). CPU per frame is per reception "
            f"delivered (a frame heard by two peers counts twice); the water's process is the "
            f"relay, or the emulated modems (`cotsfleet water --face micromodem`); the mission's "
            f"is every process (agents, water, router).\n\n{table}\n\n"
            f"The NMEA path costs {extra:.0f} us of CPU more per delivered frame across the "
            f"whole mission ({g2['all_us']:.0f} against {g1['all_us']:.0f}); the water's own "
            f"share: {g2['water_us']:.0f} against {g1['water_us']:.0f} us. The NMEA path alone "
            f"(`benchmarks.modem_bench`: two drivers, their TCP sockets and the emulated "
            f"modems in one process, {bench['packets']} full rate-1 packets): "
            f"{bench['cpu_us_per_frame']:.0f} us CPU per frame delivered, "
            f"{bench['wall_ms_per_packet']:.1f} ms wall per packet at warp 1000.\n")
    if write:
        write_section("modem_mission", "Modems: a mission on emulated WHOI Micro-Modems", body)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--warp", type=float, default=30.0)
    parser.add_argument("--rate", type=int, default=1)
    parser.add_argument("--quick", action="store_true", help="RESULTS.md left alone")
    args = parser.parse_args()
    main(args.seed, args.warp, args.rate, write=not args.quick)
