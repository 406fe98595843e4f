"""Silence is not death (issue 11): the fleet against its no-communication baseline.

``python -m benchmarks.fleet_silence [--quick] [--runs N] [--warps 60,120,240] [--mp-seeds 0,1]``

Part A, in-process (`cotsfleet.mission.inprocess`, deterministic transport): for each extra
link loss in 0, 30, 50, 70, 90 and 100 %, ``runs`` missions of the paper preset (each seed draws
its own scenario), the priority collected over the report's no-communication baseline (each
vehicle flies its initial plan), runs below that baseline, duplicate treatments, false "lost"
alarms and suspicions (a silent peer that nobody has confirmed yet) per run; then a 400 s
partition of auv1 that heals, and a silent kill of auv2 (survivors' priority over a
perfect-information replan at the kill, detection delays). Targets: never below the baseline,
duplicates at most 1 % of treatments at every loss and none at 30 %.

Part B, multi-process: ``cotsfleet run --viewer none`` (router, link emulator, one agent
process per AUV) of the one-hour paper preset at warp 60, 120 and 240 while two CPU hogs keep
both cores of the machine busy, against the in-process run of the same seed; then at warp 100
with auv1's host stalled too (`STALL`: frozen half of every 8 s for 300 s), against the
in-process run with the same stall. Targets: priority
within 2 % of the in-process run, no duplicate, all vehicles home, no false alarm, the
effective warp reported (``report["clock"]``). Every process the benchmark starts (hogs and the
mission's processes) is checked gone at the end.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import psutil

from benchmarks.results import markdown_table, misses_block, print_misses, write_section
from cotsfleet.commands.mission_args import scenario_doc
from cotsfleet.mission.faults import Fault
from cotsfleet.mission.inprocess import simulate
from fleet_agent.config import AgentConfig
from hfc_core.formats.scenario import problem_from_dict

LOSSES = (0.0, 0.3, 0.5, 0.7, 0.9, 1.0)
FAULT_ROWS = [
    ("partition auv1 @ 1000 s for 400 s", (Fault("partition", 1000.0, "auv1", 400.0),)),
    ("kill auv2 @ 1200 s (silent)", (Fault("kill", 1200.0, "auv2"),)),
]
DUP_TARGET = 0.01  # duplicates at most 1 % of treatments at every loss
MP_PRIORITY_TOLERANCE = 0.02  # multi-process within 2 % of the in-process run
HOGS = 2
# A starved host on top of the hogs: auv1's agent frozen half of every 8 s for 300 s (the
# `stall` fault), at warp 100 where a frozen half outlasts half a TDMA slot before any slowdown.
STALL = Fault("stall", 300.0, "auv1", 300.0)
STALL_WARP = 100.0


def _median(xs: list[float]) -> float:
    xs = [x for x in xs if x == x]
    return statistics.median(xs) if xs else math.nan


def _f(x: float, fmt: str = ".3f") -> str:
    return "-" if x != x else format(x, fmt)


# --------------------------------------------------------------------------- Part A


def in_process_row(name: str, runs: int, loss: float, faults: tuple[Fault, ...],
                   config: AgentConfig) -> tuple[list[object], dict[str, Any]]:
    ratios, dups, treated, false, suspects, home, oracle, delays = ([] for _ in range(8))
    undetected = below = 0
    for seed in range(runs):
        problem = problem_from_dict(scenario_doc(None, None, seed))
        sim = simulate(problem, config, seed=seed, loss=loss, faults=faults)
        r = sim.report.to_dict()
        f, base = r["fleet"], r["baseline"]["priority"]
        ratios.append(f["priority"] / base if base > 0 else math.nan)
        below += f["priority"] < base - 1e-6
        dups.append(f["duplicate_treatments"])
        treated.append(f["treatments"])
        false.append(f["false_alarms"])
        suspects.append(sum(1 for e in sim.events if e.kind == "suspect"))
        home.append(f["vehicles_home"])
        for row in f["detection_delay_s"].values():
            for d in row.values():
                if d is None:
                    undetected += 1
                else:
                    delays.append(d)
        if "oracle" in r:
            oracle.append(r["oracle"]["ratio"])
    share = sum(dups) / max(1, sum(treated))
    row: list[object] = [
        name, runs, _f(_median(ratios)), _f(min(ratios)), below, sum(dups), f"{100 * share:.2f}",
        f"{statistics.fmean(false):.2f}", f"{statistics.fmean(suspects):.2f}",
        f"{statistics.fmean(home):.2f}",
        f"{_f(_median(oracle))} (min {_f(min(oracle))})" if oracle else "-",
        (f"{_f(_median(delays), '.0f')} / {_f(max(delays), '.0f')}"
         + (f", {undetected} never" if undetected else "")) if delays or undetected else "-",
    ]
    return row, {"below": below, "share": share, "dups": sum(dups)}


def part_a(runs: int, config: AgentConfig) -> tuple[str, list[str]]:
    rows, misses = [], []
    for loss in LOSSES:
        row, stats = in_process_row(f"loss {100 * loss:.0f} %", runs, loss, (), config)
        rows.append(row)
        print(" | ".join(str(c) for c in row), flush=True)
        if stats["below"]:
            misses.append(f"loss {100 * loss:.0f} %: {stats['below']} of {runs} runs below the "
                          f"no-communication baseline")
        if stats["share"] > DUP_TARGET:
            misses.append(f"loss {100 * loss:.0f} %: duplicates {100 * stats['share']:.2f} % "
                          f"of treatments (target <= 1 %)")
        if loss == 0.3 and stats["dups"]:
            misses.append(f"loss 30 %: {stats['dups']} duplicate(s) (target 0)")
    for name, faults in FAULT_ROWS:
        row, stats = in_process_row(name, runs, 0.0, faults, config)
        rows.append(row)
        print(" | ".join(str(c) for c in row), flush=True)
        if stats["dups"]:
            misses.append(f"{name}: {stats['dups']} duplicate(s) (target 0)")
        if faults[0].kind == "partition" and stats["below"]:
            misses.append(f"{name}: {stats['below']} of {runs} runs below the "
                          f"no-communication baseline")
    table = markdown_table(
        ["condition", "runs", "priority / baseline (median)", "min", "runs below baseline",
         "duplicates", "dup % of treated", "false alarms/run", "suspicions/run",
         "vehicles home (mean)", "kill: vs perfect-info replan (median, min)",
         "detection median / worst s"], rows)
    return table, misses


# --------------------------------------------------------------------------- Part B


def _start_hogs() -> list[subprocess.Popen]:
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"],
                             stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL)
            for _ in range(HOGS)]


def _stop(procs: list[subprocess.Popen]) -> None:
    for p in procs:
        if p.poll() is None:
            p.kill()
    for p in procs:
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:
            pass


def _session_members(sid: int) -> list[int]:
    """Live (non-zombie) processes of session ``sid``, from /proc."""
    out = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()
        if int(fields[3]) == sid and fields[0] != "Z":  # fields: state ppid pgrp session
            out.append(int(entry.name))
    return out


def _alive(seen: dict[int, float]) -> list[int]:
    """PIDs in ``seen`` (pid -> create time) that are still the same, non-zombie process."""
    left = []
    for pid, created in seen.items():
        try:
            p = psutil.Process(pid)
            if p.create_time() == created and p.status() != psutil.STATUS_ZOMBIE:
                left.append(pid)
        except psutil.NoSuchProcess:
            pass
    return left


def cotsfleet_argv(*args: str) -> list[str]:
    """``cotsfleet ARGS`` as a command: the venv's console script when there is one (the
    process is then named ``cotsfleet``), else ``python -m cotsfleet``."""
    cli = Path(sys.executable).with_name("cotsfleet")
    return [str(cli), *args] if cli.exists() else [sys.executable, "-m", "cotsfleet", *args]


def run_mission_processes(seed: int, warp: float, workdir: Path, stall: bool = False,
                          viewer: str = "none", extra: tuple[str, ...] = (),
                          tag: str = "") -> dict[str, Any]:
    """One ``cotsfleet run`` in its own session (with ``stall``: `STALL` too; ``extra``: more
    arguments, e.g. a scenario and faults); every process it spawned is recorded and must be
    gone when it returns."""
    tag = tag or f"w{warp:g}-s{seed}{'-stall' if stall else ''}"
    report_path = workdir / f"report-{tag}.json"
    run_dir = workdir / f"run-{tag}"
    argv = cotsfleet_argv(
        "run", "--warp", f"{warp:g}", "--viewer", viewer, "--seed", str(seed),
        "--report", str(report_path), "--run-dir", str(run_dir), "--no-hold-viewer",
        *(["--stall", f"{STALL.vid}@{STALL.t_s:g}+{STALL.value:g}"] if stall else []),
        *extra)
    timeout = 4 * 3600 / warp + 300
    log = open(workdir / f"log-{tag}.txt", "w")
    t0 = time.perf_counter()
    launcher = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=log,
                                stderr=subprocess.STDOUT, start_new_session=True)
    seen: dict[int, float] = {launcher.pid: psutil.Process(launcher.pid).create_time()}
    timed_out = False
    try:
        while launcher.poll() is None:
            try:
                for c in psutil.Process(launcher.pid).children(recursive=True):
                    try:
                        seen.setdefault(c.pid, c.create_time())
                    except psutil.NoSuchProcess:
                        pass
            except psutil.NoSuchProcess:
                pass
            if time.perf_counter() - t0 > timeout:
                timed_out = True
                break
            time.sleep(0.25)
    finally:
        if launcher.poll() is None:  # timed out or interrupted: end its whole session
            for sig in (signal.SIGTERM, signal.SIGKILL):
                try:
                    os.killpg(launcher.pid, sig)
                except ProcessLookupError:
                    break
                try:
                    launcher.wait(timeout=15)
                    break
                except subprocess.TimeoutExpired:
                    pass
        log.close()
    wall = time.perf_counter() - t0
    # The launcher is gone; give its children a moment to finish exiting, then check.
    deadline = time.monotonic() + 15
    while (_alive(seen) or _session_members(launcher.pid)) and time.monotonic() < deadline:
        time.sleep(0.25)
    leftovers = sorted(set(_alive(seen)) | set(_session_members(launcher.pid)))
    if leftovers:  # report them, then do not leave them running
        for pid in leftovers:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
    report = json.loads(report_path.read_text()) if report_path.exists() else None
    return {"report": report, "rc": launcher.returncode, "wall_s": wall, "spawned": len(seen),
            "leftovers": leftovers, "timed_out": timed_out, "log": str(log.name)}


def part_b(seeds: list[int], warps: list[float], config: AgentConfig,
           workdir: Path) -> tuple[str, list[str], str]:
    rows, misses = [], []
    inproc: dict[tuple[int, bool], dict[str, Any]] = {}
    for seed in seeds:  # the reference, measured before the hogs start
        problem = problem_from_dict(scenario_doc(None, None, seed))
        inproc[(seed, False)] = simulate(problem, config, seed=seed).report.to_dict()
        inproc[(seed, True)] = simulate(problem, config, seed=seed,
                                        faults=[STALL]).report.to_dict()
    me = psutil.Process()
    hogs: list[subprocess.Popen] = []
    spawned = 0
    leftovers: list[int] = []
    try:
        hogs = _start_hogs()
        time.sleep(1.0)
        for warp, stall in [(w, False) for w in warps] + [(STALL_WARP, True)]:
            for seed in seeds:
                ref = inproc[(seed, stall)]["fleet"]
                res = run_mission_processes(seed, warp, workdir, stall)
                label = f"{warp:g} + stall" if stall else f"{warp:g}"
                spawned += res["spawned"]
                leftovers += res["leftovers"]
                r = res["report"]
                if r is None:
                    rows.append([label, seed, "-", "-", f"{res['wall_s']:.0f}",
                                 f"failed (rc {res['rc']}, log {res['log']})",
                                 *["-"] * 6])
                    misses.append(f"warp {label} seed {seed}: no report (rc {res['rc']}"
                                  f"{', timed out' if res['timed_out'] else ''})")
                    print(" | ".join(str(c) for c in rows[-1]), flush=True)
                    continue
                f = r["fleet"]
                n = len(r["vehicles"])
                ratio = f["priority"] / ref["priority"] if ref["priority"] > 0 else math.nan
                clock = r.get("clock")
                eff = (f"{clock['effective_warp']:.1f}" if clock and
                       clock.get("effective_warp") is not None else "-")
                if clock and clock.get("slowdowns"):
                    ups = len(clock.get("speedups") or [])
                    eff += (f" (lowest {min(s['warp'] for s in clock['slowdowns']):g}, final "
                            f"{clock.get('final_warp', '-')}, {len(clock['slowdowns'])} "
                            f"slowdown(s), {ups} speed-up(s))")
                lag = (f"{clock['max_lag_s']:.1f}" if clock and
                       clock.get("max_lag_s") is not None else "-")
                rows.append([label, seed, eff, lag, f"{res['wall_s']:.0f}",
                             f"{f['priority']:.0f} / {ref['priority']:.0f}", f"{ratio:.3f}",
                             f"{f['duplicate_treatments']} / {ref['duplicate_treatments']}",
                             f"{f['vehicles_home']}/{n}",
                             f"{f['false_alarms']} / {ref['false_alarms']}",
                             res["rc"], len(res["leftovers"])])
                print(" | ".join(str(c) for c in rows[-1]), flush=True)
                tag = f"warp {label} seed {seed}"
                if not abs(ratio - 1.0) <= MP_PRIORITY_TOLERANCE:
                    misses.append(f"{tag}: priority {100 * (ratio - 1):+.1f} % vs in-process "
                                  f"(target within 2 %)")
                if f["duplicate_treatments"]:
                    misses.append(f"{tag}: {f['duplicate_treatments']} duplicate(s) (target 0)")
                if f["vehicles_home"] < n:
                    misses.append(f"{tag}: {f['vehicles_home']} of {n} vehicles home")
                if f["false_alarms"]:
                    misses.append(f"{tag}: {f['false_alarms']} false alarm(s)")
                if clock is None:
                    misses.append(f"{tag}: the report has no clock section (effective warp "
                                  f"not reported)")
                if res["leftovers"]:
                    misses.append(f"{tag}: {len(res['leftovers'])} process(es) left running "
                                  f"after the launcher exited (killed by the benchmark)")
    finally:
        _stop(hogs)
    # Every process this benchmark started must be gone: hogs, launchers and what they spawned.
    hog_left = [p.pid for p in hogs if p.poll() is None]
    children = [c.pid for c in me.children(recursive=True)
                if c.status() != psutil.STATUS_ZOMBIE]
    clean = not (hog_left or children or leftovers)
    if not clean:
        misses.append(f"processes left: hogs {hog_left}, children {children}, mission "
                      f"leftovers {leftovers}")
    check = (f"Process check: {spawned} mission processes (launchers and what they spawned) "
             f"and {len(hogs)} hogs started; at the end "
             + ("none is left (psutil children of the benchmark, and /proc session scan of each "
                "launcher's session, both empty)." if clean else
                f"LEFT RUNNING: hogs {hog_left}, children {children}, mission {leftovers}."))
    print(check, flush=True)
    table = markdown_table(
        ["warp", "seed", "effective warp", "max lag s", "wall s",
         "priority multi / in-process", "ratio", "duplicates multi / in-process",
         "vehicles home", "false alarms multi / in-process", "exit code", "processes left"],
        rows)
    return table, misses, check


# --------------------------------------------------------------------------- main


def main(runs: int, warps: list[float], mp_seeds: list[int], quick: bool,
         skip_b: bool = False) -> int:
    config = AgentConfig()
    t0 = time.perf_counter()
    table_a, misses_a = part_a(runs, config)
    wall_a = time.perf_counter() - t0
    print(table_a, flush=True)
    table_b, misses_b, check = "", [], ""
    if not skip_b:
        t1 = time.perf_counter()
        with tempfile.TemporaryDirectory(prefix="fleet_silence-") as tmp:
            table_b, misses_b, check = part_b(mp_seeds, warps, config, Path(tmp))
        wall_b = time.perf_counter() - t1
        print(table_b, flush=True)
    misses = misses_a + misses_b
    print_misses(misses)
    if quick or skip_b:
        return 0
    load = os.getloadavg()
    body = (
        f"Issue 11's check. **Part A**, in-process (`cotsfleet.mission.inprocess`), paper preset "
        f"drawn with seeds 0..{runs - 1} (one scenario per seed), default agent and channel "
        f"settings; extra loss is uniform on top of the range model. Baseline: the report's "
        f"no-communication priority (each vehicle flies its initial plan). Targets: never below "
        f"the baseline, duplicates <= 1 % of treatments at every loss and 0 at 30 %. False alarm: "
        f"a 'lost' (confirmed silence) for a vehicle that was alive; suspicion: a peer gone "
        f"silent that nobody has confirmed yet (nothing is taken on it). Kill row: the kill "
        f"removes auv2's share, so its baseline ratio is not a target; the oracle column is the "
        f"priority the survivors collected after the kill over a centralized perfect-information "
        f"replan at the kill time; detection from the kill to each survivor's 'lost'. "
        f"{wall_a:.0f} s wall.\n\n{table_a}\n\n"
        f"**Part B**, multi-process: `cotsfleet run --viewer none --seed S --warp W` (embedded "
        f"router, link emulator, one agent process per AUV) of the one-hour paper preset, while "
        f"{HOGS} CPU hogs (`python -c \"while True: pass\"`) keep both cores busy, against the "
        f"in-process run of the same seed (no extra loss, no fault). Effective warp and max lag "
        f"come from the report's `clock` section (\"-\": the report has none). The last rows "
        f"add `--stall auv1@300+300` at warp {STALL_WARP:g} (that agent frozen the first half "
        f"of every 8 mission s, SIGSTOP in wall time), against the in-process run with the "
        f"same stall. Targets: priority within 2 %, 0 duplicates, all home, no false alarm. "
        f"{wall_b:.0f} s wall. {check} The machine may "
        f"also have been loaded by another developer's work (load average at the end "
        f"{load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f}).\n\n{table_b}\n\n" + misses_block(misses))
    write_section("fleet_silence", "fleet_agent: silence is not death (issue 11)", body)
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20, help="seeds in part A (default 20)")
    parser.add_argument("--warps", default="60,120,240", help="part B warps (default 60,120,240)")
    parser.add_argument("--mp-seeds", default="0,1", help="part B seeds (default 0,1)")
    parser.add_argument("--no-processes", action="store_true",
                        help="part A only (no RESULTS.md update)")
    parser.add_argument("--quick", action="store_true",
                        help="3 seeds, warp 60 and seed 0 only, no RESULTS.md update")
    args = parser.parse_args()
    raise SystemExit(main(3 if args.quick else args.runs,
                          [60.0] if args.quick else [float(w) for w in args.warps.split(",")],
                          [0] if args.quick else [int(s) for s in args.mp_seeds.split(",")],
                          args.quick,
                          args.no_processes))
