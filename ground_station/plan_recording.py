"""`cotsfleet plan --rrd FILE`: the planner's routes on the map and its convergence history,
the analogs of the paper's Fig. 6 (routes over the COTS field), Fig. 7 (cost per vehicle and
total per iteration) and Fig. 8 (violation and T_diff per vehicle per iteration).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import numpy as np
import rerun as rr

from ground_station import palette
from ground_station.blueprint import plan_blueprint
from ground_station.mapview import MapLayers, map_layers
from ground_station.rerun_log import log_map
from hfc_core.formats.scenario import problem_to_dict
from hfc_core.model.plan import plan_to_dict
from hfc_core.model.problem import Problem
from hfc_core.result import SolveResult

TIMELINE = "iteration"
TOTAL_COLOR: palette.Rgb = (110, 110, 110)  # readable on the plot's light and dark themes


def plan_layers(problem: Problem, scenario: Mapping[str, Any] | None = None) -> MapLayers:
    """The problem's map; the COTS field comes from the scenario document when given."""
    doc = problem_to_dict(problem)
    if scenario is not None and scenario.get("cots_map") is not None:
        doc["cots_map"] = scenario["cots_map"]
    return map_layers(doc)


def _routes(rec: rr.RecordingStream, problem: Problem, result: SolveResult) -> None:
    owner = np.full(problem.n_tasks, -1)
    for v, route in enumerate(result.plan.routes):
        owner[list(route)] = v
        veh = problem.vehicles[v]
        pts = [veh.start[:2], *(problem.tasks[t].pos[:2] for t in route), veh.rendezvous[:2]]
        rec.log(f"map/routes/{rr.escape_entity_path_part(veh.id)}", rr.LineStrips2D(
            [pts], colors=palette.vehicle_color(v), labels=[veh.id], show_labels=True,
            radii=rr.components.Radius.ui_points(1.5), draw_order=20.0), static=True)
    colors = [palette.vehicle_color(o) if o >= 0 else palette.SPOT_ABANDONED for o in owner]
    rec.log("map/spots", rr.Points2D.from_fields(colors=colors), static=True)


def _series(rec: rr.RecordingStream, path: str, iterations: np.ndarray, values: np.ndarray,
            name: str, color: palette.Rgb) -> None:
    rec.log(path, rr.SeriesLines(names=name, colors=color, widths=2.0), static=True)
    rec.send_columns(path, indexes=[rr.TimeColumn(TIMELINE, sequence=iterations)],
                     columns=rr.Scalars.columns(scalars=values))


def _convergence(rec: rr.RecordingStream, problem: Problem, result: SolveResult) -> None:
    history = result.history
    if not history:
        return
    iters = np.array([h.iteration for h in history], dtype=np.int64)
    for field in ("cost", "violation_s", "t_diff_s"):
        table = np.array([getattr(h, field) for h in history], dtype=float)  # (iters, k)
        for v, veh in enumerate(problem.vehicles):
            _series(rec, f"convergence/{field}/{rr.escape_entity_path_part(veh.id)}", iters,
                    table[:, v], veh.id, palette.vehicle_color(v))
        if field == "cost":
            _series(rec, "convergence/cost/total", iters, table.sum(axis=1), "total",
                    TOTAL_COLOR)
    _series(rec, "convergence/priority", iters, np.array([h.priority for h in history]),
            "priority", palette.SPOT_CLAIMED)


def summary_markdown(problem: Problem, result: SolveResult) -> str:
    doc = plan_to_dict(problem, result.plan)
    rows = "\n".join(
        f"| {v['id']} | {len(v['route'])} | {v['priority']:.0f} | {v['mission_time_s']:.0f} | "
        f"{v['t_diff_s']:+.1f} | {v['violation_s']:.1f} |" for v in doc["vehicles"])
    return (
        f"### {problem.name}: mode {result.mode}, seed {result.seed}\n"
        f"{result.iterations} iterations in {result.elapsed_s:.2f} s; "
        f"{doc['tasks_completed']}/{doc['tasks_total']} spots, priority "
        f"{doc['priority_collected']:.0f}/{doc['priority_total']:.0f}, "
        f"{'feasible' if doc['feasible'] else 'INFEASIBLE'}\n\n"
        "| vehicle | spots | priority | time (s) | T_diff (s) | violation (s) |\n"
        "|---|---|---|---|---|---|\n" + rows + "\n"
    )


def record_plan(problem: Problem, result: SolveResult, path: str | Path,
                scenario: Mapping[str, Any] | None = None) -> None:
    """Write ``path`` (.rrd): static map and routes, convergence on the ``iteration``
    timeline, a summary, and the layout to open it with."""
    layers = plan_layers(problem, scenario)
    rec = rr.RecordingStream("cotsfleet-plan", recording_id=f"plan-{problem.name}-{result.seed}")
    rr.set_log_time_enabled(False, recording=rec)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    rec.set_sinks(rr.FileSink(Path(path)), default_blueprint=plan_blueprint(layers.bounds))
    log_map(rec, layers)
    _routes(rec, problem, result)
    _convergence(rec, problem, result)
    rec.log("summary", rr.TextDocument(summary_markdown(problem, result),
                                       media_type="text/markdown"), static=True)
    rec.flush(timeout_sec=30.0)
    rec.disconnect()
