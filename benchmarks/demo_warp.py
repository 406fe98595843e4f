"""`make demo`'s mission as real processes at several warps, against the in-process run.

The demo (`cotsfleet scenario --paper --dynamic --seed 0`, `--abort auv2@1200`) replans far
more than the static preset: every find, every empty spot and the abort's takeover run the
planner in the agent's one thread (0.2-0.4 s of CPU each on an idle core). At warp W a burst
of b wall seconds is b x W mission seconds of silence from that vehicle; past the suspicion
window (4 cycles, 30 s for 3 AUVs) a peer suspects it and a watcher confirms, which is a false
alarm. This benchmark measures that, with the ground station logging to a web viewer as in
the demo (`--viewer web --no-hold-viewer`), on an otherwise idle machine: priority and
duplicates against the in-process simulation, false alarms, the worst host lag and how many
frames left a host after their slot. Every process is checked gone after each run
(`fleet_silence.run_mission_processes`). Figures go to `benchmarks/RESULTS.md` (`demo_warp`).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
import time
from pathlib import Path

from benchmarks.fleet_silence import cotsfleet_argv, run_mission_processes
from benchmarks.results import markdown_table, misses_block, print_misses, write_section

SEED = 0
ABORT = "auv2@1200"
WARPS = (30.0, 60.0, 120.0)


def in_process(scenario: Path, workdir: Path) -> dict:
    """The same mission in one process (`cotsfleet sim`): the reference."""
    report = workdir / "inprocess.json"
    subprocess.run(cotsfleet_argv("sim", "--scenario", str(scenario), "--seed", str(SEED),
                                  "--abort", ABORT, "--report", str(report)),
                   check=True, stdout=subprocess.DEVNULL)
    return json.loads(report.read_text())


def row(warp: float, res: dict, ref: dict) -> tuple[list, list[str]]:
    r = res["report"]
    if r is None:
        return ([f"{warp:g}", "failed", "-", "-", "-", "-", "-", "-", len(res["leftovers"])],
                [f"warp {warp:g}: no report (rc {res['rc']}, log {res['log']})"])
    f, clock = r["fleet"], r.get("clock") or {}
    misses = []
    if f["false_alarms"]:
        misses.append(f"warp {warp:g}: {f['false_alarms']} false alarm(s)")
    if f["duplicate_treatments"]:
        misses.append(f"warp {warp:g}: {f['duplicate_treatments']} duplicate(s)")
    if res["leftovers"]:
        misses.append(f"warp {warp:g}: {len(res['leftovers'])} process(es) left")
    return ([f"{warp:g}", f"{res['wall_s']:.0f}",
             f"{f['priority']:.0f} / {ref['fleet']['priority']:.0f}",
             f"{f['priority'] / ref['fleet']['priority']:.3f}",
             f"{f['duplicate_treatments']} / {ref['fleet']['duplicate_treatments']}",
             f"{f['false_alarms']} / {ref['fleet']['false_alarms']}",
             f"{clock.get('max_lag_s', float('nan')):.1f} "
             f"({clock.get('max_lag_s', float('nan')) / warp:.2f})",
             clock.get("slots_late", "-"), len(res["leftovers"])], misses)


def main(warps: tuple[float, ...], write: bool) -> int:
    t0 = time.perf_counter()
    rows, misses, spawned = [], [], 0
    with tempfile.TemporaryDirectory(prefix="demo_warp-") as tmp:
        work = Path(tmp)
        scenario = work / "demo.json"
        subprocess.run(cotsfleet_argv("scenario", "--paper", "--dynamic", "--seed", str(SEED),
                                      "-o", str(scenario)), check=True, stdout=subprocess.DEVNULL)
        ref = in_process(scenario, work)
        for warp in warps:
            res = run_mission_processes(SEED, warp, work, viewer="web",
                                        extra=("--scenario", str(scenario), "--abort", ABORT),
                                        tag=f"demo-w{warp:g}")
            spawned += res["spawned"]
            cells, missed = row(warp, res, ref)
            rows.append(cells)
            misses += missed
            print(" | ".join(str(c) for c in cells), flush=True)
    table = markdown_table(
        ["warp", "wall s", "priority multi / in-process", "ratio",
         "duplicates multi / in-process", "false alarms multi / in-process",
         "max host lag, mission s (wall s)", "frames sent after their slot",
         "processes left"], rows)
    print(table)
    print_misses(misses)
    if write:
        body = (
            f"`make demo`'s mission as real processes: `cotsfleet scenario --paper --dynamic "
            f"--seed {SEED}`, `cotsfleet run --abort {ABORT} --viewer web --no-hold-viewer "
            f"--warp W` (router, link emulator, 3 agent processes, the ground station and its "
            f"web viewer), one run per warp on an otherwise idle machine, against the "
            f"in-process `cotsfleet sim` of the same mission. Targets (the rule that "
            f"correctness never depends on the machine keeping up with the warp): 0 false "
            f"alarms, 0 duplicates, nothing left. Max host lag: the worst lateness of an "
            f"agent's step (report `clock`), in mission seconds and in wall seconds. "
            f"{spawned} processes started, {time.perf_counter() - t0:.0f} s wall.\n\n"
            f"{table}\n\n" + misses_block(misses))
        write_section("demo_warp", "make demo at several warps: bursts of planning", body)
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--warps", default=",".join(f"{w:g}" for w in WARPS),
                        help="warps to run (default 30,60,120)")
    parser.add_argument("--quick", action="store_true",
                        help="warp 60 only, no RESULTS.md update")
    args = parser.parse_args()
    raise SystemExit(main((60.0,) if args.quick else
                          tuple(float(w) for w in args.warps.split(",")), not args.quick))
