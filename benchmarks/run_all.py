"""Run every benchmark one after another (`make bench`); each rewrites its RESULTS.md section.

Run them on an otherwise idle machine: they measure wall time. Solvers compared side by side
get one pinned core each (`benchmarks.pinned`), so `--jobs 2` uses both cores of a 2-core box.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time

# (module, arguments): planner first, then the link, then the fleet that uses both.
BENCHMARKS: list[tuple[str, list[str]]] = [
    ("benchmarks.paper_table", []),
    ("benchmarks.paper_montecarlo", []),
    ("benchmarks.top_faithful", []),
    ("benchmarks.top_bench", ["--jobs", "2"]),
    ("benchmarks.paper_best", ["--jobs", "2"]),
    ("benchmarks.planner_speed", []),
    ("benchmarks.planner_scale", []),
    ("benchmarks.upper_bound", []),
    ("benchmarks.currents", []),
    ("benchmarks.channel_physics", []),
    ("benchmarks.relay_bench", []),
    ("benchmarks.fleet_mission", []),
    ("benchmarks.fleet_loss", []),
    ("benchmarks.fleet_silence", []),
    ("benchmarks.demo_warp", []),
    ("benchmarks.fleet_scale", []),
    ("benchmarks.security", []),
    ("benchmarks.insider_attacks", []),
    ("benchmarks.crash_table", []),
    ("benchmarks.startup_scale", []),
    ("benchmarks.modem_mission", []),
    ("benchmarks.helms", []),
    ("benchmarks.dynamic", ["--jobs", "2"]),
    ("benchmarks.search_value", ["--jobs", "2"]),
    ("benchmarks.dynamic_budget", ["--jobs", "2"]),
    ("benchmarks.fault_fuzz", ["--jobs", "2"]),
    ("benchmarks.sweep_bench", []),
    ("benchmarks.dashboard_bench", []),
]


def main(only: list[str], quick: bool) -> int:
    failed = []
    for module, args in BENCHMARKS:
        if only and module.rsplit(".", 1)[-1] not in only:
            continue
        argv = [sys.executable, "-m", module, *args, *(["--quick"] if quick else [])]
        print(f"== {' '.join(argv[2:])}", flush=True)
        t0 = time.monotonic()
        if subprocess.run(argv).returncode != 0:
            failed.append(module)
        print(f"== {module}: {time.monotonic() - t0:.0f} s", flush=True)
    if failed:
        print(f"failed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("only", nargs="*", help="benchmark names to run (default: all)")
    parser.add_argument("--quick", action="store_true", help="smoke runs; most write nothing")
    args = parser.parse_args()
    raise SystemExit(main(args.only, args.quick))
