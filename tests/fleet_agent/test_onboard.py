"""The agent on board (`fleet_agent.onboard`, `cotsfleet agent`): its mission from a file, the
vehicle's own clock, no operator; two agents in real time talking through emulated
Micro-Modems (`cotsfleet water --face micromodem`, standalone: no bus at all)."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from cotsfleet.mission.modem_launch import free_port_run
from fleet_agent.config import AgentConfig, dump_config
from fleet_agent.helms.moos_mission import MOOS_APPS, write_moos_mission
from fleet_agent.mission_file import MissionFileError, read_mission_file, write_mission_file
from fleet_agent.modems.choice import ModemChoice
from fleet_agent.onboard import main, own_clock
from fleet_bus.mission import Mission
from fleet_bus.process import AGENT_READY, WATER_READY
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import GeneratorParams, generate_doc

ROOT = Path(__file__).resolve().parents[2]
KEY = bytes(range(16))


def small_doc() -> dict:
    params = GeneratorParams(name="onboard", n_tasks=12, n_vehicles=2, size_m=500.0,
                             battery_s=1200.0, service_s=60.0)
    return generate_doc(params, np.random.default_rng(5))


class Clocks:
    """A host's monotonic and wall clocks, moved by hand."""

    def __init__(self, mono: float, wall: float) -> None:
        self.m, self.w = mono, wall

    def mono(self) -> float:
        return self.m

    def wall(self) -> float:
        return self.w


def test_mission_time_is_the_vehicles_own_real_time_from_the_start() -> None:
    c = Clocks(mono=500.0, wall=1_700_000_100.0)
    clock = own_clock(1_700_000_000.0, c.mono, c.wall)
    assert clock.now() == pytest.approx(100.0) and clock.warp == 1.0
    c.m += 10.0
    c.w += 10.0
    assert clock.now() == pytest.approx(110.0)
    c.w += 3600.0  # the wall clock steps mid-dive: mission time does not move
    assert clock.now() == pytest.approx(110.0)
    before = own_clock(1_700_000_200.0 + 3600.0, c.mono, c.wall)
    assert before.now() == pytest.approx(-90.0)  # not yet: the agent waits for it


def test_the_mission_file_round_trips_and_refuses_what_it_is_not(tmp_path: Path) -> None:
    mission = Mission(small_doc(), 7, "run-42")
    path = write_mission_file(tmp_path / "m.json", mission, 1_700_000_000.0)
    assert read_mission_file(path) == (mission, 1_700_000_000.0)
    write_mission_file(path, mission)
    assert read_mission_file(path) == (mission, None)
    for text, why in (("{", "not JSON"), ('{"format": "x"}', "not a mission file"),
                      ('{"format": "cotsfleet-mission/1", "scenario": 3, "seed": 1, '
                       '"run_id": "r"}', "scenario must be a map")):
        (tmp_path / "bad.json").write_text(text)
        with pytest.raises(MissionFileError, match=why) as err:
            read_mission_file(tmp_path / "bad.json")
        assert "\n" not in str(err.value)
    with pytest.raises(MissionFileError, match="cannot read"):
        read_mission_file(tmp_path / "none.json")


def test_a_mission_that_cannot_run_on_board_is_refused(tmp_path: Path, capsys) -> None:
    config = AgentConfig(slot_s=5.0).with_key(KEY)
    path = write_mission_file(tmp_path / "m.json", Mission(small_doc(), 1, "r"))
    stop = threading.Event()
    mm = ModemChoice.parse("micromodem:tcp:127.0.0.1:9", 1)
    assert main("auv1", config, tmp_path / "j", stop, path, modem=mm) == 2
    assert "no start" in capsys.readouterr().err
    assert main("auv1", config, tmp_path / "j", stop, path, start_unix=time.time()) == 2
    assert "--modem micromodem" in capsys.readouterr().err
    short = AgentConfig(slot_s=2.5).with_key(KEY)
    assert main("auv1", short, tmp_path / "j", stop, path, start_unix=time.time(),
                modem=mm) == 2
    assert "cannot hold" in capsys.readouterr().err
    assert main("auv9", config, tmp_path / "j", stop, path, start_unix=time.time(),
                modem=mm) == 2
    assert "not a vehicle" in capsys.readouterr().err


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}",
            "PYTHONUNBUFFERED": "1"}


def _ready(proc: subprocess.Popen, prefix: str, timeout_s: float) -> str:
    end = time.monotonic() + timeout_s
    assert proc.stdout is not None
    while time.monotonic() < end:
        line = proc.stdout.readline()
        if line.startswith(prefix):
            return line
        if not line and proc.poll() is not None:
            break
    raise AssertionError(f"no {prefix!r} line (exit {proc.poll()})")


def _stop(proc: subprocess.Popen) -> int:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)
    if proc.stdout is not None:
        proc.stdout.close()
    return int(proc.returncode)


@pytest.mark.integration
@pytest.mark.slow
def test_two_agents_on_board_talk_through_their_modems_in_real_time(tmp_path: Path) -> None:
    doc = small_doc()
    (tmp_path / "s.json").write_text(json.dumps(doc))
    (tmp_path / "agent.toml").write_text(dump_config(AgentConfig(slot_s=4.6).with_key(KEY)))
    start = time.time() + 4.0
    write_mission_file(tmp_path / "mission.json", Mission(doc, 3, "onboard-test"), start)
    water = subprocess.Popen(
        [sys.executable, "-m", "cotsfleet", "water", "--face", "micromodem", "--scenario",
         str(tmp_path / "s.json"), "--port", str(free_port_run(2)), "--heartbeat", "0"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=_env(), cwd=tmp_path)
    agents: list[subprocess.Popen] = []
    try:
        line = _ready(water, WATER_READY, 30.0)
        first = int(line.split("ports=")[1].split("-")[0])
        for i, vid in enumerate(("auv1", "auv2")):
            agents.append(subprocess.Popen(
                [sys.executable, "-m", "cotsfleet", "agent", "--id", vid, "--mission",
                 str(tmp_path / "mission.json"), "--config", str(tmp_path / "agent.toml"),
                 "--journal", str(tmp_path / f"{vid}.journal"),
                 "--modem", f"micromodem:tcp:127.0.0.1:{first + i}", "--modem-rate", "1"],
                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=_env(),
                cwd=tmp_path))
        for proc in agents:
            assert "(fresh), helm sim" in _ready(proc, AGENT_READY, 60.0)
        time.sleep(max(0.0, start + 20.0 - time.time()))  # two TDMA cycles and more
    finally:
        codes = [_stop(p) for p in agents]
        _stop(water)
    assert codes == [0, 0]
    for vid in ("auv1", "auv2"):
        lines = (tmp_path / f"{vid}.journal.telemetry.jsonl").read_text().splitlines()
        statuses = [json.loads(x) for x in lines if json.loads(x)["topic"] == "status"]
        last = statuses[-1]
        assert last["t_s"] >= 15.0 and last["state"] in ("transit", "injecting")
        assert last["counters"]["rx_frames"] >= 2, last["counters"]  # heard its peer
        assert last["counters"]["modem_sent"] >= 2 and last["counters"]["nav_fixes"] > 0
        assert (tmp_path / f"{vid}.journal").stat().st_size > 0


def _moos_path() -> str | None:
    path = os.environ.get("PATH", "")
    extra = os.environ.get("MOOS_IVP_BIN", "")
    for candidate in (path, f"{extra}{os.pathsep}{path}" if extra else None):
        if candidate and all(shutil.which(a, path=candidate) for a in MOOS_APPS):
            return candidate
    return None


@pytest.mark.integration
@pytest.mark.slow
def test_an_agent_on_board_drives_a_moos_vehicle_in_real_time(tmp_path: Path) -> None:
    path = _moos_path()
    if path is None:
        pytest.skip(f"MOOS-IvP apps ({', '.join(MOOS_APPS)}) not on PATH or in $MOOS_IVP_BIN "
                    "(CI does not build MOOS-IvP; docs/onboard.md)")
    doc = small_doc()
    doc["vehicles"] = doc["vehicles"][:1]
    (tmp_path / "s.json").write_text(json.dumps(doc))
    (tmp_path / "agent.toml").write_text(dump_config(AgentConfig(slot_s=4.6).with_key(KEY)))
    start = time.time() + 3.0
    write_mission_file(tmp_path / "mission.json", Mission(doc, 3, "onboard-moos"), start)
    moos_port = free_port_run(1)
    mission = write_moos_mission(problem_from_dict(doc), 0, tmp_path, 1.0, moos_port)
    env = {**_env(), "PATH": path}
    apps = [subprocess.Popen([app, str(mission)], stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL, env=env, cwd=tmp_path)
            for app in MOOS_APPS]
    water = subprocess.Popen(
        [sys.executable, "-m", "cotsfleet", "water", "--face", "micromodem", "--scenario",
         str(tmp_path / "s.json"), "--port", str(free_port_run(1)), "--heartbeat", "0"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env, cwd=tmp_path)
    agent = None
    try:
        first = int(_ready(water, WATER_READY, 30.0).split("ports=")[1].split("-")[0])
        agent = subprocess.Popen(
            [sys.executable, "-m", "cotsfleet", "agent", "--id", "auv1", "--mission",
             str(tmp_path / "mission.json"), "--config", str(tmp_path / "agent.toml"),
             "--journal", str(tmp_path / "auv1.journal"), "--helm", "moos",
             "--moos-port", str(moos_port), "--modem", f"micromodem:tcp:127.0.0.1:{first}"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env, cwd=tmp_path)
        assert "helm moos" in _ready(agent, AGENT_READY, 60.0)
        time.sleep(max(0.0, start + 15.0 - time.time()))
    finally:
        code = _stop(agent) if agent is not None else None
        _stop(water)
        for app in reversed(apps):
            app.terminate()
        for app in apps:
            try:
                app.wait(10)
            except subprocess.TimeoutExpired:
                app.kill()
                app.wait(5)
    assert code == 0
    lines = (tmp_path / "auv1.journal.telemetry.jsonl").read_text().splitlines()
    last = [json.loads(x) for x in lines if json.loads(x)["topic"] == "status"][-1]
    assert last["state"] == "transit" and last["distance_m"] > 5.0  # uSimMarine flew it
    assert last["counters"]["nav_fixes"] > 30 and last["counters"]["modem_sent"] >= 2
    assert last["counters"].get("helm_clock_drift_max_ms", 0) < 500
