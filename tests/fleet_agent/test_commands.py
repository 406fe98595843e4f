"""`cotsfleet sim` / `cotsfleet run` argument handling and the agent config file."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from cotsfleet.cli import main
from fleet_agent.config import AgentConfig, config_from_dict, dump_config, load_config


def test_config_round_trips_through_toml(tmp_path: Path) -> None:
    cfg = AgentConfig(slot_s=3.0, lost_after_cycles=4.2).with_key(bytes(range(16)))
    path = tmp_path / "agent.toml"
    path.write_text(dump_config(cfg))
    assert load_config(path) == cfg
    assert load_config(path).fleet_key == bytes(range(16))


@pytest.mark.parametrize("doc", [{"slot_s": 0}, {"claim_repeats": 0}, {"lost_after_cycles": -1},
                                 {"fleet_key_hex": "zz"}, {"fleet_key_hex": "00ff"},
                                 {"no_such_setting": 1}, {"plan_iterations": 1.5}])
def test_bad_config_is_refused_with_a_message(doc: dict) -> None:
    with pytest.raises(ValueError, match="agent config"):
        config_from_dict(doc)


def test_sim_command_monte_carlo(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    report = tmp_path / "runs.json"
    assert main(["sim", "--runs", "2", "--seed", "7", "--kill", "auv1@900",
                 "--report", str(report)]) == 0
    out = capsys.readouterr().out
    assert "mean" in out and "oracle" in out
    runs = json.loads(report.read_text())
    assert [r["seed"] for r in runs] == [7, 8]
    assert all(r["mode"] == "sim" and r["fleet"]["spots_cleared"] > 0 for r in runs)
    assert all(r["oracle"]["vid"] == "auv1" for r in runs)


@pytest.mark.parametrize("argv", [["sim", "--kill", "auv9@100"], ["sim", "--abort", "auv1"],
                                  ["sim", "--loss", "2"], ["run", "--kill", "auv7@10"],
                                  ["run", "--warp", "0"], ["sim", "--runs", "0"]])
def test_bad_arguments_exit_with_a_usage_error(argv: list[str],
                                               capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv + (["--viewer", "none"] if argv[0] == "run" else [])) == 2
    assert "error" in capsys.readouterr().err
