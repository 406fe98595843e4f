"""`cotsfleet sim` on a dynamic scenario (a truth section): the report says what the fleet did
on the real reef, with and without discovery, with extra loss."""

from __future__ import annotations

import json

import pytest

from cotsfleet.cli import main
from reef_sim.truth import reef_from_doc
from hfc_core.formats.scenario import problem_from_dict


@pytest.fixture(scope="module")
def scenario(tmp_path_factory):
    path = tmp_path_factory.mktemp("dyn") / "S.json"
    assert main(["scenario", "--paper", "--dynamic", "--seed", "0", "-o", str(path)]) == 0
    return path


def sim(scenario, tmp_path, *extra: str) -> dict:
    out = tmp_path / "R.json"
    assert main(["sim", "--scenario", str(scenario), "--seed", "1", "--report", str(out),
                 *extra]) == 0
    return json.loads(out.read_text())


@pytest.mark.parametrize("extra", [(), ("--no-discovery",), ("--loss", "0.3")],
                         ids=["fleet", "no-discovery", "loss"])
def test_sim_reports_the_real_reef(scenario, tmp_path, extra):
    doc = json.loads(scenario.read_text())
    reef = reef_from_doc(doc, problem_from_dict(doc))
    r = sim(scenario, tmp_path, *extra)
    d, f = r["dynamic"], r["fleet"]
    assert d["truth_priority"] == pytest.approx(reef.total_priority(), abs=0.01)
    spots = {t["spot"] for t in d["treated"]}
    assert spots and all(0 <= s < len(reef.spots) for s in spots)
    # every treated spot is real (an empty predicted spot is never "treated")
    assert f["priority"] == pytest.approx(sum(reef.spots[s].priority for s in spots), abs=0.05)
    assert f["duplicate_treatments"] == 0 == len(d["treated"]) - len(spots)
    assert d["empty_inspected"] > 0
    if "--no-discovery" in extra:
        assert d["spots_discovered"] == 0 and d["unmapped_treated"] == 0
    else:
        assert d["spots_discovered"] > 0 and d["unmapped_treated"] > 0
    assert {t["vehicle"] for t in d["treated"]} <= {"auv1", "auv2", "auv3"}


def test_discovery_collects_more_than_the_plan_alone(scenario, tmp_path):
    fleet = sim(scenario, tmp_path)["fleet"]["priority"]
    baseline = sim(scenario, tmp_path, "--no-discovery")["fleet"]["priority"]
    assert fleet > baseline


def test_a_sweep_over_a_dynamic_scenario_works_the_real_reef(scenario, tmp_path):
    """Each seed of `sim --runs` builds the same mission a single run does, hidden reef and
    `--no-discovery` included."""
    from cotsfleet.cli import build_parser
    from cotsfleet.commands.mission_args import mission_args
    from cotsfleet.sweep import SweepSpec, build_mission

    args = build_parser().parse_args(["sim", "--scenario", str(scenario), "--runs", "2",
                                      "--no-discovery"])
    spec = SweepSpec.from_args(args)
    want, got = mission_args(args, seed=4), build_mission(spec, 4)
    assert got.reef is not None and got.reef == want.reef
    assert not got.config.discovery
    out = tmp_path / "sweep"
    assert main(["sim", "--scenario", str(scenario), "--runs", "2", "--jobs", "1",
                 "--out", str(out)]) == 0
    runs = json.loads((out / "sweep.json").read_text())
    assert len(runs) == 2 and all("dynamic" in r and r["dynamic"]["treated"] for r in runs)
