import json

import pytest

from cotsfleet.cli import main
from hfc_core.cotsmap import cots_map_of
from hfc_core.scenario import problem_from_dict


def test_paper_preset_to_file(tmp_path, capsys):
    out = tmp_path / "paper.json"
    assert main(["scenario", "--paper", "--seed", "2", "-o", str(out)]) == 0
    doc = json.loads(out.read_text())
    p = problem_from_dict(doc)
    assert p.n_tasks == 90 and p.n_vehicles == 3
    assert cots_map_of(doc) is not None
    assert "90 spots" in capsys.readouterr().out


def test_generic_scenario_to_stdout(capsys):
    assert main(["scenario", "--tasks", "12", "--vehicles", "2", "--size", "400",
                 "--service", "30", "--seed", "5"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert len(doc["tasks"]) == 12 and len(doc["vehicles"]) == 2
    assert {t["service_s"] for t in doc["tasks"]} == {30.0}
    assert doc["name"] == "generated-seed5"


def test_same_seed_same_file(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    main(["scenario", "--paper", "-o", str(a)])
    main(["scenario", "--paper", "-o", str(b)])
    assert a.read_text() == b.read_text()


@pytest.mark.parametrize(
    "argv",
    [["--tasks", "-1"], ["--vehicles", "0"], ["--speed", "0"], ["--battery", "nan"],
     ["--battery", "-5"], ["--size", "inf"], ["--paper", "--size", "500"],
     ["--service", "-1"], ["-o", "/nonexistent-dir/x.json"]],
)
def test_bad_flags_exit_2_with_one_line(argv, capsys):
    assert main(["scenario", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cotsfleet scenario: error:") and "\n" not in err


def test_unit_named_flags_are_the_same_as_the_short_ones(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    assert main(["scenario", "--tasks", "6", "--battery", "900", "--speed", "1.5",
                 "--service", "40", "-o", str(a)]) == 0
    assert main(["scenario", "--tasks", "6", "--battery-s", "900", "--speed-mps", "1.5",
                 "--service-s", "40", "-o", str(b)]) == 0
    doc = json.loads(b.read_text())
    assert a.read_text() == b.read_text()
    assert doc["speed_mps"] == 1.5 and doc["vehicles"][0]["battery_s"] == 900.0


def test_written_scenarios_fit_the_schema(tmp_path):
    from cotsfleet.schemas import validate

    out = tmp_path / "s.json"
    assert main(["scenario", "--tasks", "30", "--land-forbidden", "-o", str(out)]) == 0
    validate(json.loads(out.read_text()), "scenario")
