"""Fleet size: the acoustic wire's limit (255 vehicles) is the one cap, and every command
that would go beyond it stops with one line and exit code 2."""

from __future__ import annotations

import json

import pytest

from cotsfleet.cli import main
from cotsfleet.commands.mission_args import MAX_PRESET_VEHICLES
from fleet_agent.wire import MAX_VEHICLES


def _one_line_error(capsys, command: str) -> str:
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"cotsfleet {command}: error:") and "\n" not in err
    return err


def test_the_preset_cap_is_the_wires() -> None:
    assert MAX_PRESET_VEHICLES == MAX_VEHICLES == 255


@pytest.mark.parametrize("vehicles", ["0", "256", "1000"])
def test_scenario_refuses_a_fleet_the_wire_cannot_carry(vehicles: str, capsys) -> None:
    assert main(["scenario", "--vehicles", vehicles, "--spots", "10", "--area-m", "3000"]) == 2
    assert "1..255" in _one_line_error(capsys, "scenario")


def test_scenario_makes_a_fleet_at_the_limit(tmp_path) -> None:
    out = tmp_path / "s.json"
    assert main(["scenario", "--vehicles", "255", "--spots", "20", "--area-m", "3000",
                 "-o", str(out)]) == 0
    assert len(json.loads(out.read_text())["vehicles"]) == 255


def test_sim_refuses_a_preset_beyond_the_limit(capsys) -> None:
    assert main(["sim", "--vehicles", "256"]) == 2
    assert "1..255" in _one_line_error(capsys, "sim")


def test_sim_refuses_a_scenario_file_beyond_the_limit(tmp_path, capsys) -> None:
    out = tmp_path / "big.json"
    assert main(["scenario", "--vehicles", "255", "--spots", "10", "--area-m", "3000",
                 "-o", str(out)]) == 0
    doc = json.loads(out.read_text())
    doc["vehicles"].append(dict(doc["vehicles"][0], id="one-too-many"))
    out.write_text(json.dumps(doc))
    assert main(["sim", "--scenario", str(out)]) == 2
    assert "at most 255" in _one_line_error(capsys, "sim")
