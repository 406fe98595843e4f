"""`cotsfleet ctl`'s bad input: one line and exit 2 (the live path is
tests/integration/test_ctl_run.py), and the run record it finds a mission by."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from cotsfleet.cli import main
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


@pytest.mark.parametrize("argv", [["ctl", "recall", "auv2"],  # no --run-dir
                                  ["ctl", "--run-di", "x", "recall", "auv2"],  # abbreviated
                                  ["ctl", "--run-dir", "x"]])  # no order
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
