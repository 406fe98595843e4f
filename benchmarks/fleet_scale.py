"""Large fleets on the v2 wire: 24 AUVs x 600 spots in process, 12 AUVs as OS processes.

``python -m benchmarks.fleet_scale [--quick] [--seed N]``

(a) `cotsfleet scenario --vehicles 24 --spots 600 --area-m 3000 --battery-s 7200`, simulated
in process with a kill at 3000 s of the vehicle that works longest in the same mission without
a fault (a plan may leave vehicles idle: one killed at the start would test nothing; the
benchmark fails if the victim was not at sea): wall time (target <= 180 s on one core), duplicates
(target 0), detection of the dead vehicle by the survivors still at sea, and the fleet's
priority over a centralized ``cotsfleet plan --time-limit 20`` of the same scenario (target
>= 0.85); peak RSS of the simulation per simulated vehicle.
(b) ``cotsfleet run --vehicles 12 --warp 30 --viewer none`` as a child process: completes, 0
duplicates, largest frame <= 64 B, peak RSS of every agent process (sampled twice a second);
at the end every process it started (the launcher's whole tree, seen while it ran, and its
session) must be gone, else the benchmark fails.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import psutil

from benchmarks.results import markdown_table, write_section
from cotsfleet.cli import main as cotsfleet
from cotsfleet.io import read_scenario
from cotsfleet.mission.faults import Fault
from cotsfleet.mission.inprocess import simulate
from fleet_agent.config import AgentConfig
from hfc_core.model.problem import Problem

KILL_S = 3000.0
PLAN_S = 20.0
RUN_TIMEOUT_S = 1800.0
SAMPLE_S = 0.5
MB = 1024.0 * 1024.0


def rss_mb() -> float:
    """This process's resident set now, MB."""
    return psutil.Process().memory_info().rss / MB


def longest_working(problem: Problem, seed: int) -> tuple[str, float]:
    """The vehicle at sea longest in the mission without a fault, and for how long: the
    one whose loss the kill row tests (a plan may leave vehicles idle at the start)."""
    report = simulate(problem, AgentConfig(), seed=seed).report.to_dict()
    v = max(report["vehicles"], key=lambda v: (v["battery_used_s"], v["id"]))
    return v["id"], float(v["battery_used_s"])


def in_process(workdir: Path, seed: int, quick: bool) -> dict[str, Any]:
    """Part (a): the 24-AUV mission in process, and the centralized plan it is compared to."""
    scenario = workdir / "scale24.json"
    spots, battery = ("150", "1800") if quick else ("600", "7200")
    argv = ["scenario", "--vehicles", "24", "--spots", spots, "--area-m", "3000",
            "--battery-s", battery, "--seed", str(seed), "-o", str(scenario)]
    if cotsfleet(argv) != 0:
        raise SystemExit(f"cotsfleet {' '.join(argv)} failed")
    problem, _ = read_scenario(scenario)
    base_mb = rss_mb()  # before both runs: the peak is that of the larger (they are alike)
    victim, victim_s = longest_working(problem, seed)
    if not quick and victim_s <= KILL_S:
        raise SystemExit(f"no vehicle is at sea at {KILL_S:g} s: the kill would test nothing")
    kill = Fault("kill", KILL_S, victim)
    gc.collect()  # the fault-free run's objects go before the measured run starts
    sim = simulate(problem, AgentConfig(), seed=seed, faults=[] if quick else [kill])
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB
    f = sim.report.to_dict()["fleet"]
    # Detection by the vehicles still at sea: one already home has stopped listening.
    delays = [d for d in f["detection_delay_s"].get(kill.vid, {}).values() if d is not None]
    plan_json = workdir / "plan24.json"
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "cotsfleet", "plan", str(scenario), "--mode",
                           "best", "--time-limit", str(PLAN_S), "--seed", str(seed),
                           "--json", str(plan_json)], capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"cotsfleet plan failed: {done.stderr.strip()}")
    plan = json.loads(plan_json.read_text())
    return {"wall_s": sim.wall_s, "spots": f["spots_cleared"], "priority": f["priority"],
            "duplicates": f["duplicate_treatments"], "home": f["vehicles_home"],
            "false_alarms": f["false_alarms"], "taken_over": f["spots_taken_over"],
            "detected_by": len(delays), "detect_max_s": max(delays) if delays else None,
            "victim": victim, "victim_mission_s": victim_s,
            "largest_frame": sim.report.to_dict()["messages"]["largest_frame_bytes"],
            "plan_priority": plan["priority_collected"],
            "plan_wall_s": time.perf_counter() - t0,
            "ratio": f["priority"] / plan["priority_collected"],
            "peak_mb": peak_mb, "base_mb": base_mb,
            "mb_per_vehicle": max(0.0, peak_mb - base_mb) / problem.n_vehicles,
            "n_vehicles": problem.n_vehicles, "n_tasks": problem.n_tasks}


def _role(cmdline: list[str]) -> str:
    text = " ".join(cmdline)
    for role in ("fleet_agent", "comms_sim.router", "comms_sim", "ground_station"):
        if f"-m {role}" in text:
            return {"comms_sim": "relay", "comms_sim.router": "router"}.get(role, role)
    return "other"


def processes(workdir: Path, seed: int, quick: bool) -> dict[str, Any]:
    """Part (b): `cotsfleet run` as a child in its own session, its tree sampled."""
    vehicles = "4" if quick else "12"
    report = workdir / "run12" / "report.json"
    argv = [sys.executable, "-m", "cotsfleet", "run", "--vehicles", vehicles, "--warp", "30",
            "--viewer", "none", "--seed", str(seed), "--run-dir", str(workdir / "run12"),
            "--report", str(report)]
    seen: dict[tuple[int, float], dict[str, Any]] = {}  # (pid, start time) -> role, peak MB
    t0 = time.perf_counter()
    child = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             text=True, start_new_session=True)
    out_lines: list[str] = []
    reader = _drain(child, out_lines)
    try:
        launcher = psutil.Process(child.pid)
        while child.poll() is None and time.perf_counter() - t0 < RUN_TIMEOUT_S:
            try:
                tree = [launcher, *launcher.children(recursive=True)]
            except psutil.NoSuchProcess:
                break
            for p in tree:
                try:
                    key = (p.pid, p.create_time())
                    rss = p.memory_info().rss / MB
                    row = seen.setdefault(key, {"role": _role(p.cmdline()), "peak_mb": 0.0})
                    row["peak_mb"] = max(row["peak_mb"], rss)
                except psutil.Error:
                    pass  # it ended between the listing and the look
            time.sleep(SAMPLE_S)
        timed_out = child.poll() is None
        if timed_out:
            child.terminate()
        code = child.wait(timeout=60)
    finally:
        reader.join(timeout=10)
    wall = time.perf_counter() - t0
    time.sleep(1.0)  # the launcher reaps its children before it exits; allow the OS a beat
    left = [(pid, row["role"]) for (pid, started), row in seen.items()
            if _alive(pid, started)]
    in_session = [p.pid for p in psutil.process_iter(["pid"]) if _sid(p.pid) == child.pid]
    for pid in {pid for pid, _ in left} | set(in_session):  # ours: never leave them behind
        try:
            psutil.Process(pid).kill()
        except psutil.Error:
            pass
    doc = json.loads(report.read_text()) if report.exists() else {}
    agents = [r["peak_mb"] for r in seen.values() if r["role"] == "fleet_agent"]
    f = doc.get("fleet", {})
    return {"code": code, "timed_out": timed_out, "wall_s": wall,
            "home": f.get("vehicles_home"), "vehicles": int(vehicles),
            "duplicates": f.get("duplicate_treatments"), "spots": f.get("spots_cleared"),
            "largest_frame": doc.get("messages", {}).get("largest_frame_bytes"),
            "end_s": doc.get("end_s"), "processes_seen": len(seen), "agents": len(agents),
            "agent_mb_max": max(agents) if agents else None,
            "agent_mb_median": sorted(agents)[len(agents) // 2] if agents else None,
            "left": left, "left_in_session": in_session,
            "tail": out_lines[-5:]}


def _drain(child: subprocess.Popen, lines: list[str]) -> threading.Thread:
    """Read the child's output on a thread (a full pipe would stall it)."""
    def run() -> None:
        assert child.stdout is not None
        for line in child.stdout:
            lines.append(line.rstrip())

    t = threading.Thread(target=run, daemon=True)
    t.start()
    return t


def _alive(pid: int, started: float) -> bool:
    """Is the process we saw (same pid, same start time: not a reused pid) still there?"""
    try:
        p = psutil.Process(pid)
        return p.create_time() == started and p.status() != psutil.STATUS_ZOMBIE
    except psutil.Error:
        return False


def _sid(pid: int) -> int | None:
    try:
        return os.getsid(pid)
    except OSError:
        return None


def main(seed: int, quick: bool) -> int:
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="fleet_scale-") as tmp:
        workdir = Path(tmp)
        a = in_process(workdir, seed, quick)
        print(f"(a) in-process {a['n_vehicles']}x{a['n_tasks']}: {a['wall_s']:.1f} s wall, "
              f"{a['duplicates']} duplicates, priority {a['priority']:.0f} vs plan "
              f"{a['plan_priority']:.0f} = {a['ratio']:.3f}, peak {a['peak_mb']:.0f} MB",
              flush=True)
        b = processes(workdir, seed, quick)
        print(f"(b) cotsfleet run: exit {b['code']}, {b['wall_s']:.0f} s wall, "
              f"{b['duplicates']} duplicates, largest frame {b['largest_frame']} B, "
              f"{b['processes_seen']} processes seen, left {b['left']} {b['left_in_session']}",
              flush=True)
    gone = not b["left"] and not b["left_in_session"]
    ok_b = (b["code"] == 0 and not b["timed_out"] and b["duplicates"] == 0
            and b["largest_frame"] is not None and b["largest_frame"] <= 64 and gone)
    rows_a = [
        ["wall time (one core)", f"{a['wall_s']:.1f} s", "<= 180 s"],
        ["spots cleared / duplicates", f"{a['spots']} / {a['duplicates']}", "- / 0"],
        ["fleet priority / centralized plan at 20 s",
         f"{a['priority']:.0f} / {a['plan_priority']:.0f} = {a['ratio']:.3f}", ">= 0.85"],
        [f"{a['victim']} (killed) detected by survivors at sea (latest)",
         f"{a['detected_by']} ({a['detect_max_s']} s)",
         f"<= 4.5 cycles = {4.5 * 24 * AgentConfig().slot_s:.0f} s"],
        ["vehicles home, false alarms, spots taken over",
         f"{a['home']}, {a['false_alarms']}, {a['taken_over']}", ""],
        ["largest frame", f"{a['largest_frame']} B", "<= 64 B"],
        ["peak RSS (whole process) / per simulated vehicle",
         f"{a['peak_mb']:.0f} MB / {a['mb_per_vehicle']:.2f} MB", ""],
    ]
    rows_b = [
        ["completed (exit code)", f"{b['code']}{' (timed out)' if b['timed_out'] else ''}", "0"],
        ["wall time, mission end", f"{b['wall_s']:.0f} s, t={b['end_s']} s", ""],
        ["vehicles home / duplicates", f"{b['home']}/{b['vehicles']} / {b['duplicates']}",
         "- / 0"],
        ["largest frame", f"{b['largest_frame']} B", "<= 64 B"],
        ["peak RSS per agent process (median / max)",
         f"{b['agent_mb_median']:.0f} / {b['agent_mb_max']:.0f} MB"
         if b["agents"] else "n/a", ""],
        ["processes seen / left after the end", f"{b['processes_seen']} / "
         f"{len(b['left']) + len(b['left_in_session'])}", "- / 0"],
    ]
    head = ["figure", "measured", "target"]
    load = os.getloadavg()
    body = (f"Seed {seed}, default agent and channel settings. Load average (1 min) "
            f"{load_before:.1f} before the benchmark; {load[0]:.1f} / {load[1]:.1f} / "
            f"{load[2]:.1f} at its end, its own processes included (part (b) runs 15 on 2 "
            f"cores).\n\n"
            f"**(a)** `cotsfleet scenario --vehicles 24 --spots 600 --area-m 3000 --battery-s "
            f"7200`, in process with a kill at {KILL_S:g} s of the vehicle working longest "
            f"without a fault ({a['victim']}, {a['victim_mission_s']:.0f} s at sea; the plan "
            f"may leave vehicles idle) (the whole 7200 s mission); "
            f"centralized `cotsfleet plan --mode best --time-limit 20`. Detection counts "
            f"only survivors still at sea (a vehicle home has stopped listening). Per-vehicle "
            f"memory: (peak RSS - RSS before the simulation) / 24.\n\n"
            f"{markdown_table(head, rows_a)}\n\n"
            f"**(b)** `cotsfleet run --vehicles 12 --warp 30 --viewer none` as a child in its "
            f"own session; its process tree sampled every {SAMPLE_S:g} s (RSS per process); at "
            f"the end every process seen (pid and start time) and the session are checked "
            f"gone.\n\n{markdown_table(head, rows_b)}\n")
    print(body)
    if not quick:
        write_section("fleet_scale", "fleet_agent: large fleets on the v2 wire (24 and 12 AUVs)",
                      body)
    if not gone:
        print(f"FAIL: processes outlived the mission: {b['left']} {b['left_in_session']}",
              file=sys.stderr)
    if not ok_b:
        print("FAIL: (b) " + "; ".join(b["tail"]), file=sys.stderr)
    return 0 if ok_b and a["duplicates"] == 0 else 1


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true",
                        help="24x150 without a kill and 4 AUVs as processes; no RESULTS.md")
    args = parser.parse_args()
    raise SystemExit(main(args.seed, args.quick))
