"""What `cotsfleet run --helm` and `--modem` decide before anything starts: the slot a
Micro-Modem packet needs, what is missing for a helm (exit 2, one line), the ROS 2 domain and
namespaces of a run, and a native child (a MOOS app) that dies with its launcher."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cotsfleet.cli import main
from cotsfleet.commands.mission_args import config_sets
from cotsfleet.mission.helm_launch import HelmLaunch, check_helm, ros_domain, ros_env
from cotsfleet.mission.modem_launch import (
    ModemLaunch,
    free_port_run,
    micromodem_slot_s,
    scenario_span_m,
)
from fleet_agent.modems.micromodem import micromodem_spec
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import paper_preset_doc

ROOT = Path(__file__).resolve().parents[2]


def alive(pid: int) -> bool:
    """A running process (a zombie is gone for our purposes)."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.fixture(scope="module")
def paper():
    return problem_from_dict(paper_preset_doc(0))


@pytest.mark.parametrize("rate, slot", [(0, 5.0), (1, 4.9), (5, 5.1)])
def test_the_slot_holds_a_full_packet_across_the_scenario(paper, rate: int, slot: float) -> None:
    # Rate 1: 3 x 64 B at 500 bps = 3.07 s; 1188 m across the paper preset = 0.79 s; 1 s.
    spec = micromodem_spec(rate)
    assert scenario_span_m(paper) == pytest.approx(1188.07, abs=0.01)
    assert micromodem_slot_s(spec, paper) == slot
    packet = spec.airtime_s(spec.frames_per_packet * spec.max_frame_bytes)
    assert slot >= packet + scenario_span_m(paper) / 1500.0 + 1.0


def test_a_slot_in_the_users_config_is_kept(tmp_path: Path) -> None:
    flat, table, none = tmp_path / "a.toml", tmp_path / "b.toml", tmp_path / "c.toml"
    flat.write_text("slot_s = 7.0\n")
    table.write_text("[agent]\nslot_s = 7.0\n")
    none.write_text("coop_period_s = 60.0\n")
    assert config_sets(flat, "slot_s") and config_sets(table, "slot_s")
    assert not config_sets(none, "slot_s") and not config_sets(None, "slot_s")


def test_a_missing_helm_is_named_in_one_line_with_exit_2(monkeypatch, capsys, tmp_path) -> None:
    monkeypatch.setenv("PATH", str(tmp_path))  # no MOOS-IvP here
    assert main(["run", "--helm", "moos", "--viewer", "none", "--run-dir",
                 str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "MOOSDB" in err and "pHelmIvP" in err and "PATH" in err
    assert not (tmp_path / "run").exists()  # nothing started
    monkeypatch.setitem(sys.modules, "rclpy", None)  # rclpy not installed
    with pytest.raises(ValueError, match=r"ros2.*pip install"):
        check_helm("ros2")


def test_an_unemulated_rate_is_a_usage_error(capsys, tmp_path) -> None:
    with pytest.raises(ValueError, match="not emulated"):
        ModemLaunch("micromodem", 3)
    assert main(["run", "--modem", "micromodem", "--modem-rate", "3", "--viewer", "none",
                 "--run-dir", str(tmp_path / "run")]) == 2
    assert "not emulated" in capsys.readouterr().err


def test_a_run_has_a_ros_domain_and_namespaces_of_its_own(paper, tmp_path: Path) -> None:
    a, b = ros_domain("20250101-000000-aaaa"), ros_domain("20250101-000000-bbbb")
    assert 1 <= a <= 100 and 1 <= b <= 100 and a == ros_domain("20250101-000000-aaaa")
    env = ros_env("r")
    assert env["ROS_LOCALHOST_ONLY"] == "1" and env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    pytest.importorskip("rclpy", reason="rclpy not installed (pip install -e '.[ros2]')")
    launch = HelmLaunch("ros2", paper, tmp_path, 30.0, "run-1")
    ns = launch.namespace("auv1")
    assert ns.startswith("/cf_") and ns.endswith("/auv1")
    assert HelmLaunch("ros2", paper, tmp_path, 30.0, "run-2").namespace("auv1") != ns
    argv = launch.agent_argv("auv1")
    assert argv[argv.index("--ros-namespace") + 1] == ns and "--emulation" in argv


def test_the_water_takes_a_run_of_free_ports() -> None:
    base = free_port_run(4)
    import socket

    for port in range(base, base + 4):
        with socket.socket() as s:
            s.bind(("127.0.0.1", port))  # free now


@pytest.mark.integration
def test_a_native_child_dies_with_its_launcher(tmp_path: Path) -> None:
    """A launcher SIGKILLed: its native child (here ``sleep``, as a MOOS app would be) gets
    SIGTERM from the kernel (PR_SET_PDEATHSIG, set before exec)."""
    launcher = subprocess.Popen(
        [sys.executable, "-c", (
            "import os, subprocess, sys, time\n"
            "env = {**os.environ, 'COTSFLEET_PARENT_PID': str(os.getpid())}\n"
            "p = subprocess.Popen([sys.executable, '-m', 'cotsfleet.mission.native', 'sleep',"
            " '60'], env=env)\n"
            "print(p.pid, flush=True)\n"
            "time.sleep(60)\n")],
        stdout=subprocess.PIPE, text=True, cwd=ROOT,
        env={**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"})
    try:
        child = int(launcher.stdout.readline())  # type: ignore[union-attr]
        time.sleep(0.5)
        with open(f"/proc/{child}/cmdline", "rb") as fh:
            assert fh.read().split(b"\0")[0] == b"sleep"  # it became the program: same pid
        launcher.send_signal(signal.SIGKILL)
        launcher.wait(5)
        end = time.monotonic() + 5.0
        while alive(child) and time.monotonic() < end:
            time.sleep(0.05)
        assert not alive(child)
    finally:
        if launcher.poll() is None:
            launcher.kill()
            launcher.wait(5)
        launcher.stdout.close()  # type: ignore[union-attr]


def test_a_program_not_on_path_is_said(tmp_path: Path) -> None:
    out = subprocess.run([sys.executable, "-m", "cotsfleet.mission.native", "no-such-app-xyz"],
                         capture_output=True, text=True, cwd=ROOT, timeout=30,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert out.returncode == 127 and "no-such-app-xyz is not on PATH" in out.stderr


def test_credentials_come_with_the_mission_file_an_agent_on_board_loads(tmp_path: Path,
                                                                       capsys) -> None:
    from fleet_agent.mission_file import read_mission_file
    from fleet_bus.credentials import load_ring

    d = tmp_path / "creds"
    assert main(["credentials", str(d), "--vehicles", "2", "--seed", "4",
                 "--start", "2030-01-01T00:00:00"]) == 0
    assert "cotsfleet agent --id ID --mission" in capsys.readouterr().out
    for where in (d, d / "auv1", d / "auv2"):
        mission, start = read_mission_file(where / "mission.json")
        assert mission.run_id == load_ring(d).run_id and mission.seed == 4
        assert start == 1893456000.0 and mission.roster() == ("auv1", "auv2")
    assert main(["credentials", str(tmp_path / "x"), "--start", "soon"]) == 2
    assert not (tmp_path / "x").exists()


def test_the_shipped_systemd_unit_runs_cotsfleet_agent_as_documented() -> None:
    """The unit's ExecStart, with the agent.env it documents, is a valid `cotsfleet agent`
    command line for a MOOS helm and a Micro-Modem on its serial line."""
    import shlex

    from cotsfleet.cli import build_parser

    text = (ROOT / "examples" / "systemd" / "cotsfleet-agent.service").read_text()
    env = dict(line[2:].strip().split("=", 1) for line in text.splitlines()
               if line.startswith("#   COTSFLEET_"))
    exec_start = text.split("ExecStart=", 1)[1].split("\n# ", 1)[0].replace("\\\n", " ")
    words = []
    for word in shlex.split(exec_start):
        if word.startswith("$") and not word.startswith("${"):
            words += env.get(word[1:], "").split()  # unbraced: split into words
        else:
            for name, value in env.items():
                word = word.replace("${" + name + "}", value)
            words.append(word)
    assert words[0].endswith("/cotsfleet") and words[1] == "agent"
    args = build_parser().parse_args(words[1:])
    assert args.id == "auv2" and args.helm == "moos" and args.moos_port == 9000
    assert args.modem == "micromodem:/dev/ttyUSB0" and args.modem_rate == 1
    assert str(args.mission) == "/etc/cotsfleet/auv2/mission.json"
    assert str(args.credentials) == "/etc/cotsfleet/auv2"
    doc = (ROOT / "docs" / "onboard.md").read_text()
    assert "--mission /etc/cotsfleet/auv2/mission.json" in doc
