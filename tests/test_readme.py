"""The README's commands run as written (issue 32: a README that drifts from the CLI fails).

Every shell command in README.md's ``sh`` blocks and docs/index.md's quick paths runs in a
temporary directory, in order (a command may use what an earlier one wrote): the cheap ones
for real, made quicker only where their budget is a knob (a planner's time limit or
iterations, a sweep's number of runs); the ones that start a mission or a server (`run`,
`python -m ...`, `make demo`) as far as their argument parsing, the program's own parser
stopped right after it (`parse_only`), which refuses an option that does not exist. Inline
commands in README.md and docs/*.md (`cotsfleet ...`, `python -m ...` in backticks) are often
fragments (`cotsfleet run --listen`), so for them only options and commands that do not exist
fail. And the README's figure of the modem's hearing range is the channel model's.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import re
import runpy
import shlex
import sys
from pathlib import Path

import pytest

from cotsfleet.cli import main

REPO = Path(__file__).resolve().parents[1]
DOCS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
# What the README's commands read from the repository (relative paths, as a user on a clone).
LINKED = ("examples", "benchmarks")
# Python entry points the docs name (each parses its arguments with argparse).
MODULES = ("fleet_agent", "comms_sim", "comms_sim.router", "ground_station",
           "fleet_agent.helms.moos_mission", "fleet_agent.helms.ros2_vehicle")
# Commands that are not ours to run: the package manager, the viewer binary, the test suite.
NOT_OURS = ("pip", "rerun", "make test", "make bench")
PARSE_ERRORS = ("unrecognized arguments", "invalid choice", "ambiguous option")

pytestmark = pytest.mark.slow


# -- reading the docs ------------------------------------------------------------------------


def shell_commands(path: Path, heading: str | None = None) -> list[str]:
    """The commands of ``path``'s ``sh`` blocks (under ``heading`` only, if given): one per
    line, continuation lines joined, comments dropped, ``a && b`` as two commands."""
    text = path.read_text(encoding="utf-8")
    if heading is not None:
        text = text.split(heading, 1)[1].split("\n## ", 1)[0]
    out = []
    for block in re.findall(r"```sh\n(.*?)```", text, flags=re.S):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split(" #", 1)[0].strip()
            if line and not line.startswith("#"):
                out += [part.strip() for part in line.split("&&")]
    return out


def inline_commands(path: Path) -> list[str]:
    text = path.read_text(encoding="utf-8")
    return [m for m in re.findall(r"`([^`\n]+)`", text)
            if re.match(r"(cotsfleet|python -m) ", m) and "..." not in m]  # ...: elided


def cotsfleet_argv(command: str) -> list[str] | None:
    argv = shlex.split(command)
    if argv and argv[0] in ("cotsfleet", ".venv/bin/cotsfleet"):
        return argv[1:]
    return None


# -- running them --------------------------------------------------------------------------


@contextlib.contextmanager
def parse_only():
    """argparse stops right after parsing: a program runs as far as its options and no
    further (exit 0), or says which option it refuses (exit 2)."""
    real = argparse.ArgumentParser.parse_args

    def parse_and_stop(self, args=None, namespace=None):
        real(self, args, namespace)
        raise SystemExit(0)

    argparse.ArgumentParser.parse_args = parse_and_stop  # type: ignore[method-assign]
    try:
        yield
    finally:
        argparse.ArgumentParser.parse_args = real  # type: ignore[method-assign]


def parse(argv: list[str]) -> tuple[int, str]:
    """``argv`` (``cotsfleet ...`` or ``python -m MODULE ...``) parsed by its own program:
    (exit code, what it said on stderr)."""
    err = io.StringIO()
    with parse_only(), contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            if argv[0] in ("cotsfleet", ".venv/bin/cotsfleet"):
                code = main(argv[1:])
            else:
                assert argv[:2] == ["python", "-m"], argv
                module = argv[2]
                assert module in MODULES, f"a module the docs name is not known here: {module}"
                saved = sys.argv
                sys.argv = [module, *argv[3:]]
                for name in (module, f"{module}.__main__"):  # run afresh, as `python -m` does
                    if name != module or not hasattr(sys.modules.get(name), "__path__"):
                        sys.modules.pop(name, None)
                try:
                    runpy.run_module(module, run_name="__main__", alter_sys=True)
                finally:
                    sys.argv = saved
                code = 0
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
    return code, err.getvalue()


def cheaper(argv: list[str]) -> list[str]:
    """The same command with a smaller budget where the budget is a knob: a planner's time
    or iterations, a compare's, a sweep's number of runs (and never a cluster)."""
    argv = list(argv)
    command = argv[0]
    if command == "plan":
        for flag in ("--time-limit", "--iterations"):
            if flag in argv:
                i = argv.index(flag)
                del argv[i:i + 2]
        mode = argv[argv.index("--mode") + 1] if "--mode" in argv else "best"
        argv += ["--time-limit", "0.3"] if mode == "best" else ["--iterations", "3"]
    elif command == "compare":
        argv += ["--quick", "--best-time-limit", "0.3"]
    elif command == "sim" and "--runs" in argv:
        i = argv.index("--runs")
        argv[i + 1] = "2"
    return argv


def expensive(argv: list[str]) -> bool:
    """A mission of processes, an order to one, or a sweep on a Dask cluster: parsed, not
    run."""
    return argv[0] in ("run", "ctl") or "--scheduler" in argv


@pytest.fixture
def workdir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    for name in LINKED:
        (tmp_path / name).symlink_to(REPO / name)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("TMPDIR", str(tmp_path))  # where sim's default --out goes
    return tmp_path


def run_commands(commands: list[str], workdir: Path) -> list[str]:
    """Every command, in order; returns how each was checked."""
    done = []
    for command in commands:
        if command.startswith(NOT_OURS):
            if command.startswith("rerun "):  # it replays what an earlier command recorded
                assert (workdir / shlex.split(command)[1]).is_file(), command
            done.append(f"not ours: {command}")
            continue
        if command == "make demo":
            for line in make_demo(workdir):
                code, err = parse(line)
                assert code == 0, f"make demo: {' '.join(line)}: {err}"
            done.append("parsed: make demo")
            continue
        argv = cotsfleet_argv(command)
        if argv is None or expensive(argv):
            code, err = parse(shlex.split(command))
            assert code == 0, f"{command}: {err}"
            done.append(f"parsed: {command}")
            continue
        try:
            code = main(cheaper(argv))
        except SystemExit as exc:  # --version, --help
            code = exc.code
        assert code == 0, command
        done.append(f"ran: {command}")
    return done


def make_demo(workdir: Path) -> list[list[str]]:
    """The cotsfleet commands of the Makefile's demo recipe, its run directory here."""
    text = (REPO / "Makefile").read_text(encoding="utf-8")
    recipe = text.split("\ndemo:", 1)[1].split("\n\n", 1)[0]
    commands = []
    for part in recipe.replace("\\\n", " ").split("&&"):
        part = part.strip()
        if "/bin/cotsfleet " in part:
            part = part.replace("$$dir", str(workdir / "demo"))
            argv = shlex.split(part)
            commands.append(["cotsfleet", *argv[1:]])
    (workdir / "demo").mkdir()
    assert [c[1] for c in commands] == ["scenario", "run"], commands
    return commands


# -- the tests -------------------------------------------------------------------------------


def test_the_readmes_commands_run_as_written(workdir: Path, capsys) -> None:
    commands = shell_commands(REPO / "README.md")
    assert len(commands) > 25 and "make demo" in commands
    done = run_commands(commands, workdir)
    capsys.readouterr()
    ran = [d for d in done if d.startswith("ran:")]
    assert len(ran) >= 15, done
    for name in ("s.json", "d.json", "r.json", "r.md", "r0.md", "r-priority.png", "paper.json",
                 "plan.json", "reef.json", "plan.geojson", "plan.rrd", "big.json"):
        assert (workdir / name).is_file(), name
    assert (workdir / "creds").is_dir() and (workdir / "sweep" / "sweep.md").is_file()


def test_the_quick_paths_of_the_docs_index_run_as_written(workdir: Path, capsys) -> None:
    commands = shell_commands(REPO / "docs" / "index.md", "## Quick paths")
    assert commands and any(c.startswith("cotsfleet run") for c in commands)
    done = run_commands(commands, workdir)
    capsys.readouterr()
    assert (workdir / "r.md").is_file() and any(d.startswith("parsed: cotsfleet run")
                                                for d in done)


@pytest.mark.parametrize("path", DOCS, ids=lambda p: p.name)
def test_inline_commands_name_options_that_exist(path: Path) -> None:
    """`python -m fleet_agent --id auv2 --scenario S.json` in the README: the agent has no
    --scenario. Fragments (an option without its value, a required one left out) are fine."""
    wrong = []
    for command in inline_commands(path):
        try:
            argv = shlex.split(command)
        except ValueError:
            wrong.append(f"{command}: not a shell command")
            continue
        if argv[:2] == ["python", "-m"] and argv[2] not in MODULES:
            continue  # benchmarks and scripts: not the product's commands
        try:
            code, err = parse(argv)
        except ImportError as exc:  # e.g. the ROS 2 helm without rclpy
            pytest.skip(f"{command}: {exc}")
        if code != 0 and any(e in err for e in PARSE_ERRORS):
            wrong.append(f"{command}: {err.strip().splitlines()[-1]}")
    assert wrong == []


def test_the_readmes_hearing_range_is_the_channel_models() -> None:
    """The README said "a hard 3 km" where `cotsfleet link` says nothing is heard beyond
    4448 m: one definition, the channel's hearing range (`ChannelConfig.horizon_m`)."""
    from comms_sim.config import PRESETS

    text = (REPO / "README.md").read_text(encoding="utf-8")
    assert "hard 3 km" not in text
    km = re.search(r"hearing range, beyond which nothing is heard \(([\d.]+) km for the "
                   r"default `psk_1k`", text)
    assert km is not None
    assert float(km.group(1)) == round(PRESETS["psk_1k"].horizon_m / 1000.0, 1)
    glossary = (REPO / "docs" / "glossary.md").read_text(encoding="utf-8")
    assert f"{round(PRESETS['psk_1k'].horizon_m)} m for the default" in glossary
