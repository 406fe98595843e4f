import json

import pytest

from cotsfleet.cli import main
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.cotsmap import cots_map_of


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


# -- large areas (--area-m): compact aggregations over kilometres -------------------------------


def _xy(doc):
    import numpy as np

    return np.array([t["pos"][:2] for t in doc["tasks"]], dtype=float)


def _groups(xy, link_m=50.0):
    """Sizes of the groups of spots chained by gaps of at most ``link_m``."""
    import numpy as np
    from scipy.cluster.hierarchy import fcluster, linkage

    return np.bincount(fcluster(linkage(xy, "single"), link_m, "distance"))[1:]


def _median_5nn_m(xy):
    import numpy as np
    from scipy.spatial import cKDTree

    return float(np.median(cKDTree(xy).query(xy, 6)[0][:, 5]))


def test_large_area_scenario_of_the_issue(tmp_path, capsys):
    from cotsfleet.schemas import validate

    out = tmp_path / "area.json"
    assert main(["scenario", "--vehicles", "24", "--spots", "600", "--area-m", "3000",
                 "--battery-s", "7200", "--seed", "1", "-o", str(out)]) == 0
    said = capsys.readouterr().out
    assert "600 spots in 24 aggregations" in said and "note:" not in said  # all reachable
    doc = json.loads(out.read_text())
    validate(doc, "scenario")
    p = problem_from_dict(doc)
    assert p.n_tasks == 600 and p.n_vehicles == 24
    assert {(v.start, v.rendezvous, v.battery_s) for v in p.vehicles} == {
        ((1500.0, 1500.0, 0.0), (1500.0, 1500.0, 0.0), 7200.0)}  # one station, the centre
    xy = _xy(doc)
    assert xy.min() >= 0 and xy.max() <= 3000
    assert xy.min(axis=0).max() < 600 and xy.max(axis=0).min() > 2400  # spread over the area
    groups = _groups(xy)
    assert 20 <= (groups >= 10).sum() <= 24  # separate aggregations, not one blob
    assert groups[groups >= 10].sum() >= 0.9 * 600
    assert _median_5nn_m(xy) < 50  # as dense as the paper's (30 spots within r = 32-40 m)


def test_large_area_keeps_clusters_where_the_field_generator_blurs_them(tmp_path):
    """The reason for a second generator: eq. 1's 1/d tails of 24 centres over 3 km add up to
    one broad blob (`--size`), the mixture of aggregations does not (`--area-m`)."""
    a, f = tmp_path / "a.json", tmp_path / "f.json"
    common = ["--vehicles", "24", "--spots", "600", "--seed", "0"]
    assert main(["scenario", *common, "--area-m", "3000", "-o", str(a)]) == 0
    assert main(["scenario", *common, "--size", "3000", "-o", str(f)]) == 0
    area, field = _xy(json.loads(a.read_text())), _xy(json.loads(f.read_text()))
    assert _median_5nn_m(area) < 0.6 * _median_5nn_m(field)
    in_aggregations = [g[g >= 10].sum() / 600 for g in (_groups(area), _groups(field))]
    assert in_aggregations[0] > 0.9 and in_aggregations[1] < 0.5


def test_spots_and_tasks_are_the_same_flag(tmp_path):
    for extra in ([], ["--area-m", "2500"]):
        a, b = tmp_path / "a.json", tmp_path / "b.json"
        assert main(["scenario", "--tasks", "40", *extra, "-o", str(a)]) == 0
        assert main(["scenario", "--spots", "40", *extra, "-o", str(b)]) == 0
        assert a.read_text() == b.read_text() and len(json.loads(a.read_text())["tasks"]) == 40


def test_large_area_is_seeded(tmp_path):
    files = [tmp_path / f"{i}.json" for i in range(3)]
    for path, seed in zip(files, ("4", "4", "5")):
        assert main(["scenario", "--area-m", "4000", "--spots", "120", "--vehicles", "6",
                     "--centres", "9", "--service-s", "70", "--speed-mps", "1.5",
                     "--seed", seed, "-o", str(path)]) == 0
    assert files[0].read_text() == files[1].read_text() != files[2].read_text()
    doc = json.loads(files[0].read_text())
    assert (_groups(_xy(doc)) >= 5).sum() <= 9 and doc["speed_mps"] == 1.5
    assert {t["service_s"] for t in doc["tasks"]} == {70.0}
    assert doc["name"] == "area4000m-6auv-120spots-seed4"


def test_out_of_reach_spots_are_counted_as_the_planner_sees_them(tmp_path, capsys):
    out = tmp_path / "far.json"
    assert main(["scenario", "--area-m", "6000", "--spots", "200", "--vehicles", "4",
                 "--battery-s", "3600", "-o", str(out)]) == 0
    doc = json.loads(out.read_text())
    p = problem_from_dict(doc)
    alone = [p.route_time_s(0, [i]) for i in range(p.n_tasks)]  # station, spot, station
    far = sum(t > p.vehicles[0].battery_s for t in alone)
    assert 0 < far < 200
    assert f"note: {far} spot(s) lie beyond a round trip" in capsys.readouterr().out


@pytest.mark.parametrize("argv", [
    ["--area-m", "3000", "--paper"], ["--area-m", "3000", "--size", "900"],
    ["--area-m", "3000", "--land-forbidden"], ["--area-m", "0"], ["--area-m", "nan"],
    ["--area-m", "3000", "--centres", "0"], ["--area-m", "3000", "--spots", "-1"],
    ["--area-m", "3000", "--battery-s", "-1"], ["--area-m", "3000", "--service-s", "-5"],
    ["--area-m", "3000", "--from-geojson", "reef.geojson"],
])
def test_bad_large_area_flags_exit_2_with_one_line(argv, capsys):
    assert main(["scenario", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cotsfleet scenario: error:") and "\n" not in err


def test_a_large_area_mission_plans_and_flies(tmp_path, assert_feasible):
    from cotsfleet.mission.inprocess import simulate
    from hfc_core.solve import solve

    out = tmp_path / "area.json"
    assert main(["scenario", "--vehicles", "5", "--spots", "60", "--area-m", "2000",
                 "--battery-s", "3600", "--seed", "3", "-o", str(out)]) == 0
    p = problem_from_dict(json.loads(out.read_text()))
    solve(p, "best", max_iterations=30, seed=0)  # checked feasible by the autouse fixture
    report = simulate(p, seed=3).report
    assert report.fleet.spots_cleared > 0 and report.fleet.duplicate_treatments == 0
    assert report.fleet.vehicles_home == 5


# -- dynamic missions (--dynamic): the map and the hidden reef it predicts ----------------------


def test_dynamic_paper_preset_is_the_demo_scenario(tmp_path, capsys):
    from cotsfleet.io import read_scenario
    from reef_sim.scenarios.dynamic import dynamic_preset_doc
    from reef_sim.scenarios.field import paper_preset_doc
    from reef_sim.truth import reef_from_doc

    out = tmp_path / "dyn.json"
    assert main(["scenario", "--paper", "--dynamic", "--seed", "2", "-o", str(out)]) == 0
    said = capsys.readouterr().out
    assert json.loads(out.read_text()) == dynamic_preset_doc(2)
    problem, doc = read_scenario(out)  # schema, problem and reef all accept it
    reef = reef_from_doc(doc, problem)
    assert doc["tasks"] == paper_preset_doc(2)["tasks"]  # the prior is the static scenario's
    total = sum(t["priority"] for t in doc["tasks"])
    assert (f"truth: 67 of 90 predicted spots hold COTS (23 empty), 12 unmapped "
            f"aggregation(s); real priority {reef.total_priority():.0f} vs the map's "
            f"{total:.0f}") in said


def test_static_scenarios_carry_no_truth(tmp_path, capsys):
    out = tmp_path / "s.json"
    assert main(["scenario", "--paper", "--seed", "2", "-o", str(out)]) == 0
    assert "truth" not in json.loads(out.read_text())
    assert "truth:" not in capsys.readouterr().out


def test_dynamic_knobs_reach_the_truth(tmp_path):
    from reef_sim.truth import reef_from_doc

    out = tmp_path / "dyn.json"
    assert main(["scenario", "--dynamic", "--tasks", "40", "--vehicles", "2", "--size", "600",
                 "--empty-share", "0.5", "--priority-error", "0", "--unmapped", "7",
                 "--unmapped-spread-m", "20", "--p-detect", "0.6", "--detect-radius-m", "12",
                 "--inspect-s", "35", "--seed", "9", "-o", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["name"] == "generated-dynamic-seed9" and len(doc["vehicles"]) == 2
    reef = reef_from_doc(doc, problem_from_dict(doc))
    assert (reef.p_detect, reef.detect_radius_m, reef.inspect_s) == (0.6, 12.0, 35.0)
    assert len(reef.empty(40)) == 20 and len(reef.unmapped()) == 7
    for s in reef.spots:  # no priority error: the map's priorities where it is right
        if s.task is not None:
            assert s.priority == doc["tasks"][s.task]["priority"]


def test_dynamic_large_area(tmp_path, capsys):
    from reef_sim.truth import reef_from_doc

    out = tmp_path / "area.json"
    assert main(["scenario", "--area-m", "3000", "--vehicles", "6", "--spots", "180",
                 "--dynamic", "--seed", "1", "-o", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["name"] == "area3000m-6auv-180spots-dynamic-seed1"
    reef = reef_from_doc(doc, problem_from_dict(doc))
    assert len(reef.unmapped()) == 24 and len(reef.empty(180)) == 45
    assert "truth: 135 of 180 predicted spots" in capsys.readouterr().out


@pytest.mark.parametrize("argv, message", [
    (["--dynamic", "--empty-share", "1.5"], "--empty-share must be in 0..1, got 1.5"),
    (["--dynamic", "--empty-share", "nan"], "--empty-share must be in 0..1, got nan"),
    (["--dynamic", "--priority-error", "-0.2"], "--priority-error must be >= 0, got -0.2"),
    (["--dynamic", "--unmapped", "-1"], "--unmapped must be an integer >= 0, got -1"),
    (["--dynamic", "--unmapped-spread-m", "0"], "--unmapped-spread-m must be positive"),
    (["--dynamic", "--p-detect", "1.2"], "--p-detect must be in 0..1, got 1.2"),
    (["--dynamic", "--detect-radius-m", "-3"], "--detect-radius-m must be >= 0, got -3.0"),
    (["--dynamic", "--inspect-s", "inf"], "--inspect-s must be >= 0, got inf"),
    (["--empty-share", "0.3"], "--empty-share: only with --dynamic"),
    (["--unmapped", "3"], "--unmapped: only with --dynamic"),
    (["--p-detect", "0.5"], "--p-detect: only with --from-geojson or --dynamic"),
    (["--simplify-m", "5"], "--simplify-m: only with --from-geojson"),
    (["--dynamic", "--from-geojson", "reef.geojson"], "--dynamic: not with --from-geojson"),
])
def test_bad_dynamic_flags_exit_2_with_one_line(argv, message, capsys):
    assert main(["scenario", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cotsfleet scenario: error:") and "\n" not in err
    assert message in err


def _with_truth(tmp_path, change):
    from reef_sim.scenarios.dynamic import dynamic_preset_doc

    doc = dynamic_preset_doc(0)
    change(doc["truth"])
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))  # NaN is written as the NaN literal Python reads back
    return path


MALFORMED_TRUTH = {
    "priority NaN": (lambda t: t["spots"][3].update(priority=float("nan")),
                     "truth.spots[3].priority: must be finite"),
    "pos as text": (lambda t: t["spots"][1].update(pos="here"),
                    "truth.spots[1].pos: expected array, got string 'here'"),
    "no such task": (lambda t: t["spots"][5].update(task=999),
                     "truth.spots[5].task: no task 999 in the scenario"),
    "two spots, one task": (lambda t: t["spots"][7].update(task=t["spots"][2]["task"]),
                            "truth.spots[7].task: task 2 is already named by truth.spots[2]"),
    "p_detect above 1": (lambda t: t.update(p_detect=1.5), "truth.p_detect: must be <= 1"),
    "p_detect NaN": (lambda t: t.update(p_detect=float("nan")), "truth.p_detect: must be finite"),
    "negative radius": (lambda t: t.update(detect_radius_m=-1.0),
                        "truth.detect_radius_m: must be >= 0"),
    "task as text": (lambda t: t["spots"][0].update(task="12"),
                     "truth.spots[0].task: expected integer or null"),
}


@pytest.mark.parametrize("how", list(MALFORMED_TRUTH))
def test_a_malformed_truth_stops_every_command_with_exit_2(how, tmp_path, capsys):
    change, message = MALFORMED_TRUTH[how]
    path = _with_truth(tmp_path, change)
    assert main(["plan", str(path), "--mode", "hfc-cm", "--iterations", "3"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"cotsfleet plan: error: {path}: ") and "\n" not in err
    assert message in err


def test_a_scenario_with_truth_still_plans(tmp_path, capsys):
    path = _with_truth(tmp_path, lambda t: None)
    assert main(["plan", str(path), "--mode", "hfc-cm", "--iterations", "3"]) == 0
