"""Sweeps (`cotsfleet sim --runs N`): one process, local workers and Dask side by side; a
1,000-run sweep on a local Dask cluster; memory per simulated vehicle.

``python -m benchmarks.sweep_bench [--quick] [--reps 3] [--big-runs 1000] [--no-write]``

1. ``cotsfleet sim --runs 6`` (paper preset, seeds 0-5) with ``--jobs 1``, ``--jobs 2`` and
   ``--scheduler --jobs 2`` (a local Dask cluster of 2 workers), interleaved ``reps`` times;
   the median wall time of the whole command (what a user waits for: start-up, the runs,
   sweep.md) and of the sweep alone, the ratio to ``--jobs 1`` (target: ``--jobs 2`` at most
   0.65), and whether every sweep.md is byte-identical to ``--jobs 1``'s but for its wall
   times (`cotsfleet.reporting.sweep.machine_free`).
2. ``cotsfleet sim --runs 1000 --scheduler --jobs 2``: the paper preset (3 AUVs, 90 spots,
   3600 s batteries, drawn anew per seed), seeds 0-999, no fault: wall time, runs per minute,
   failures, and the cluster's efficiency (sum of the runs' own wall times over workers x
   sweep wall time: what the scheduling and the start-up cost).
3. Peak RSS of a fresh process simulating one mission (as a worker does), minus its RSS once
   the simulator is imported, per simulated vehicle: the paper preset and two large areas
   (the 24-AUV one is reported as failed while the wire format carries at most 8).

Run it on an otherwise idle machine: it measures wall time and needs both cores.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.results import markdown_table, write_section

REPO = Path(__file__).resolve().parents[1]
MODES = [("--jobs 1", ["--jobs", "1"]), ("--jobs 2", ["--jobs", "2"]),
         ("--scheduler --jobs 2 (local Dask)", ["--scheduler", "--jobs", "2"])]
TARGET_RATIO = 0.65
WORKER_RUNS = 30  # seeds one worker runs in a row for the growth figure
SWEEP_LINE = re.compile(r"(\d+) of (\d+) run\(s\) in ([0-9.]+) s wall on (.+)")
# (label, `cotsfleet scenario` arguments or None for the paper preset, full run only)
MEMORY_SCENARIOS = [
    ("paper preset (3 AUVs, 90 spots, 1 km, 3600 s)", None, False),
    ("area 8 AUVs, 200 spots, 2 km, 3600 s", ["--vehicles", "8", "--spots", "200",
                                              "--area-m", "2000", "--battery-s", "3600"], False),
    ("area 24 AUVs, 600 spots, 3 km, 7200 s", ["--vehicles", "24", "--spots", "600",
                                               "--area-m", "3000", "--battery-s", "7200"], True),
]


def cotsfleet(*argv: str) -> subprocess.CompletedProcess:
    proc = subprocess.run([sys.executable, "-m", "cotsfleet", *argv], cwd=REPO,
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"cotsfleet {' '.join(argv)} failed ({proc.returncode}):\n"
                           f"{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")
    return proc


def timed_sweep(argv: list[str], out: Path) -> dict:
    """One ``cotsfleet sim`` sweep: the command's wall time, the sweep's (as it prints it),
    its sweep.md and its runs."""
    # Here, not at the top: the memory probe runs this module in a fresh process, and the
    # reporting package brings matplotlib (30 MB) that a sweep's run never loads.
    from cotsfleet.reporting.sweep import machine_free

    t0 = time.perf_counter()
    proc = cotsfleet("sim", *argv, "--out", str(out))
    wall = time.perf_counter() - t0
    match = SWEEP_LINE.search(proc.stdout)
    assert match, proc.stdout[-1000:]
    return {"wall_s": wall, "sweep_s": float(match.group(3)), "where": match.group(4),
            # the summary but for its wall times, which depend on the machine
            "md": machine_free((out / "sweep.md").read_text()),
            "runs": json.loads((out / "sweep.json").read_text())}


def jobs_side_by_side(tmp: Path, reps: int) -> tuple[str, list]:
    """Section 1: the same 6-run sweep under each mode, interleaved ``reps`` times."""
    walls: dict[str, list[float]] = {m: [] for m, _ in MODES}
    sweeps: dict[str, list[float]] = {m: [] for m, _ in MODES}
    mds: dict[str, set[str]] = {m: set() for m, _ in MODES}
    for rep in range(reps):
        for i, (mode, extra) in enumerate(MODES):
            r = timed_sweep(["--runs", "6", *extra], tmp / f"six-{rep}-{i}")
            walls[mode].append(r["wall_s"])
            sweeps[mode].append(r["sweep_s"])
            mds[mode].add(r["md"])
            print(f"rep {rep}: {mode}: {r['wall_s']:.2f} s (sweep {r['sweep_s']:.2f} s)",
                  flush=True)
    base = statistics.median(walls["--jobs 1"])
    reference = next(iter(mds["--jobs 1"]))
    rows = []
    for mode, _ in MODES:
        med = statistics.median(walls[mode])
        rows.append([f"`cotsfleet sim --runs 6 {mode.split(' (')[0]}`", f"{med:.2f}",
                     f"{min(walls[mode]):.2f} - {max(walls[mode]):.2f}",
                     f"{statistics.median(sweeps[mode]):.2f}", f"{med / base:.2f}",
                     "yes" if mds[mode] == {reference} else "NO"])
    ratio = statistics.median(walls["--jobs 2"]) / base
    verdict = "met" if ratio <= TARGET_RATIO else "NOT met"
    table = markdown_table(["command", "wall s (median)", "min - max", "sweep alone s",
                            "ratio to --jobs 1",
                            "sweep.md identical to --jobs 1 (but for wall times)"], rows)
    body = (f"Paper preset, seeds 0-5, no fault, {reps} repetition(s) interleaved. Wall time of "
            "the whole command (Python start-up, imports, the runs, sweep.json and sweep.md); "
            "'sweep alone' is what the command prints for the runs. Target: `--jobs 2` at most "
            f"{TARGET_RATIO} of `--jobs 1`: **{verdict}** ({ratio:.2f}).\n\n{table}\n")
    return body, rows


def thousand_runs(tmp: Path, runs: int) -> str:
    """Section 2: a large sweep on a local Dask cluster of 2 workers."""
    r = timed_sweep(["--runs", str(runs), "--scheduler", "--jobs", "2"], tmp / "big")
    ok = [x for x in r["runs"] if "error" not in x]
    busy = sum(x["run_s"] for x in r["runs"])
    per_run = statistics.median(x["run_s"] for x in ok) if ok else float("nan")
    table = markdown_table(
        ["runs", "failed", "command wall s", "sweep wall s", "runs per minute",
         "median run s", "cluster efficiency"],
        [[runs, runs - len(ok), f"{r['wall_s']:.0f}", f"{r['sweep_s']:.0f}",
          f"{60 * runs / r['sweep_s']:.1f}", f"{per_run:.2f}",
          f"{busy / (2 * r['sweep_s']):.2f}"]])
    return (f"`cotsfleet sim --runs {runs} --scheduler --jobs 2`: the paper preset (3 AUVs, "
            f"90 spots, 1 km, 3600 s batteries, drawn anew for each seed), seeds 0-{runs - 1}, "
            f"no fault, on {r['where']}. Cluster efficiency: the runs' own wall times summed, "
            "over 2 workers x the sweep's wall time (1.00: no time lost to start-up, "
            "scheduling or transfers); a run's time (`run_s` in sweep.json) is the whole run in "
            f"its worker: scenario, every agent's initial plan, the mission.\n\n{table}\n")


def probe(scenario: str, runs: int = 1) -> None:
    """(Run in a fresh process.) Simulate seeds 0..``runs``-1 of ``scenario`` (a file, or
    ``paper``) one after another as a sweep worker does and print as JSON the RSS before, the
    peak after the first run and the peak after the last."""
    import resource

    import cotsfleet.mission.inprocess  # noqa: F401 - the simulator loaded: the baseline
    from cotsfleet.sweep import SweepSpec, run_seed
    from fleet_agent.config import AgentConfig

    def peak_mb() -> float:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024

    doc = None if scenario == "paper" else json.loads(Path(scenario).read_text())
    spec = SweepSpec(doc, None, 0.0, AgentConfig(), ())
    base = peak_mb()
    result = run_seed(spec, 0).to_dict()
    first = peak_mb()
    for seed in range(1, runs):
        run_seed(spec, seed)
    vehicles = len(result["vehicles"]) if "vehicles" in result else 3
    print(json.dumps({"base_mb": base, "peak_mb": first, "last_peak_mb": peak_mb(),
                      "runs": runs, "vehicles": vehicles, "run_s": result["run_s"],
                      "error": result.get("error")}))


def worker_growth(runs: int) -> str:
    """Section 3, second part: does a worker's footprint stay one mission's over many runs?"""
    out = subprocess.run([sys.executable, "-m", "benchmarks.sweep_bench", "--probe", "paper",
                          "--probe-runs", str(runs)],
                         cwd=REPO, capture_output=True, text=True, check=True).stdout
    m = json.loads(out.strip().splitlines()[-1])
    return (f"One worker running {runs} seeds of the paper preset one after another (as a "
            f"sweep's worker does): peak RSS {m['peak_mb']:.0f} MB after the first run, "
            f"{m['last_peak_mb']:.0f} MB after the last (each mission's garbage is collected "
            "before the next is frozen out of the collector's sight: `cotsfleet.mission."
            "inprocess.simulate`).\n")


def memory(tmp: Path, quick: bool) -> str:
    """Section 3: peak RSS per simulated vehicle."""
    rows = []
    for label, args, full_only in MEMORY_SCENARIOS:
        if quick and (full_only or args is not None):
            continue
        target = "paper"
        if args is not None:
            target = str(tmp / f"{len(rows)}.json")
            cotsfleet("scenario", *args, "--seed", "0", "-o", target)
        out = subprocess.run([sys.executable, "-m", "benchmarks.sweep_bench", "--probe", target],
                             cwd=REPO, capture_output=True, text=True, check=True).stdout
        m = json.loads(out.strip().splitlines()[-1])
        if m["error"] is not None:  # e.g. more vehicles than the wire format carries yet
            rows.append([label, f"failed: {m['error']}", "-", "-", "-"])
        else:
            rows.append([label, f"{m['run_s']:.1f}", f"{m['base_mb']:.0f}",
                         f"{m['peak_mb']:.0f}",
                         f"{(m['peak_mb'] - m['base_mb']) / m['vehicles']:.1f}"])
        print(" | ".join(rows[-1]), flush=True)
    table = markdown_table(["mission (seed 0, no fault)", "run s", "RSS with the "
                            "simulator loaded, MB", "peak RSS, MB", "MB per simulated vehicle "
                            "(peak - loaded) / vehicles"], rows)
    return ("Peak RSS (`ru_maxrss`) of a fresh process that simulates one mission in-process "
            "the way a sweep worker does (`cotsfleet.sweep.run_seed`). A worker of a sweep "
            "holds one mission at a time, so this is its footprint.\n\n" + table + "\n")


def main(reps: int, big_runs: int, quick: bool, write: bool) -> None:
    with tempfile.TemporaryDirectory(prefix="sweep_bench-") as tmpdir:
        tmp = Path(tmpdir)
        t0 = time.perf_counter()
        side, _ = jobs_side_by_side(tmp, reps)
        print(side, flush=True)
        big = thousand_runs(tmp, big_runs)
        print(big, flush=True)
        mem = memory(tmp, quick) + "\n" + worker_growth(5 if quick else WORKER_RUNS)
        print(mem, flush=True)
        total = time.perf_counter() - t0
    body = (f"### `--jobs` and Dask beside one process\n\n{side}\n"
            f"### A {big_runs}-run sweep on a local Dask cluster\n\n{big}\n"
            f"### Memory per simulated vehicle\n\n{mem}\n"
            f"Total {total:.0f} s wall. Rerun: `python -m benchmarks.sweep_bench`.\n")
    if write and not quick:
        write_section("sweep_bench", "Sweeps: local workers, Dask, memory", body)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=3, help="repetitions of section 1")
    parser.add_argument("--big-runs", type=int, default=1000, help="runs of section 2")
    parser.add_argument("--quick", action="store_true",
                        help="1 repetition, a 20-run section 2, the paper preset's memory "
                             "only; RESULTS.md untouched")
    parser.add_argument("--no-write", action="store_true", help="print, leave RESULTS.md")
    parser.add_argument("--probe", help=argparse.SUPPRESS)
    parser.add_argument("--probe-runs", type=int, default=1, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.probe:
        probe(args.probe, args.probe_runs)
    else:
        main(1 if args.quick else args.reps, 20 if args.quick else args.big_runs, args.quick,
             not args.no_write)
