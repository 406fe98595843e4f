"""Whole missions through the ports (issues 28 and 29): `cotsfleet run --helm ros2` (real ROS 2
processes on loopback, discovery confined to this host, a domain of the run's own), `--helm
moos` (MOOS-IvP communities from PATH), and `--modem micromodem` (each agent's NMEA driver on
its emulated Micro-Modem), each against the same scenario and seed flown the default way.

Each completes with every vehicle home, no spot treated twice, and at least 0.95 of the
priority of the reference: `cotsfleet sim` (the in-process simulation) for the helms, the
default water (the Zenoh relay) for the modem. The ROS 2 test needs rclpy (the ``ros2``
extra, which ``make test`` installs); the MOOS test needs MOOS-IvP's apps on PATH or in
``$MOOS_IVP_BIN``, which CI does not build: it skips, saying so.
"""

from __future__ import annotations

import functools
import os
import shutil
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from leftovers import alive, kill_children

from cotsfleet.mission.inprocess import InProcessBackend
from cotsfleet.mission.modem_launch import micromodem_slot_s
from cotsfleet.mission.processes import ProcessBackend, ProcessOptions
from cotsfleet.mission.runner import run_mission
from fleet_agent.config import AgentConfig
from fleet_agent.helms.moos_mission import MOOS_APPS
from fleet_agent.modems.micromodem import micromodem_spec
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import GeneratorParams, generate_doc

pytestmark = [pytest.mark.integration, pytest.mark.slow]
SEED = 3
SHARE = 0.95


@functools.lru_cache(maxsize=None)
def scenario() -> dict:
    params = GeneratorParams(name="ports", n_tasks=30, n_vehicles=3, size_m=600.0,
                             battery_s=1500.0, service_s=60.0)
    return generate_doc(params, np.random.default_rng(11))


@functools.lru_cache(maxsize=None)
def sim_report() -> dict:
    """What `cotsfleet sim` collects on the scenario and seed."""
    doc = scenario()
    problem = problem_from_dict(doc)
    backend = InProcessBackend(problem, AgentConfig(), seed=SEED)
    return run_mission(problem, backend, (), seed=SEED, step_s=60.0).report.to_dict()


def run_processes(run_dir: Path, **options) -> tuple[dict, ProcessBackend]:
    doc = scenario()
    problem = problem_from_dict(doc)
    opts = ProcessOptions(run_dir=run_dir, progress_every_s=0, **options)
    launcher = ProcessBackend(problem, doc, SEED, opts, out=lambda line: None)
    result: dict = {}
    thread = threading.Thread(target=lambda: result.update(report=run_mission(
        problem, launcher, (), seed=SEED, step_s=25.0).report.to_dict()), daemon=True)
    thread.start()
    try:
        thread.join(timeout=420)
    finally:
        if thread.is_alive():  # last resort: never leave processes behind
            kill_children(launcher)
    assert not thread.is_alive(), "the launcher did not finish"
    for name, child in launcher.children.items():
        assert child.popen.poll() is not None and not alive(child.popen.pid), name
    return result["report"], launcher


def check_outcome(report: dict, reference: dict, helm: str) -> None:
    f = report["fleet"]
    assert not report.get("failure"), report.get("failure")
    assert f["vehicles_home"] == 3, [(v["id"], v["state"]) for v in report["vehicles"]]
    assert f["duplicate_treatments"] == 0
    assert f["priority"] >= SHARE * reference["fleet"]["priority"], (
        f["priority"], reference["fleet"]["priority"])
    assert f["false_alarms"] == 0
    for v in report["vehicles"]:
        assert v.get("helm", "sim") == helm and v["nav_fixes"] > 100, v  # "sim" is the default


def test_a_ros2_mission_collects_what_the_simulation_does(tmp_path: Path) -> None:
    pytest.importorskip("rclpy", reason="rclpy not installed (pip install -e '.[ros2]')")
    report, launcher = run_processes(tmp_path, warp=30.0, helm="ros2")
    check_outcome(report, sim_report(), "ros2")
    assert report["helm"]["name"] == "ros2" and not report["helm"]["clock_pinned"]
    assert 1 <= report["helm"]["ros_domain_id"] <= 100
    # Every vehicle was a ROS 2 node of its own, and each ended with the mission.
    assert {f"auv{i}.vehicle" for i in (1, 2, 3)} <= set(launcher.children)


def moos_bin() -> str | None:
    """A PATH with MOOS-IvP's apps: the process's, or with ``$MOOS_IVP_BIN`` before it."""
    path = os.environ.get("PATH", "")
    extra = os.environ.get("MOOS_IVP_BIN", "")
    for candidate in (path, f"{extra}{os.pathsep}{path}" if extra else None):
        if candidate and all(shutil.which(a, path=candidate) for a in MOOS_APPS):
            return candidate
    return None


def test_a_moos_mission_collects_what_the_simulation_does(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    path = moos_bin()
    if path is None:
        pytest.skip(f"MOOS-IvP apps ({', '.join(MOOS_APPS)}) not on PATH or in $MOOS_IVP_BIN "
                    "(CI does not build MOOS-IvP; docs/onboard.md says how)")
    monkeypatch.setenv("PATH", path)
    report, launcher = run_processes(tmp_path, warp=30.0, helm="moos")
    check_outcome(report, sim_report(), "moos")
    helm = report["helm"]
    assert helm["clock_pinned"] and report["clock"]["holds"] == 0
    # The fleet's clock kept MOOS's pace: each vehicle's MOOS time within 0.5 s of the
    # mission clock over the whole mission (MOOSTimeWarp is fixed, the clock was held fixed).
    assert max(helm["clock_drift_max_s"].values()) < 0.5, helm
    assert (tmp_path / "moos" / "auv1.moos").is_file()
    assert {f"auv1.{app}" for app in MOOS_APPS} <= set(launcher.children)


def test_a_micromodem_mission_collects_what_the_water_does(tmp_path: Path) -> None:
    slot = micromodem_slot_s(micromodem_spec(1), problem_from_dict(scenario()))
    assert slot == 4.6  # 3 x 64 B at 500 bps (3.07 s), 600 m x 1.41 across (0.57 s), 1 s
    # The reference and the modems' mission at once: each mostly waits on its clock.
    with ThreadPoolExecutor(2) as pool:
        reference = pool.submit(run_processes, tmp_path / "water", warp=50.0)
        modems = pool.submit(run_processes, tmp_path / "micromodem", warp=50.0,
                             modem="micromodem", agent_config=AgentConfig(slot_s=slot),
                             slot_from_modem=True)
        (water, _), (report, launcher) = reference.result(), modems.result()
    check_outcome(report, water, "sim")
    modem = report["modem"]
    assert modem["name"] == "micromodem" and modem["rate"] == 1
    assert modem["slot_s"] == slot and modem["slot_from"] == "modem"
    assert "water" in launcher.children and "relay" not in launcher.children
    # Frames crossed the emulated modems: link events and counters as with the relay.
    link = report["messages"]["link"]
    assert link["delivered"] > 0.9 * link["sent"] > 0
    sent = sum(v["counters"].get("modem_sent", 0) for v in report["vehicles"])
    assert sent > 100
