"""The mission report as a typed tree: `to_dict` is report.json as it always was (golden
reports written before the tree existed), `from_dict` reads it back or says what is wrong."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from cotsfleet.cli import build_parser, main
from cotsfleet.commands.mission_args import mission_args
from cotsfleet.mission.inprocess import simulate
from cotsfleet.mission.report_model import (
    FailedRun,
    MissionReport,
    ReportError,
    run_from_dict,
    runs_from_list,
)

DATA = Path(__file__).parent / "data" / "reports"
# Written by `cotsfleet sim` before the typed tree (commit 819a5fc), and by `cotsfleet run`
# (run7-kill: the process backend's sections: clock, security, exit codes).
GOLDEN = ("paper7-kill", "dynamic4-abort", "run7-kill")
# Fields added since: a defect fix (issue 32: "10 of 4 aggregations the map missed found"),
# and what drove each vehicle (issue 28: its helm, the navigation fixes its agent used).
ADDED = {"dynamic.unmapped_found", "vehicles.0.nav_fixes", "vehicles.0.helm"}


def golden(name: str) -> dict[str, Any]:
    return json.loads((DATA / f"{name}.report.json").read_text())


def differences(old: Any, new: Any, path: str = "") -> list[str]:
    """Every field that differs, by its dotted path (fields only in ``new``: ``+path``)."""
    if isinstance(old, dict) and isinstance(new, dict):
        out = [f"-{path}{k}" for k in old if k not in new]
        out += [f"+{path}{k}" for k in new if k not in old]
        for k in old.keys() & new.keys():
            out += differences(old[k], new[k], f"{path}{k}.")
        return out
    if isinstance(old, list) and isinstance(new, list) and len(old) == len(new):
        return [d for i, (a, b) in enumerate(zip(old, new))
                for d in differences(a, b, f"{path}{i}.")]
    return [] if old == new and type(old) is type(new) else [f"{path.rstrip('.')}: {old!r} "
                                                             f"-> {new!r}"]


def shape(doc: Any, path: str = "") -> set[str]:
    """Every field's dotted path and type (lists by their first element; maps of numbers,
    such as counters by name, as one field): what a reader of report.json relies on,
    whatever the mission's figures."""
    if isinstance(doc, dict) and doc and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in doc.values()):
        return {f"{path.rstrip('.')}: map"}
    if isinstance(doc, dict):
        return {p for k, v in doc.items() for p in shape(v, f"{path}{k}.")} | {path}
    if isinstance(doc, list):
        return shape(doc[0], f"{path}0.") if doc else {f"{path}[]"}
    kind = "number" if isinstance(doc, (int, float)) and not isinstance(doc, bool) else \
        type(doc).__name__
    return {f"{path.rstrip('.')}: {kind}"}


def simulated(argv: list[str]) -> MissionReport:
    m = mission_args(build_parser().parse_args(["sim", *argv]))
    return simulate(m.problem, m.config, seed=m.seed, loss=m.loss, faults=m.faults,
                    reef=m.reef).report


def test_paper_preset_seed_7_gives_report_json_with_todays_fields() -> None:
    """The figures move with the fleet's logic (the golden report predates per-vehicle
    frame authentication); the fields and their types do not."""
    new = simulated(["--seed", "7", "--kill", "auv2@1200"]).to_dict()
    added = {p for p in shape(new) - shape(golden("paper7-kill"))
             if not any(p.startswith(f) for f in ADDED)}
    assert added == set() and shape(golden("paper7-kill")) <= shape(new)


def test_a_dynamic_mission_gives_report_json_with_todays_fields(tmp_path: Path) -> None:
    scenario = tmp_path / "d4.json"
    assert main(["scenario", "--paper", "--dynamic", "--seed", "4", "-o", str(scenario)]) == 0
    new = simulated(["--scenario", str(scenario), "--abort", "auv2@1200"]).to_dict()
    added = {p for p in shape(new) - shape(golden("dynamic4-abort"))
             if not any(p.startswith(f) for f in ADDED)}
    assert added == set() and shape(golden("dynamic4-abort")) <= shape(new)


@pytest.mark.parametrize("name", GOLDEN)
def test_a_report_json_reads_back_to_the_same_document(name: str) -> None:
    doc = golden(name)
    report = MissionReport.from_dict(doc, name)
    assert report.to_dict() == doc
    assert json.dumps(report.to_dict()) == json.dumps(doc)  # same field order, same values
    assert MissionReport.read(DATA / f"{name}.report.json") == report


def test_readers_get_attributes_not_keys() -> None:
    report = MissionReport.from_dict(golden("run7-kill"))
    assert report.fleet.spots_total == 90 and report.vehicle("auv3").killed
    assert report.clock is not None and report.clock.effective_warp == 118.71
    assert report.security is not None and report.security.relay == {}
    assert report.slowest_detection_s == 29.0 and report.dynamic is None
    c = report.collected
    assert (c.spots, c.spots_of, c.on_reef) == (50, 90, False)
    d = MissionReport.from_dict(golden("dynamic4-abort")).collected
    assert (d.spots, d.spots_of, d.priority, d.on_reef) == (45, 79, 3057.73, True)


def test_unknown_top_level_fields_are_kept_unknown_nested_ones_refused() -> None:
    doc = {**golden("paper7-kill"), "from_a_newer_writer": {"x": [1, 2]}}
    report = MissionReport.from_dict(doc)
    assert report.other == {"from_a_newer_writer": {"x": [1, 2]}}
    assert report.to_dict() == doc
    bad = golden("paper7-kill")
    bad["fleet"]["spotz_cleared"] = 3
    with pytest.raises(ReportError, match=r"r.json: .*unknown field `spotz_cleared`.*\$.fleet"):
        MissionReport.from_dict(bad, "r.json")


@pytest.mark.parametrize("change,message", [
    (lambda d: d["fleet"].update(spots_total="90"), "Expected `int`, got `str` - at "
                                                    "`$.fleet.spots_total`"),
    (lambda d: d.pop("messages"), "not a mission report (no messages)"),
    (lambda d: d["vehicles"][0].pop("state"), "missing required field `state` - at "
                                              "`$.vehicles[0]`"),
    (lambda d: d["faults"].append({"kind": "kill"}), "missing required field `vid`"),
])
def test_a_bad_report_is_one_clear_error(change, message: str) -> None:
    doc = golden("paper7-kill")
    change(doc)
    with pytest.raises(ReportError) as err:
        MissionReport.from_dict(doc, "r.json")
    assert str(err.value).startswith("r.json: ") and message in str(err.value)


def test_not_a_report_at_all() -> None:
    with pytest.raises(ReportError, match="expected an object, got list"):
        MissionReport.from_dict([1], "x.json")
    with pytest.raises(ReportError, match="not valid JSON"):
        MissionReport.read(Path(__file__))  # Python is not JSON


def test_a_sweeps_json_reads_back_with_its_failures() -> None:
    runs = [golden("paper7-kill"), {"seed": 9, "error": "RuntimeError('x')", "run_s": 0.1}]
    got = runs_from_list(runs, "s.json")
    assert isinstance(got[0], MissionReport) and isinstance(got[1], FailedRun)
    assert [r.to_dict() for r in got] == runs
    with pytest.raises(ReportError, match=r"s.json\[1\]: not a failed run"):
        runs_from_list([runs[0], {"seed": "nine", "error": "x"}], "s.json")
    with pytest.raises(ReportError, match="non-empty list"):
        runs_from_list([], "s.json")
    assert run_from_dict(runs[1]).seed == 9


def test_without_the_relays_counters_the_report_says_unknown_not_zero() -> None:
    """With the relay gone at the end, `run` reported "0 receptions" and "By the relay: none";
    its counters are null now, in messages and in security."""
    import numpy as np

    from cotsfleet.mission.report import build_report
    from fleet_bus.ledger import FleetLedger
    from hfc_core.formats.scenario import problem_from_dict
    from reef_sim.scenarios.field import GeneratorParams, generate_doc

    problem = problem_from_dict(generate_doc(GeneratorParams(n_tasks=5, n_vehicles=2),
                                             np.random.default_rng(0)))
    security = {"refused_total": 0, "operator": {}, "relay": {}, "agents": {}}
    gone = build_report(problem, FleetLedger(), None, [], mode="run", seed=0, end_s=10.0,
                        extra={"security": security})
    assert gone.messages.link is None and gone.messages.link_by_sender == {}
    assert gone.security is not None and gone.security.relay is None
    doc = gone.to_dict()
    assert doc["messages"]["link"] is None and doc["security"]["relay"] is None
    assert MissionReport.from_dict(doc) == gone
    there = build_report(problem, FleetLedger(), {}, [], mode="run", seed=0, end_s=10.0,
                         extra={"security": security})
    assert there.messages.link is not None and there.security.relay == {}


def test_a_vehicle_killed_twice_has_both_kills_detected_and_no_false_alarm() -> None:
    """A fault fuzz (preset seed 59: auv3 killed at 950 s, restarted at 1253 s, killed again
    at 1556 s) reported 2 false alarms: the report kept the last kill only, so the first
    kill's detections (984 s, 986 s) counted as alarms about a live vehicle. A 'lost' before
    any kill still is one."""
    import numpy as np

    from cotsfleet.mission.faults import Fault
    from cotsfleet.mission.report import build_report
    from fleet_bus.ledger import FleetLedger
    from fleet_bus.states import EventKind
    from fleet_bus.telemetry import Event
    from hfc_core.formats.scenario import problem_from_dict
    from reef_sim.scenarios.field import GeneratorParams, generate_doc

    problem = problem_from_dict(generate_doc(GeneratorParams(n_tasks=5, n_vehicles=3),
                                             np.random.default_rng(0)))
    faults = [Fault("kill", 950.0, "auv3"), Fault("restart", 1253.0, "auv3"),
              Fault("kill", 1556.0, "auv3"), Fault("restart", 2229.0, "auv3")]
    ledger = FleetLedger()
    for t, who in ((900.0, "auv1"), (984.0, "auv2"), (986.0, "auv1"), (1591.0, "auv2")):
        ledger.add_event(Event(t, who, EventKind.LOST, peer="auv3", detail="silent"))
    report = build_report(problem, ledger, {}, faults, mode="sim", seed=0, end_s=3000.0)
    assert report.fleet.false_alarms == 1  # the one at 900 s, before any kill
    assert report.fleet.detection_delay_s["auv3"] == {"auv1": None, "auv2": 35.0}
