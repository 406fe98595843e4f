"""The insider attacks (`cotsfleet.mission.insider`): a vehicle's leaked credentials used
against the fleet, in process; each costs at most the insider's own share (issue 31)."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from cotsfleet.cli import build_parser, main
from cotsfleet.commands.mission_args import mission_args
from cotsfleet.mission.faults import Fault, FaultError, parse_faults
from cotsfleet.mission.inprocess import InProcessBackend, simulate
from cotsfleet.mission.insider import Insider, insider_rng
from cotsfleet.mission.report_model import MissionReport
from fleet_agent.config import AgentConfig
from fleet_agent.wire import Abort, Claim, ClearedSegment, Found
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import paper_preset_doc


def sim(argv: list[str]) -> MissionReport:
    m = mission_args(build_parser().parse_args(["sim", *argv]))
    return simulate(m.problem, m.config, seed=m.seed, loss=m.loss, faults=m.faults,
                    reef=m.reef).report


@lru_cache(maxsize=None)
def unattacked() -> float:
    return sim(["--seed", "7"]).fleet.priority


def insider_of(dynamic: bool = False) -> tuple[Insider, InProcessBackend]:
    doc = paper_preset_doc(7)
    backend = InProcessBackend(problem_from_dict(doc), AgentConfig(), seed=7)
    chains = backend.fleet.chains
    assert chains is not None and chains.seeds is not None
    return Insider(backend.problem, backend.fleet.codec, chains, backend.config, 0,
                   chains.seeds[0], insider_rng(7, 0)), backend


def test_an_insider_attack_names_its_insider() -> None:
    with pytest.raises(FaultError, match="--insider"):
        parse_faults(attacks=["claim-all@600"])
    with pytest.raises(FaultError, match="no insider attack"):
        parse_faults(attacks=["forge@600"], insider="auv1")
    f, = parse_faults(attacks=["phantom@600"], insider="auv1")
    assert (f.kind, f.vid, f.value) == ("phantom", "auv1", 24)
    assert "by insider auv1" in f.describe()
    with pytest.raises(FaultError):
        Fault("all-cleared", 600.0)


def test_the_cli_refuses_an_unknown_insider_and_a_busy_hold_in_process(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "--seed", "7", "--attack", "claim-all@600", "--insider", "auv9"]) == 2
    assert "unknown vehicle" in capsys.readouterr().err
    assert main(["sim", "--seed", "7", "--attack", "busy-hold@600", "--insider", "auv1"]) == 2
    assert "paced clock" in capsys.readouterr().err


def test_the_frames_say_what_each_attack_says() -> None:
    insider, backend = insider_of()
    codec = backend.fleet.codec
    cleared = [codec.unseal(f).msg for f in insider.frames("all-cleared", 600.0)]
    assert all(isinstance(m, ClearedSegment) and m.sender == 0 for m in cleared)
    assert len(cleared) == codec.n_segments
    claims = [codec.unseal(f).msg for f in insider.frames("claim-all", 600.0)]
    assert all(isinstance(m, Claim) and m.sender == 1 for m in claims)  # in auv2's name
    assert sorted(t for m in claims for t in m.tasks) == list(range(codec.n_tasks))
    aborts = [codec.unseal(f).msg for f in insider.frames("abort-as", 600.0)]
    assert [(type(m), m.sender, m.who) for m in aborts] == [(Abort, 1, 1), (Abort, 0, 1)]
    assert insider.frames("phantom", 600.0) == []  # no finds in a mission without discovery


def test_phantoms_are_finds_in_the_insiders_top_slots(tmp_path: Path) -> None:
    scenario = tmp_path / "d7.json"
    assert main(["scenario", "--paper", "--dynamic", "--seed", "7", "-o", str(scenario)]) == 0
    m = mission_args(build_parser().parse_args(["sim", "--scenario", str(scenario)]))
    backend = InProcessBackend(m.problem, m.config, seed=7, reef=m.reef)
    chains = backend.fleet.chains
    assert chains is not None and chains.seeds is not None
    insider = Insider(m.problem, backend.fleet.codec, chains, backend.config, 0,
                      chains.seeds[0], np.random.default_rng(0))
    finds = [backend.fleet.codec.unseal(insider.frames("phantom", 600.0 + i)[0]).msg
             for i in range(3)]
    assert all(isinstance(f, Found) and f.priority == 500.0 for f in finds)
    top = m.problem.n_tasks + m.config.find_slots
    assert [f.slot for f in finds] == [top - 1, top - 2, top - 3]


def test_claims_in_its_own_name_are_refused_and_the_insider_named() -> None:
    report = sim(["--seed", "7", "--attack", "claim-own@600", "--insider", "auv1"])
    assert report.fleet.priority >= 0.99 * unattacked()
    assert report.suspects is not None and set(report.suspects) == {"auv1"}


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["all-cleared", "claim-all", "abort-as"])
def test_each_insider_attack_costs_at_most_the_insiders_share(kind: str) -> None:
    """Issue 31's check: at least 0.6 of the unattacked priority, 0 duplicates, the attack
    in the report."""
    report = sim(["--seed", "7", "--attack", f"{kind}@600", "--insider", "auv1"])
    assert report.fleet.duplicate_treatments == 0
    assert report.fleet.priority >= 0.6 * unattacked()
    assert [(f.kind, f.vid) for f in report.faults] == [(kind, "auv1")]
    if kind != "all-cleared":  # the frames in auv2's name: dropped, counted
        assert report.fleet.priority >= 0.99 * unattacked()
        assert sum(report.messages.dropped_by_agents.values()) > 0

