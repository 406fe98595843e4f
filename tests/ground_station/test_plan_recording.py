"""`record_plan`: routes and convergence of a real solve, read back from the .rrd."""

from __future__ import annotations

import numpy as np
import pytest
from rerun.chunk import RrdReader

from ground_station import palette
from ground_station.plan_recording import record_plan
from ground_station.recording_reader import read_recording
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.solve import solve


@pytest.fixture(scope="module")
def recorded(tmp_path_factory, paper_doc):
    problem = problem_from_dict(paper_doc)
    result = solve(problem, "hfc-cm", max_iterations=15, seed=2)
    path = tmp_path_factory.mktemp("plan") / "plan.rrd"
    record_plan(problem, result, path, scenario=paper_doc)
    return problem, result, path, read_recording(path, timeline="iteration")


def test_routes_run_start_spots_rendezvous(recorded):
    problem, result, _, ents = recorded
    for v, route in enumerate(result.plan.routes):
        veh = problem.vehicles[v]
        (strip,) = ents[f"/map/routes/{veh.id}"].static["LineStrips2D:strips"]
        expected = [veh.start[:2], *(problem.tasks[t].pos[:2] for t in route), veh.rendezvous[:2]]
        np.testing.assert_allclose(strip, expected)


def test_spots_are_coloured_by_vehicle_or_left_out(recorded):
    problem, result, _, ents = recorded
    colors = ents["/map/spots"].static["Points2D:colors"]
    owner = {t: v for v, route in enumerate(result.plan.routes) for t in route}
    rgba = lambda c: (c[0] << 24) | (c[1] << 16) | (c[2] << 8) | 0xFF  # noqa: E731
    for t in range(problem.n_tasks):
        want = palette.vehicle_color(owner[t]) if t in owner else palette.SPOT_ABANDONED
        assert colors[t] == rgba(want)
    assert "/map/field" in ents, "the paper scenario's COTS field is under the routes"


def test_convergence_series_match_the_history(recorded):
    problem, result, _, ents = recorded
    assert len(result.history) >= 2
    for field in ("cost", "violation_s", "t_diff_s"):
        for v, veh in enumerate(problem.vehicles):
            got = ents[f"/convergence/{field}/{veh.id}"].series("Scalars:scalars")
            assert [(t, x[0]) for t, x in got] == [
                (float(h.iteration), getattr(h, field)[v]) for h in result.history]
    total = ents["/convergence/cost/total"].series("Scalars:scalars")
    np.testing.assert_allclose([x[0] for _, x in total], [sum(h.cost) for h in result.history])


def test_summary_and_layout_travel_with_the_file(recorded):
    problem, result, path, ents = recorded
    text = ents["/summary"].static["TextDocument:text"][0]
    assert f"mode {result.mode}" in text and problem.vehicles[0].id in text
    assert RrdReader(path).blueprints()


def test_a_problem_without_a_field_still_records(tmp_path, small_doc):
    small_doc.pop("forbidden")  # routing around land is the planner's business, not ours
    problem = problem_from_dict(small_doc)
    result = solve(problem, "hfc-cm", max_iterations=5, seed=0)
    record_plan(problem, result, tmp_path / "small.rrd")
    ents = read_recording(tmp_path / "small.rrd", timeline="iteration")
    assert "/map/field" not in ents
    assert len(ents["/map/spots"].static["Points2D:positions"]) == problem.n_tasks
