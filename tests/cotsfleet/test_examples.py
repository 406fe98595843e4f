"""The files in examples/ are current, load with the product's own loaders, and say what they
claim (the agent TOML documents every field, with the defaults)."""

import dataclasses
import importlib.util
import json
import re
from pathlib import Path

import pytest
from shapely.geometry import LineString, shape

from comms_sim.config import load_config as load_channel
from cotsfleet.cli import main
from cotsfleet.geo import LocalFrame
from cotsfleet.geo.export import plan_geojson
from cotsfleet.io import read_scenario
from fleet_agent.config import AgentConfig
from fleet_agent.config import load_config as load_agent
from hfc_core.solve import solve

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
REEF = EXAMPLES / "green_island_reef.geojson"


def test_example_scenario_is_what_the_reef_gives(tmp_path, capsys):
    out = tmp_path / "s.json"
    assert main(["scenario", "--from-geojson", str(REEF), "-o", str(out)]) == 0
    assert "60 spots, 3 AUVs" in capsys.readouterr().out
    committed = json.loads((EXAMPLES / "green_island.json").read_text())
    assert json.loads(out.read_text()) == committed, "regenerate examples/green_island.json"


def test_example_reef_is_regenerated_by_its_script(tmp_path, monkeypatch):
    spec = importlib.util.spec_from_file_location("build_reef",
                                                  EXAMPLES / "build_example_reef.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(module, "OUT", tmp_path / "reef.geojson")
    module.main()
    assert json.loads((tmp_path / "reef.geojson").read_text()) == json.loads(REEF.read_text())


def test_example_reef_looks_like_a_survey_off_cairns():
    doc = json.loads(REEF.read_text())
    roles = [f["properties"]["role"] for f in doc["features"]]
    assert roles.count("cots") == 60 and roles.count("land") == 1 and roles.count("no_go") == 1
    assert roles.count("truth") >= 10 and "start" in roles and "rendezvous" in roles
    for f in doc["features"]:
        for lon, lat, *_ in shape(f["geometry"]).exterior.coords if f["properties"][
                "role"] in ("land", "no_go") else [f["geometry"]["coordinates"]]:
            assert 145.9 < lon < 146.1 and -16.85 < lat < -16.7


def test_example_plan_keeps_off_the_reef_flat():
    problem, doc = read_scenario(EXAMPLES / "green_island.json")
    result = solve(problem, "best", seed=0, max_iterations=30)
    out = plan_geojson(problem, result.plan.routes, LocalFrame.of_scenario(doc), doc)
    polygons = [shape(f["geometry"]) for f in json.loads(REEF.read_text())["features"]
                if f["properties"]["role"] in ("land", "no_go")]
    routes = [f for f in out["features"] if f["properties"]["role"] == "route"]
    assert sum(len(r["properties"]["tasks"]) for r in routes) >= 30
    for r in routes:
        line = LineString(r["geometry"]["coordinates"])
        assert all(p.relate_pattern(line, "FF*******") for p in polygons)


def test_example_agent_toml_documents_every_field_with_its_default():
    text = (EXAMPLES / "agent.toml").read_text()
    assert load_agent(EXAMPLES / "agent.toml") == AgentConfig()
    lines = text.splitlines()
    for field in dataclasses.fields(AgentConfig):
        at = next(i for i, line in enumerate(lines) if re.match(rf"{field.name}\s*=", line))
        commented = "#" in lines[at] or lines[at - 1].lstrip().startswith("#")
        assert commented, f"{field.name} has no comment in examples/agent.toml"


def test_example_channel_toml_loads():
    config = load_channel(EXAMPLES / "channel.toml")
    assert config.extra_loss == pytest.approx(0.1) and len(config.partitions) == 1
