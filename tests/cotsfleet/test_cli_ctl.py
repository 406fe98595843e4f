"""`cotsfleet ctl`'s bad input: one line and exit 2 (the live path is
tests/integration/test_ctl_run.py), with a run dir or from another host (``--connect
--credentials DIR/ground``), and the run record it finds a mission by."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from cotsfleet.cli import main
from fleet_bus.credentials import write_run_credentials
from fleet_bus.session import free_tcp_endpoint
from cotsfleet.mission.run_record import (
    NoMission,
    RunRecord,
    read_run_record,
    remove_run_record,
    write_run_record,
)


def _record(run_dir: Path, pid: int) -> None:
    write_run_record(run_dir, RunRecord("run-x", "tcp/127.0.0.1:1", pid,
                                        str(run_dir / "credentials"), ("auv1", "auv2")))


def _error(capsys, argv: list[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, err
    return err


@pytest.mark.parametrize("words, says", [
    (["recal", "auv2"], "unknown order 'recal'"),
    (["recall"], "recall takes VEHICLE|all"),
    (["recall", "auv1", "auv2"], "recall takes VEHICLE|all"),
    (["add-spot", "1", "x", "3"], "could not convert"),
    (["add-spot", "1", "2", "-3"], "priority in (0, 6553.5]"),
    (["add-spot", "1", "2"], "add-spot takes X Y PRIORITY"),
    (["drop-spot", "seven"], "invalid literal"),
    (["drop-spot", "70000"], "drop-spot takes a spot id")])
def test_a_bad_order_is_one_line_and_exit_2(tmp_path: Path, capsys, words, says) -> None:
    err = _error(capsys, ["ctl", "--run-dir", str(tmp_path), *words])
    assert says in err and err.startswith("cotsfleet ctl: error:")


def test_a_run_dir_without_a_running_mission_is_said(tmp_path: Path, capsys) -> None:
    assert "no such run dir" in _error(capsys, ["ctl", "--run-dir", str(tmp_path / "no"),
                                                "recall", "auv2"])
    assert "no mission is running in" in _error(
        capsys, ["ctl", "--run-dir", str(tmp_path), "recall", "auv2"])
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    _record(tmp_path, dead.pid)  # a launcher that was killed left its record
    assert "is over (its launcher, pid" in _error(
        capsys, ["ctl", "--run-dir", str(tmp_path), "recall", "auv2"])
    (tmp_path / "run.json").write_text("{not json")
    assert "not a run record" in _error(capsys, ["ctl", "--run-dir", str(tmp_path),
                                                 "recall", "auv2"])


def test_a_vehicle_the_mission_does_not_have_is_refused_before_sending(tmp_path: Path,
                                                                       capsys) -> None:
    _record(tmp_path, os.getpid())
    err = _error(capsys, ["ctl", "--run-dir", str(tmp_path), "pause", "auv7"])
    assert "no vehicle 'auv7' in this mission; it has auv1, auv2" in err


def test_a_negative_timeout_is_refused(tmp_path: Path, capsys) -> None:
    assert "--timeout" in _error(capsys, ["ctl", "--run-dir", str(tmp_path), "--timeout",
                                          "-1", "recall", "auv2"])


@pytest.mark.parametrize("argv", [["ctl", "recall", "auv2"],  # no --run-dir nor --connect
                                  ["ctl", "--run-di", "x", "recall", "auv2"],  # abbreviated
                                  ["ctl", "--run-dir", "x"],  # no order
                                  ["ctl", "--run-dir", "x", "--connect", "127.0.0.1:7447",
                                   "recall", "auv2"]])  # both
def test_argparse_refuses_missing_and_abbreviated_options(argv: list[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2


def test_the_record_is_written_whole_and_removed(tmp_path: Path) -> None:
    _record(tmp_path, os.getpid())
    got = read_run_record(tmp_path)
    assert got.vehicles == ("auv1", "auv2") and got.operator_dir == tmp_path / \
        "credentials" / "operator"
    assert [p.name for p in tmp_path.iterdir()] == ["run.json"]  # no temporary left
    remove_run_record(tmp_path)
    remove_run_record(tmp_path)  # twice: nothing to remove is fine
    with pytest.raises(NoMission):
        read_run_record(tmp_path)


@pytest.fixture(scope="module")
def creds(tmp_path_factory) -> dict[str, Path]:
    """A mission's credentials for one host (plain logins) and for hosts elsewhere (TLS)."""
    root = tmp_path_factory.mktemp("ctlcreds")
    write_run_credentials(root / "plain", ("auv1", "auv2"))
    write_run_credentials(root / "tls", ("auv1", "auv2"), tls=True)
    return {"plain": root / "plain", "tls": root / "tls"}


def test_connect_needs_the_ground_stations_credentials(creds, tmp_path: Path, capsys) -> None:
    def ctl(*argv: str) -> str:
        return _error(capsys, ["ctl", "--connect", "127.0.0.1:1", *argv, "recall", "auv2"])

    assert "--connect needs --credentials DIR/ground" in ctl()
    assert f"--credentials {tmp_path}: no ring.json there" in ctl("--credentials",
                                                                  str(tmp_path))
    for who in ("station", "auv1", "relay"):  # listens only; a vehicle's; the relay's
        assert "holds neither the ground station's nor the operator's signing key" in ctl(
            "--credentials", str(creds["plain"] / who))
    assert "--credentials goes with --connect" in _error(capsys, [
        "ctl", "--run-dir", str(tmp_path), "--credentials", str(creds["plain"] / "ground"),
        "recall", "auv2"])


def test_connect_names_the_missions_vehicles_and_the_bus_transport(creds, capsys) -> None:
    ground = str(creds["plain"] / "ground")
    assert "no vehicle 'auv9' in this mission; it has auv1, auv2" in _error(
        capsys, ["ctl", "--connect", "127.0.0.1:1", "--credentials", ground, "pause", "auv9"])
    # plain logins stay on loopback; TLS credentials take no plain TCP off it
    assert "holds plain logins, for one host over loopback" in _error(
        capsys, ["ctl", "--connect", "10.0.0.9:7447", "--credentials", ground, "pause",
                 "auv1"])
    assert "across machines the bus is TLS; use tls/10.0.0.9:7447" in _error(
        capsys, ["ctl", "--connect", "tcp/10.0.0.9:7447", "--credentials",
                 str(creds["tls"] / "ground"), "pause", "auv1"])


def test_connect_to_no_router_is_one_line_and_exit_2(creds, capsys) -> None:
    endpoint = free_tcp_endpoint()  # nobody listens there
    err = _error(capsys, ["ctl", "--connect", endpoint, "--credentials",
                          str(creds["plain"] / "ground"), "recall", "auv2"])
    assert f"cannot reach the mission's router at {endpoint}" in err and ".rs:" not in err
