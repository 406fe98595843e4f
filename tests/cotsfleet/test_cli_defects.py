"""What a newcomer tripped on (issue 32, "Commands that fail or surprise"): each one is a
clear line and exit code 2, or does what a user expects, never a traceback."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from cotsfleet.cli import build_parser, main
from reef_sim.scenarios.field import GeneratorParams, generate_doc

REPO = Path(__file__).resolve().parents[2]


def one_line_error(capsys: pytest.CaptureFixture, command: str) -> str:
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"cotsfleet {command}: error: ") and "\n" not in err, err
    assert "Traceback" not in err
    return err


@pytest.fixture
def small(tmp_path: Path) -> Path:
    doc = generate_doc(GeneratorParams(name="small", n_tasks=12, n_vehicles=2, size_m=400.0,
                                       battery_s=900.0, service_s=60.0),
                       np.random.default_rng(1))
    path = tmp_path / "small.json"
    path.write_text(json.dumps(doc))
    return path


@pytest.fixture
def no_spots(small: Path, tmp_path: Path) -> Path:
    doc = json.loads(small.read_text())
    doc["tasks"] = []
    path = tmp_path / "empty.json"
    path.write_text(json.dumps(doc))
    return path


def test_a_scenario_without_spots_is_refused_when_made(tmp_path, capsys) -> None:
    assert main(["scenario", "--tasks", "0", "-o", str(tmp_path / "s.json")]) == 2
    assert "--tasks must be at least 1" in one_line_error(capsys, "scenario")
    assert not (tmp_path / "s.json").exists()


@pytest.mark.parametrize("argv", [
    ["plan", "{s}", "--time-limit", "0.2"],
    ["compare", "--scenario", "{s}", "--quick"],
    ["sim", "--scenario", "{s}", "--out", "{d}/out"],
    ["run", "--scenario", "{s}", "--viewer", "none", "--run-dir", "{d}/run"],
])
def test_a_scenario_file_without_spots_is_one_line_everywhere(argv, no_spots, tmp_path,
                                                             capsys) -> None:
    """plan, sim and compare ended in the planner's traceback (argmax of an empty
    sequence), run in one squashed line from a dead agent."""
    args = [a.format(s=no_spots, d=tmp_path) for a in argv]
    assert main(args) == 2
    assert "the scenario has no COTS spot" in one_line_error(capsys, argv[0])
    assert not (tmp_path / "run").exists()  # refused before anything started


def test_abbreviated_options_are_errors_not_guesses(capsys) -> None:
    """`--kil auv3@1200` ran as `--kill` (argparse abbreviations)."""
    with pytest.raises(SystemExit) as exc:
        build_parser().parse_args(["sim", "--kil", "auv3@1200"])
    assert exc.value.code == 2
    assert "unrecognized arguments: --kil" in capsys.readouterr().err
    for prefix in ("--scen", "--rep"):
        with pytest.raises(SystemExit):
            build_parser().parse_args(["sim", prefix, "x"])


def test_every_parser_refuses_abbreviations() -> None:
    parser = build_parser()
    subparsers = next(a for a in parser._actions if a.__class__.__name__ ==
                      "_SubParsersAction")
    assert not parser.allow_abbrev
    assert all(not p.allow_abbrev for p in subparsers.choices.values())
    from ground_station.__main__ import parse_args

    with pytest.raises(SystemExit):
        parse_args(["--rr", "x.rrd"])


def test_version(capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    version = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]
    assert capsys.readouterr().out.strip().startswith(f"cotsfleet {version}")
    import cotsfleet

    assert cotsfleet.__version__ == version


@pytest.mark.parametrize("command", ["sim", "run", "credentials"])
def test_vehicles_with_a_scenario_file_is_refused_not_ignored(command, small, tmp_path,
                                                              capsys) -> None:
    args = {"sim": ["sim", "--scenario", str(small), "--vehicles", "5"],
            "run": ["run", "--scenario", str(small), "--vehicles", "5", "--viewer", "none",
                    "--run-dir", str(tmp_path / "run")],
            "credentials": ["credentials", str(tmp_path / "creds"), "--scenario", str(small),
                            "--vehicles", "5"]}[command]
    assert main(args) == 2
    err = one_line_error(capsys, command)
    assert "--vehicles 5: not with --scenario" in err and "cotsfleet scenario --vehicles 5" in err


@pytest.mark.parametrize("argv,flag", [
    (["run", "--viewer", "none", "--rrd", "{d}/nowhere/m.rrd"], "--rrd"),
    (["run", "--viewer", "none", "--report", "{d}/nowhere/r.json"], "--report"),
    (["run", "--viewer", "none", "--run-dir", "{d}/nowhere/run"], "--run-dir"),
    (["sim", "--report", "{d}/nowhere/r.json"], "--report"),
    (["sim", "--out", "{d}/nowhere/out"], "--out"),
    (["plan", "{s}", "--json", "{d}/nowhere/p.json"], "--json"),
    (["scenario", "-o", "{d}/nowhere/s.json"], "-o"),
    (["link", "--plot", "{d}/nowhere/l.png"], "--plot"),
])
def test_output_paths_are_checked_alike_before_anything_runs(argv, flag, small, tmp_path,
                                                             capsys) -> None:
    """`--rrd /nonexistent/m.rrd` created /nonexistent while `plan --json` refused such a
    path: one rule now (`cotsfleet.commands.checks`), before any work."""
    assert main([a.format(d=tmp_path, s=small) for a in argv]) == 2
    err = one_line_error(capsys, argv[0])
    assert f"{flag} {tmp_path}/nowhere" in err and "no such directory" in err
    assert not (tmp_path / "nowhere").exists()


def test_a_reports_json_ends_in_json(tmp_path, capsys) -> None:
    """Its Markdown and figures are named after it (r.json: r.md, r-*.png)."""
    assert main(["sim", "--report", str(tmp_path / "r.txt")]) == 2
    assert "ends in .json" in one_line_error(capsys, "sim")


def test_two_sims_in_one_directory_keep_both_reports(small, tmp_path, monkeypatch) -> None:
    """`sim --report r.json` then `sim --report r0.json` wrote report.md and the plots into the
    working directory twice: the first was lost."""
    monkeypatch.chdir(tmp_path)
    assert main(["sim", "--scenario", str(small), "--report", "r.json"]) == 0
    assert main(["sim", "--scenario", str(small), "--report", "r0.json", "--no-discovery",
                 "--seed", "3"]) == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    for stem in ("r", "r0"):
        assert {f"{stem}.json", f"{stem}.md", f"{stem}-priority.png", f"{stem}-timeline.png",
                f"{stem}-link.png", f"{stem}-events.jsonl", f"{stem}-scenario.json"} <= \
            set(names), names
    assert "seed 3" in (tmp_path / "r0.md").read_text()
    assert "seed 3" not in (tmp_path / "r.md").read_text()
    assert not (tmp_path / "report.md").exists()
    # and `cotsfleet report` finds what it needs to draw r0 again, beside it
    assert main(["report", "r0.json", "-o", "again"]) == 0
    assert (tmp_path / "again" / "r0-timeline.png").is_file()


def test_native_viewer_without_a_display_falls_back_to_the_web_viewer(monkeypatch) -> None:
    from ground_station import viewer

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    chosen, note = viewer.resolve_viewer("native")
    assert chosen == "web" and note is not None and "no display" in note
    assert "\n" not in note
    assert viewer.resolve_viewer("none") == ("none", None)
    assert viewer.resolve_viewer(None) == ("web", None)
    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setattr(viewer.shutil, "which", lambda name: "/usr/bin/rerun")
    assert viewer.resolve_viewer("native") == ("native", None)


def test_the_ground_station_refuses_an_rrd_nowhere_before_connecting(tmp_path) -> None:
    target = tmp_path / "nowhere" / "m.rrd"
    proc = subprocess.run([sys.executable, "-m", "ground_station", "--viewer", "none",
                           "--rrd", str(target), "--connect", "tcp/127.0.0.1:9"],
                          capture_output=True, text=True, timeout=60,
                          env={**os.environ, "PYTHONPATH": str(REPO)})
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip() == (f"ground_station: --rrd {target}: no such directory "
                                   f"{str(target.parent)!r}")
    assert not target.parent.exists()
