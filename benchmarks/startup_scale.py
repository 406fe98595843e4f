"""How `cotsfleet run`'s start-up grows with the fleet: the figures behind the default
start-up timeout (`cotsfleet.mission.processes.startup_timeout_for`).

``python -m benchmarks.startup_scale [--sizes 3,6,12,24] [--seed N]``

For each fleet size, the paper preset with that many vehicles as real processes on this
machine: wall seconds from launching `cotsfleet run` to its "mission ..." line (router, relay
and every agent started, every agent's initial plan computed and announced: the clock
starts), then Ctrl-C. One run per size: the machine is shared, read the figures as a trend.
"""

from __future__ import annotations

import argparse
import signal
import subprocess
import sys
import tempfile
import time

from benchmarks.results import markdown_table, write_section

LIMIT_S = 1200.0


def startup_s(vehicles: int, seed: int) -> float | None:
    """Seconds from launch to the clock's start, or None if it never started."""
    with tempfile.TemporaryDirectory() as tmp:
        proc = subprocess.Popen(
            [sys.executable, "-m", "cotsfleet", "run", "--vehicles", str(vehicles), "--seed",
             str(seed), "--viewer", "none", "--warp", "60", "--run-dir", f"{tmp}/run",
             "--startup-timeout", str(LIMIT_S)],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        t0, took = time.monotonic(), None
        try:
            assert proc.stdout is not None
            for line in proc.stdout:
                if line.startswith("mission "):
                    took = time.monotonic() - t0
                    break
        finally:
            proc.send_signal(signal.SIGINT)
            try:
                proc.communicate(timeout=120)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.communicate()
        return took


def main(sizes: list[int], seed: int) -> None:
    rows = []
    for n in sizes:
        took = startup_s(n, seed)
        print(f"{n} vehicles: start-up {took if took is None else round(took, 1)} s", flush=True)
        rows.append([n, "never" if took is None else round(took, 1),
                     "" if took is None else round(took / n, 2)])
    write_section("startup_scale", "Start-up time against fleet size (`cotsfleet run`)",
                  markdown_table(["vehicles", "start-up (s)", "per vehicle (s)"], rows)
                  + "\n\nLaunch to the clock's start (every agent planned and announced), "
                  "paper preset, one run per size, warp 60.")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="3,6,12,24")
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    main([int(s) for s in args.sizes.split(",")], args.seed)
