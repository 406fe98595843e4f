"""JSON Schemas of the user's files: what they accept, what they say when a file breaks them."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from comms_sim.config import ChannelConfig, Partition, TdmaConfig
from cotsfleet.cli import main
from cotsfleet.errors import UsageError
from cotsfleet.io import read_agent_config, read_channel_config
from cotsfleet.schemas import SchemaViolation, schema, validate
from fleet_agent.config import AgentConfig
from reef_sim.scenarios.field import GeneratorParams, generate_doc, paper_preset_doc

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture
def scenario_doc() -> dict:
    params = GeneratorParams(n_tasks=8, n_vehicles=2, size_m=400.0, battery_s=900.0)
    return generate_doc(params, np.random.default_rng(2))


def _full(doc: dict) -> dict:
    """``doc`` with every optional section: forbidden, truth, current, geo."""
    doc = json.loads(json.dumps(doc))
    doc["forbidden"] = [[[390.0, 390.0], [399.0, 390.0], [399.0, 399.0]]]
    doc["truth"] = {"detect_radius_m": 25.0, "p_detect": 0.9, "inspect_s": 20.0,
                    "spots": [{"pos": [1.0, 2.0, -3.0], "priority": 57.0, "service_s": 74.2,
                               "task": 1},
                              {"pos": [5.0, 6.0, -3.0], "priority": 31.0, "service_s": 66.0,
                               "task": None}]}
    doc["current"] = {"anything": "the planner engineer decides"}
    doc["geo"] = {"crs": "EPSG:32755", "origin_m": [389180.0, 8146080.0],
                  "forbidden_roles": ["land"]}
    return doc


def test_scenarios_we_write_fit_the_schema(scenario_doc):
    validate(paper_preset_doc(1), "scenario")
    validate(_full(scenario_doc), "scenario")
    validate({**scenario_doc, "current": None}, "scenario")  # still water


@pytest.mark.parametrize("current", [
    {"kind": "uniform", "velocity_mps": [0.4, -0.2]},
    {"kind": "tidal", "velocity_mps": [0.5, 0.3], "period_s": 44712.0, "phase_s": 9000.0},
    {"kind": "grid", "origin": [0.0, 0.0], "cell_m": 100.0,
     "u": [[0.1, 0.2], [0.0, 0.1]], "v": [[0.0, 0.0], [0.1, 0.1]]},
    None])
def test_currents_the_planner_reads_load(current, scenario_doc, tmp_path):
    from cotsfleet.io import read_scenario

    path = tmp_path / "s.json"
    path.write_text(json.dumps({**scenario_doc, "current": current}))
    problem, _ = read_scenario(path)
    assert (problem.current is None) == (current is None)
    validate(json.loads((REPO / "examples" / "green_island.json").read_text()), "scenario")


BREAKS = {
    "missing pos": (lambda d: d["tasks"][3].pop("pos"), "tasks[3]: missing field 'pos'"),
    "battery as text": (lambda d: d["vehicles"][1].update(battery_s="1h"),
                        "vehicles[1].battery_s: expected number, got string '1h'"),
    "short point": (lambda d: d["vehicles"][0].update(start=[1.0]),
                    "vehicles[0].start: needs at least 2 item(s), got 1"),
    "negative priority": (lambda d: d["tasks"][0].update(priority=-2),
                          "tasks[0].priority: must be >= 0, got -2"),
    "zero speed": (lambda d: d.update(speed_mps=0), "speed_mps: must be > 0, got 0"),
    "p_detect above 1": (lambda d: d["truth"].update(p_detect=1.5),
                         "truth.p_detect: must be <= 1, got 1.5"),
    "truth task as text": (lambda d: d["truth"]["spots"][1].update(task="12"),
                           "truth.spots[1].task: expected integer or null"),
    "two-vertex polygon": (lambda d: d["forbidden"][0].pop(),
                           "forbidden[0]: needs at least 3 item(s), got 2"),
    "geo crs by name": (lambda d: d["geo"].update(crs="UTM 55S"),
                        "geo.crs: 'UTM 55S' does not have the expected form"),
    "geo typo": (lambda d: d["geo"].update(orign_m=[0, 0]),
                 "geo: unknown field(s) 'orign_m'"),
    "current not an object": (lambda d: d.update(current=[1, 2]),
                              "current: expected object or null, got array"),
    "not an object": (lambda d: d.clear(), "missing field 'name'"),
}


@pytest.mark.parametrize("how", list(BREAKS))
def test_plan_names_the_offending_field(how, scenario_doc, tmp_path, capsys):
    change, message = BREAKS[how]
    doc = _full(scenario_doc)
    change(doc)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    assert main(["plan", str(path), "--mode", "hfc-cm", "--iterations", "5"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"cotsfleet plan: error: {path}: ") and "\n" not in err
    assert message in err


def test_messages_never_dump_the_document(scenario_doc):
    with pytest.raises(SchemaViolation) as caught:
        validate({"name": "x", "speed_mps": 1, "vehicles": "x" * 500, "tasks": []}, "scenario")
    assert len(str(caught.value)) < 120 and caught.value.path == "vehicles"


def _props(name: str) -> set[str]:
    return set(schema(name)["properties"])


def test_agent_schema_lists_every_config_field():
    assert _props("agent") == {f.name for f in dataclasses.fields(AgentConfig)}
    validate(dataclasses.asdict(AgentConfig()), "agent")
    validate(dataclasses.asdict(AgentConfig().with_key(bytes(16))), "agent")


def test_channel_schema_lists_every_config_field():
    assert _props("channel") == {f.name for f in dataclasses.fields(ChannelConfig)} | {"preset"}
    channel = schema("channel")["properties"]
    assert set(channel["tdma"]["properties"]) == {f.name for f in dataclasses.fields(TdmaConfig)}
    partition = channel["partitions"]["items"]["properties"]
    assert {f.name for f in dataclasses.fields(Partition)} <= set(partition)


def _write(tmp_path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize("text,message", [
    ("slot_s = ", "not valid TOML"),
    ("slot = 2.5", "unknown field(s) 'slot'"),
    ("[agent]\nslot_s = -1", "slot_s: must be > 0, got -1"),
    ("plan_iterations = 'many'", "plan_iterations: expected integer, got string"),
    ("fleet_key_hex = 'abcd'", "fleet_key_hex: 'abcd' does not have the expected form"),
    ("claim_repeats = 2.5", "claim_repeats: expected integer, got number 2.5"),
])
def test_agent_config_errors_are_one_line(text, message, tmp_path):
    path = _write(tmp_path, "agent.toml", text)
    with pytest.raises(UsageError) as caught:
        read_agent_config(path)
    assert str(caught.value).startswith(f"{path}: ") and message in str(caught.value)
    assert "\n" not in str(caught.value)


def test_agent_config_file_errors(tmp_path):
    with pytest.raises(UsageError, match="no such file"):
        read_agent_config(tmp_path / "nope.toml")
    with pytest.raises(UsageError, match="is a directory"):
        read_agent_config(tmp_path)
    assert read_agent_config(_write(tmp_path, "a.toml", "[agent]\nslot_s = 3")).slot_s == 3


@pytest.mark.parametrize("name,text,message", [
    ("c.yaml", "preset: psk_1k", "must be .toml or .json"),
    ("c.toml", "preset = 'fast'", "unknown preset 'fast'"),
    ("c.toml", "preset = 3", "preset: expected string, got number 3"),
    ("c.toml", "extra_loss = 2.0", "extra_loss: must be <= 1, got 2.0"),
    ("c.json", '{"tdma": {"slot_s": 0.5}}', "cannot hold a 64-byte frame"),
    ("c.json", '{"partitions": [{"end_s": 5}]}', "partitions[0]: missing field 'groups'"),
    ("c.json", "{", "not valid JSON"),
])
def test_channel_config_errors_are_one_line(name, text, message, tmp_path):
    path = _write(tmp_path, name, text)
    with pytest.raises(UsageError) as caught:
        read_channel_config(path)
    assert message in str(caught.value) and "\n" not in str(caught.value)


def _names(node) -> set[str]:
    """Every property name anywhere in a schema."""
    if isinstance(node, dict):
        own = set(node.get("properties", {}))
        return own.union(*(_names(v) for v in node.values()))
    if isinstance(node, list):
        return set().union(*(_names(v) for v in node)) if node else set()
    return set()


@pytest.mark.parametrize("name", ["scenario", "agent", "channel"])
def test_docs_describe_every_field(name):
    text = (REPO / "docs" / "scenario.md").read_text()
    missing = sorted(n for n in _names(schema(name)) if f"`{n}`" not in text)
    assert not missing, f"docs/scenario.md does not mention {missing}"
