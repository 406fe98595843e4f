"""`cotsfleet compare`: progress with an ETA on stderr as each mode finishes, any scenario,
clean failures on bad files."""

import io
import re
from pathlib import Path

import pytest

from cotsfleet.cli import main
from cotsfleet.commands.compare import available_modes
from cotsfleet.reporting.progress import Progress

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "green_island.json"
QUICK = ["--quick", "--best-time-limit", "0.3"]


def test_progress_line_per_mode_with_eta(capsys):
    assert main(["compare", *QUICK]) == 0
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    modes = available_modes()
    assert len(lines) == len(modes)
    for i, (line, mode) in enumerate(zip(lines, modes), start=1):
        assert re.match(rf"compare: {i}/{len(modes)} {mode} \d+/90 spots in [\d.]+ s "
                        r"\[\d\d:\d\d elapsed, ETA \d\d:\d\d\]$", line), line
    assert lines[-1].endswith("ETA 00:00]")
    assert "paper (Table I" in captured.out and "compare:" not in captured.out


def test_compare_your_own_scenario(capsys):
    assert main(["compare", "--scenario", str(EXAMPLE), *QUICK]) == 0
    out = capsys.readouterr().out
    assert out.startswith("green-island-reef: 60 COTS spots, 3 AUVs")
    assert re.search(r"best\s+total .* \d+/60", out) and "paper (Table I" not in out


@pytest.mark.parametrize("content,message", [
    (None, "no such file"), ("{oops", "not valid JSON"),
    ('{"name": "x", "speed_mps": 1, "vehicles": [], "tasks": []}',
     "vehicles: needs at least 1 item(s), got 0")])
def test_bad_scenario_files_exit_2(content, message, tmp_path, capsys):
    path = tmp_path / "s.json"
    if content is not None:
        path.write_text(content)
    assert main(["compare", "--scenario", str(path), *QUICK]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cotsfleet compare: error:") and "\n" not in err and message in err


@pytest.mark.parametrize("limit", ["0", "-1", "nan"])
def test_bad_time_limit_exits_2(limit, capsys):
    assert main(["compare", "--best-time-limit", limit]) == 2
    assert "--best-time-limit" in capsys.readouterr().err


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_draws_a_bar_on_a_terminal():
    stream = _Terminal()
    with Progress(2, "compare", "mode", stream=stream) as progress:
        progress.start("ga")
        progress.done("ga", "49/90 spots")
        progress.start("best")
    text = stream.getvalue()
    assert "compare: ga: 0/2 modes" in text and "compare: best: 1/2 modes" in text
    assert "ga 49/90 spots" in text and "\n" not in text.strip("\r ")
