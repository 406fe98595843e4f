"""The same mission behind each helm: `cotsfleet run --helm sim|ros2|moos` at warps 10 and 30.

    python -m benchmarks.helms [--seed N] [--warps 10 30] [--helms sim ros2 moos] [--quick]

The paper preset drawn with ``--seed`` (3 AUVs, 90 spots, 3600 s battery), every vehicle
behind one helm: the simulated vehicle in the agent's process (``sim``), the project's
simulated vehicle served as a ROS 2 node per vehicle on the fleet's clock (``ros2``, real
rclpy processes on loopback), or a MOOS-IvP community per vehicle (``moos``: MOOSDB,
uSimMarineV22, pMarinePIDV22, pHelmIvP from PATH or ``$MOOS_IVP_BIN``; skipped, said, if
missing). Recorded per run: priority against `cotsfleet sim` (the in-process simulation of the
same scenario and seed), duplicate treatments, vehicles home, wall time (first spawn to
report), navigation fixes per vehicle-minute (mission minutes), the worst delay between a fix
and the agent's step that took it (mission seconds, and wall milliseconds at the warp), the
worst lag of a fix from the helm's stamp to its receipt, and for MOOS the worst drift of a
vehicle's MOOS clock from the mission clock. One more MOOS run at warp 30 lets the fleet's
clock hold and slow as usual (``pin_clock=False``): what a fixed ``MOOSTimeWarp`` does then.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from benchmarks.results import markdown_table, write_section
from cotsfleet.commands.mission_args import scenario_doc
from cotsfleet.mission.inprocess import simulate
from cotsfleet.mission.processes import ProcessBackend, ProcessOptions
from cotsfleet.mission.runner import run_mission
from fleet_agent.config import AgentConfig
from fleet_agent.helms.moos_mission import MOOS_APPS
from hfc_core.formats.scenario import problem_from_dict

TICKS = os.sysconf("SC_CLK_TCK")


def cpu_s(pid: int) -> float:
    """User and system CPU seconds of a running process (0 if it is gone)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / TICKS


class MeasuredBackend(ProcessBackend):
    """The launcher, with each child's CPU seconds read just before the mission closes."""

    cpu: dict[str, float]

    def close(self) -> None:
        self.cpu = {name: cpu_s(c.popen.pid) for name, c in self.children.items()}
        super().close()


def run_measured(doc: dict[str, Any], seed: int, **options: Any
                 ) -> tuple[dict[str, Any], float, dict[str, float]]:
    """One `cotsfleet run` mission (no viewer): its report, wall seconds from the first spawn
    to the report, and the CPU seconds of each of its processes."""
    problem = problem_from_dict(doc)
    run_dir = Path(tempfile.mkdtemp(prefix="cotsfleet-bench-"))
    try:
        t0 = time.perf_counter()
        backend = MeasuredBackend(problem, doc, seed, ProcessOptions(
            run_dir=run_dir, progress_every_s=0, **options), out=lambda line: None)
        report = run_mission(problem, backend, (), seed=seed,
                             step_s=options.get("warp", 60.0) * 0.25).report.to_dict()
        return report, time.perf_counter() - t0, getattr(backend, "cpu", {})
    finally:
        shutil.rmtree(run_dir, ignore_errors=True)


def moos_path() -> str | None:
    """A PATH with MOOS-IvP's apps: the process's, or with ``$MOOS_IVP_BIN`` before it."""
    path = os.environ.get("PATH", "")
    extra = os.environ.get("MOOS_IVP_BIN", "")
    for candidate in (path, f"{extra}{os.pathsep}{path}" if extra else None):
        if candidate and all(shutil.which(a, path=candidate) for a in MOOS_APPS):
            return candidate
    return None


def figures(report: dict[str, Any], warp: float) -> dict[str, Any]:
    vehicles = report["vehicles"]
    minutes = max(report["end_s"], 1.0) / 60.0
    delay_s = max(v["counters"].get("nav_delay_max_ms", 0) for v in vehicles) / 1000.0
    lag_s = max(v["counters"].get("helm_fix_lag_max_ms", 0) for v in vehicles) / 1000.0
    drift = max((v["counters"].get("helm_clock_drift_max_ms", 0) for v in vehicles),
                default=0) / 1000.0
    f = report["fleet"]
    return {"priority": f["priority"], "duplicates": f["duplicate_treatments"],
            "home": f["vehicles_home"], "false_alarms": f["false_alarms"],
            "fixes_per_vehicle_min": sum(v.get("nav_fixes", 0) for v in vehicles) / len(vehicles)
            / minutes, "delay_s": delay_s, "delay_wall_ms": 1000.0 * delay_s / warp,
            "lag_s": lag_s, "drift_s": drift, "holds": report["clock"].get("holds", 0),
            "late": sum(v["counters"].get("late", 0) for v in vehicles),
            "failure": report.get("failure", "")}


def main(seed: int, warps: list[float], helms: list[str], write: bool) -> None:
    doc = scenario_doc(None, None, seed)
    problem = problem_from_dict(doc)
    sim = simulate(problem, AgentConfig(), seed=seed).report.fleet.priority
    print(f"cotsfleet sim: priority {sim:.1f}", flush=True)
    rows, notes = [], []
    path = moos_path()
    runs: list[tuple[str, float, bool]] = [(h, w, True) for h in helms for w in warps]
    if "moos" in helms and 30.0 in warps:
        runs.append(("moos", 30.0, False))  # the fleet's clock holds and slows as usual
    for helm, warp, pinned in runs:
        if helm == "moos" and path is None:
            notes.append(f"moos at warp {warp:g}: skipped, MOOS-IvP apps not on PATH or in "
                         "$MOOS_IVP_BIN")
            continue
        if helm == "ros2":
            try:
                import rclpy  # noqa: F401
            except ImportError:
                notes.append("ros2: skipped, rclpy not installed (pip install -e '.[ros2]')")
                continue
        saved = os.environ.get("PATH", "")
        if helm == "moos":
            os.environ["PATH"] = path  # type: ignore[assignment]
        try:
            report, wall, _ = run_measured(doc, seed, warp=warp, helm=helm,
                                           pin_clock=None if pinned else False)
        finally:
            os.environ["PATH"] = saved
        g = figures(report, warp)
        label = helm if pinned or helm != "moos" else "moos, clock not held fixed"
        rows.append([label, f"{warp:g}", round(g["priority"], 1),
                     f"{g['priority'] / sim:.3f}", g["duplicates"], g["home"],
                     f"{wall:.0f}", round(g["fixes_per_vehicle_min"], 1),
                     f"{g['delay_s']:.2f} ({g['delay_wall_ms']:.0f} ms)",
                     f"{g['lag_s']:.2f}", f"{g['drift_s']:.3f}" if helm == "moos" else "-",
                     g["holds"], g["false_alarms"], g["late"]])
        print(f"{label} warp {warp:g}: priority {g['priority']:.1f} ({g['priority'] / sim:.3f} "
              f"of sim), {g['duplicates']} duplicates, {g['home']} home, {wall:.0f} s wall, "
              f"{g['fixes_per_vehicle_min']:.1f} fixes/vehicle-min, worst fix-to-use "
              f"{g['delay_s']:.2f} s, drift {g['drift_s']:.3f} s {g['failure']}", flush=True)
    table = markdown_table(
        ["helm", "warp", "priority", "of sim", "duplicates", "home", "wall s",
         "fixes / vehicle-min", "worst fix-to-use, mission s (wall)", "worst helm lag s",
         "MOOS clock drift s", "holds", "false alarms", "late events"], rows)
    body = (f"Paper preset drawn with seed {seed} (3 AUVs, 90 spots, 3600 s battery), default "
            f"agent settings, the Zenoh relay as the water, no faults; `cotsfleet sim` "
            f"collects priority {sim:.1f} on it. Wall time from the first spawn to the report "
            "(startup and initial plans included). Fixes per vehicle-minute of mission time; "
            "the worst delay from a fix to the agent's step that took it, in mission seconds "
            "(and wall milliseconds at the warp); the worst lag of a fix from the helm's stamp "
            "to its receipt by the agent's adapter. MOOS runs keep the fleet's clock at the "
            "warp (MOOSTimeWarp cannot follow a hold); the last MOOS row lets it hold and "
            "slow as usual: the drift is how far the MOOS vehicles' clocks ran ahead of the "
            f"fleet's.\n\n{table}\n" + "".join(f"\n- {n}" for n in notes))
    if write:
        write_section("helms", "Helms: sim, ROS 2 and MOOS-IvP behind the same mission", body)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--warps", type=float, nargs="+", default=[10.0, 30.0])
    parser.add_argument("--helms", nargs="+", default=["sim", "ros2", "moos"],
                        choices=["sim", "ros2", "moos"])
    parser.add_argument("--quick", action="store_true",
                        help="warp 30 only, sim and ros2, RESULTS.md left alone")
    args = parser.parse_args()
    if args.quick:
        main(args.seed, [30.0], ["sim", "ros2"], write=False)
    else:
        main(args.seed, args.warps, args.helms, write=True)
