"""Reports a person reads: report.md and its figures match report.json and the event log."""

import dataclasses
import json
import math

import numpy as np
import pytest
from PIL import Image

from cotsfleet.cli import main
from cotsfleet.reporting import read_events, write_report_bundle, write_sweep_summary
from cotsfleet.reporting.plots import timeline_series
from cotsfleet.reporting.sweep import METRICS, statistics_rows
from cotsfleet.reporting.timeline import (Spots, collected_over_time, down_intervals,
                                          time_shares, vehicle_segments)
from fleet_agent.config import AgentConfig
from cotsfleet.mission.faults import Fault
from cotsfleet.mission.inprocess import simulate
from reef_sim.scenarios.field import GeneratorParams, generate_doc
from hfc_core.formats.scenario import problem_from_dict

SCENARIO = GeneratorParams(n_tasks=24, n_vehicles=3, size_m=600.0, battery_s=1800.0)


@pytest.fixture(scope="module")
def mission():
    """A small simulated mission with a kill, a restart and link loss: (report, events,
    scenario document)."""
    doc = generate_doc(SCENARIO, np.random.default_rng(3))
    problem = problem_from_dict(doc)
    faults = [Fault("kill", 500.0, "auv2"), Fault("restart", 800.0, "auv2")]
    result = simulate(problem, AgentConfig(), seed=3, loss=0.2, faults=faults)
    return result.report, [dataclasses.asdict(e) for e in result.events], doc


def test_bundle_exists_and_matches_the_report(mission, tmp_path):
    report, events, doc = mission
    paths = write_report_bundle(report, tmp_path, events, doc)
    names = sorted(p.name for p in paths)
    assert names == ["link.png", "priority_over_time.png", "report.md", "vehicle_timeline.png"]
    for p in paths:
        if p.suffix == ".png":
            with Image.open(p) as img:
                assert img.format == "PNG" and img.width > 400 and img.height > 150
    text = (tmp_path / "report.md").read_text()
    f = report["fleet"]
    assert f"**Spots cleared:** {f['spots_cleared']} of {f['spots_total']} (" in text
    assert f"**Priority collected:** {f['priority']:,.1f} of {f['priority_total']:,.1f}" in text
    for v in report["vehicles"]:
        assert f"| {v['id']} | {v['state']} | {v['tasks_treated']} | {v['priority']:,.1f}" in text
    assert "| kill | auv2 | 500 |" in text and "| restart | auv2 | 800 |" in text
    link = report["messages"]["link"]
    assert f"{link['sent']:,} receptions" in text and f"{link['delivered']:,} delivered" in text
    assert f"random {link['random']:,}" in text
    for name in ("priority_over_time.png", "vehicle_timeline.png", "link.png"):
        assert f"]({name})" in text


def test_priority_over_time_ends_at_the_reported_priority(mission):
    report, events, doc = mission
    collected = collected_over_time(events, Spots.of_scenario(doc))
    assert collected.spots[-1] == report["fleet"]["spots_cleared"]
    assert collected.priority[-1] == pytest.approx(report["fleet"]["priority"], abs=0.01)
    assert collected.t_s == sorted(collected.t_s)
    per_vehicle = sum(values[-1] for _, values in collected.by_vehicle.values())
    assert per_vehicle == pytest.approx(collected.priority[-1])


def test_timeline_agrees_with_each_vehicles_figures(mission):
    """Transit time x speed is the distance the vehicle reports; injection time is the sum
    of its spots' injection times; the segments tile the mission exactly. (A killed vehicle
    is left out of the distance check: an injection cut short by the kill leaves no event,
    and the restarted agent resumes from its last checkpoint.)"""
    report, events, doc = mission
    spots = Spots.of_scenario(doc)
    segments = vehicle_segments(report, events, spots)
    speed = doc["speed_mps"]
    for v in report["vehicles"]:
        segs = segments[v["id"]]
        assert segs[0].start_s == 0.0 and segs[-1].end_s == report["end_s"]
        assert all(a.end_s == b.start_s for a, b in zip(segs, segs[1:]))
        spent = time_shares(segs)
        mine = {t for e in events if e["id"] == v["id"] and e["kind"] == "cleared"
                for t in e["tasks"]}
        assert spent["inject"] == pytest.approx(sum(spots.service_s[t] for t in mine))
        if v["home"] and not v["killed"]:
            assert spent["transit"] * speed == pytest.approx(v["distance_m"], abs=1.0)
    assert time_shares(segments["auv2"])["down"] == pytest.approx(300.0)


@pytest.mark.parametrize("faults,expected", [
    ([("kill", 100), ("restart", 300)], [(100, 300)]),
    ([("kill", 100)], [(100, 1000)]),
    ([("restart", 50), ("kill", 100)], [(100, 1000)]),  # a restart before any kill: nothing
    ([("kill", 100), ("restart", 200), ("kill", 600), ("restart", 700)], [(100, 200),
                                                                          (600, 700)]),
    ([("abort", 100)], []),
])
def test_down_intervals(faults, expected):
    report = {"faults": [{"kind": k, "vid": "a", "t_s": t} for k, t in faults]}
    assert down_intervals(report, "a", 1000.0) == [(float(a), float(b)) for a, b in expected]


def test_without_events_or_scenario_it_says_what_is_missing(mission, tmp_path):
    report, events, _ = mission
    paths = write_report_bundle(report, tmp_path / "a")
    assert [p.name for p in paths] == ["report.md", "link.png"]
    assert "no event log was given" in (tmp_path / "a" / "report.md").read_text()
    write_report_bundle(report, tmp_path / "b", events)
    text = (tmp_path / "b" / "report.md").read_text()
    assert "counts spots instead of priority" in text and "75 s" in text


def test_event_objects_are_accepted(tmp_path):
    from fleet_bus.telemetry import Event

    report = {"end_s": 200.0, "vehicles": [{"id": "a", "home": False}], "fleet": {}}
    write_report_bundle(report, tmp_path, [Event(100.0, "a", "cleared", [1])],
                        {"tasks": [{"id": 1, "priority": 5.0, "service_s": 60.0}]})
    assert "| a | 140 (70 %) | 60 (30 %) |" in (tmp_path / "report.md").read_text()


def test_missing_and_extra_fields_are_tolerated(tmp_path):
    report = {"mode": "sim", "scenario": "x", "fleet": {"spots_cleared": 1, "new_counter": 7},
              "messages": {"link": {"sent": 4, "delivered": 3, "brand_new_reason": 1},
                           "future": {"a": 1}},
              "dynamic": {"spots_found": 3, "missed": [1, 2]}, "unheard_of": {"x": 1}}
    write_report_bundle(report, tmp_path, [])
    text = (tmp_path / "report.md").read_text()
    assert "## Dynamic mission" in text and "- spots_found: 3" in text
    assert "## Other fields" in text and "- unheard_of.x: 1" in text
    assert "- new_counter: 7" in text and "brand_new_reason 1" in text
    assert "- future.a: 1" in text
    write_report_bundle({}, tmp_path / "empty")
    assert (tmp_path / "empty" / "report.md").read_text().startswith("# Mission report: ?")


def test_every_ratio_says_what_it_is_a_ratio_to(mission, tmp_path):
    report = {**mission[0], "oracle": {"vid": "auv2", "t_s": 500.0, "priority": 800.0,
                                       "collected": 820.0, "ratio": 1.025}}
    write_report_bundle(report, tmp_path, mission[1], mission[2])
    text = (tmp_path / "report.md").read_text()
    assert "1.025 times the 800.0 of a centralized replan" in text
    assert "a ratio above 1 is possible" in text
    for line in text.splitlines():
        for pct in [m for m in line.split("(")[1:] if " %" in m.split(")")[0]]:
            inside = pct.split(")")[0]
            assert " % of " in inside or line.startswith("|"), line


def test_warnings_for_false_alarms_and_duplicates(tmp_path):
    report = {"fleet": {"false_alarms": 2, "duplicate_treatments": 3, "treatments": 30},
              "interrupted": True}
    write_report_bundle(report, tmp_path)
    text = (tmp_path / "report.md").read_text()
    assert "**Warning:** 2 false alarm(s)" in text
    assert "**Warning:** 3 duplicate treatment(s): spots injected more than once (10 % of all " \
           "treatments)" in text
    assert "**Warning:** the mission was interrupted" in text


def test_link_timeline_in_either_shape():
    rows = [{"t_s": 0.0, "delivered": 1, "random": 0, "note": "x"},
            {"t_s": 60.0, "delivered": 5, "random": 2, "note": "y"}]
    columns = {"t_s": [0.0, 60.0], "delivered": [1, 5], "random": [0, 2]}
    expected = {"t_s": [0.0, 60.0], "delivered": [1.0, 5.0], "random": [0.0, 2.0]}
    assert timeline_series(rows) == expected == timeline_series(columns)
    assert timeline_series({"delivered": [1]}) is None and timeline_series(None) is None


def _sweep_reports(mission, n=5):
    report = mission[0]
    out = []
    for i in range(n):
        r = json.loads(json.dumps(report))
        r["seed"] = 10 + i
        r["fleet"]["priority"] = 100.0 * (i + 1)
        r["oracle"] = {"ratio": 0.9 + 0.05 * i}
        out.append(r)
    out.append({"seed": 99, "error": "RuntimeError: the planner fell over | badly"})
    return out


def test_sweep_summary_medians_quartiles_and_failures(mission, tmp_path):
    reports = _sweep_reports(mission)
    path = write_sweep_summary(reports, tmp_path)
    text = path.read_text()
    assert "**Failed runs:** 1 of 6" in text
    q1, med, q3 = np.percentile([100, 200, 300, 400, 500], [25, 50, 75])
    assert f"| priority collected | {med:,.1f} | {q1:,.1f} - {q3:,.1f} | 100.0 - 500.0 | 5 |" \
        in text
    assert "| 99 | - |" in text and "RuntimeError: the planner fell over / badly" in text
    for r in reports[:-1]:
        assert f"| {r['seed']} | {r['fleet']['spots_cleared']}/" in text
    assert "Note 1:" in text and "ratios above 1 are possible" in text
    rows = (tmp_path / "sweep.csv").read_text().splitlines()
    assert len(rows) == 1 + len(reports) and rows[-1].startswith("99,")


def test_statistics_leave_out_runs_without_the_figure():
    reports = [{"fleet": {"spots_cleared": 3}}, {"fleet": {"spots_cleared": 5}}]
    rows = {r[0]: r for r in statistics_rows(reports)}
    assert rows["spots cleared"][1:] == ["4", "4 - 4", "3 - 5", "2"]
    oracle = next(m for m in METRICS if m.key == "oracle_ratio")
    assert oracle.label not in rows and math.isnan(oracle.value(reports[0]))


def test_report_command_finds_events_and_scenario(mission, tmp_path, capsys):
    report, events, doc = mission
    (tmp_path / "report.json").write_text(json.dumps(report))
    (tmp_path / "scenario.json").write_text(json.dumps(doc))
    (tmp_path / "events.jsonl").write_text("".join(json.dumps(e) + "\n" for e in events))
    assert read_events(tmp_path / "events.jsonl") == events
    assert main(["report", str(tmp_path / "report.json"), "-o", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "events.jsonl" in out and "scenario.json" in out
    assert (tmp_path / "out" / "vehicle_timeline.png").is_file()
    sweep = tmp_path / "sweep.json"
    sweep.write_text(json.dumps(_sweep_reports(mission, 2)))
    assert main(["report", str(sweep)]) == 0
    assert (tmp_path / "sweep.md").is_file()


@pytest.mark.parametrize("setup,argv_extra,message", [
    (lambda d: (d / "r.json").write_text("[}"), [], "not valid JSON"),
    (lambda d: (d / "r.json").write_text('{"a": 1}'), [], "not a mission report"),
    (lambda d: (d / "r.json").write_text("[1, 2]"), [], "expected a list of mission reports"),
    (lambda d: None, [], "no such file"),
    (lambda d: ((d / "r.json").write_text('{"fleet": {}}'),
                (d / "e.jsonl").write_text('{"t_s": 1}\n{"t_s": 2}\nnope\n')),
     ["--events", "e.jsonl"], "e.jsonl:3: not JSON"),
    (lambda d: (d / "r.json").write_text('{"fleet": {}}'), ["--events", "missing.jsonl"],
     "no such file"),
    (lambda d: (d / "r.json").write_text('{"fleet": {}}'), ["--scenario", "."],
     "is a directory"),
    (lambda d: ((d / "r.json").write_text('{"fleet": {}}'), (d / "f").write_text("")),
     ["-o", "f"], "not a directory"),
])
def test_report_command_bad_input_exits_2(setup, argv_extra, message, tmp_path, capsys,
                                          monkeypatch):
    monkeypatch.chdir(tmp_path)
    setup(tmp_path)
    assert main(["report", "r.json", *argv_extra]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cotsfleet report: error:") and "\n" not in err and message in err
