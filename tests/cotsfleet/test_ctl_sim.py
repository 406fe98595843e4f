"""The operator's live orders in the in-process mission (`cotsfleet sim --ctl`): through the
water from the topside modem, proven by its key chain, acted on, acknowledged, reported."""

from __future__ import annotations

import pytest

from cotsfleet.mission.faults import FaultError, check_schedule, parse_faults
from cotsfleet.mission.inprocess import simulate
from fleet_agent.config import AgentConfig
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import paper_preset_doc

CONFIG = AgentConfig(plan_iterations=100, replan_iterations=50)


@pytest.fixture(scope="module")
def problem():
    return problem_from_dict(paper_preset_doc(5))


@pytest.fixture(scope="module")
def alone(problem):
    return simulate(problem, CONFIG, seed=1)


def _home_s(result, vid: str) -> float:
    return min(e.t_s for e in result.events if e.id == vid and e.kind == "replan"
               and e.detail == "home")


def test_a_recall_brings_auv2_home_early_and_the_others_take_over(problem, alone) -> None:
    r = simulate(problem, CONFIG, seed=1, faults=parse_faults(ctls=["recall:auv2@1200"]))
    rep = r.report
    assert rep.fleet.duplicate_treatments == 0
    assert rep.fleet.vehicles_home == 3
    assert _home_s(r, "auv2") < _home_s(alone, "auv2") - 300
    assert rep.fleet.spots_taken_over > 0
    recall = [e for e in r.events if e.id == "auv2" and e.kind == "recall"]
    assert len(recall) == 1 and 1200 < recall[0].t_s <= 1200 + 3 * 30 + 5  # lag 2 intervals
    assert not [e for e in r.events if e.id != "auv2" and e.kind in ("recall", "abort")]
    c = rep.commands
    assert c is not None and [o.order for o in c.sent] == ["recall auv2"]
    assert set(c.sent[0].acked) == {"auv2"} and c.sent[0].acked["auv2"] > recall[0].t_s - 1
    assert c.taken == {"auv2": 1} and c.refused == {}


def test_an_unsigned_order_is_refused_and_counted(problem, alone) -> None:
    # An insider holds the fleet key (the frame passes the fleet MAC) but not the topside's
    # chain: its recall is proven false once the topside discloses a key, never acted on.
    r = simulate(problem, CONFIG, seed=1, faults=parse_faults(
        ctls=["unsigned:recall:auv3@600", "pause:auv1@700", "resume:auv1@760"]))
    assert not [e for e in r.events if e.kind in ("recall", "abort")]
    c = r.report.commands
    assert c is not None and c.refused.get("unsigned", 0) >= 1
    counts = {v: s.counters for v, s in r.statuses.items()}
    assert sum(n.get("ctl_unsigned", 0) for n in counts.values()) == c.refused["unsigned"]
    assert r.report.fleet.duplicate_treatments == 0


def test_pause_holds_the_vehicle_until_resume(problem, alone) -> None:
    r = simulate(problem, CONFIG, seed=1, faults=parse_faults(
        ctls=["pause:auv1@600", "resume:auv1@1200"]))
    ev = {e.kind: e.t_s for e in r.events if e.id == "auv1" and e.kind in ("pause", "resume")}
    assert 600 < ev["pause"] < 700 and 1200 < ev["resume"] < 1300
    c = r.report.commands
    assert c is not None and all(set(o.acked) == {"auv1"} for o in c.sent)
    # Held meanwhile: auv1 treats nothing between the pause and the resume.
    held = [e for e in r.events if e.id == "auv1" and e.kind == "cleared"
            and ev["pause"] + 120 < e.t_s < ev["resume"]]
    assert held == []
    assert r.report.fleet.duplicate_treatments == 0 and r.report.fleet.vehicles_home == 3


def test_drop_spot_is_done_for_everyone_and_treated_by_nobody(problem, alone) -> None:
    late = [e for e in alone.events if e.kind == "cleared" and e.t_s > 2000]
    spot = late[0].tasks[0]
    r = simulate(problem, CONFIG, seed=1, faults=parse_faults(ctls=[f"drop-spot:{spot}@300"]))
    treated = [t for e in r.events if e.kind == "cleared" for t in e.tasks]
    assert spot not in treated
    assert {e.id for e in r.events if e.kind == "dropped"} == {"auv1", "auv2", "auv3"}
    c = r.report.commands
    assert c is not None and set(c.sent[0].acked) == {"auv1", "auv2", "auv3"}


def test_a_stale_order_is_refused(problem) -> None:
    config = AgentConfig(plan_iterations=100, replan_iterations=50, ctl_max_age_s=40.0)
    r = simulate(problem, config, seed=1, faults=parse_faults(ctls=["recall:auv2@1200"]))
    assert not [e for e in r.events if e.kind == "recall"]
    c = r.report.commands
    assert c is not None and c.refused.get("stale", 0) >= 1
    assert c.sent[0].acked == {} and set(c.sent[0].refused.values()) <= {"stale"}


def test_orders_are_checked_before_the_mission(problem) -> None:
    vehicles = [v.id for v in problem.vehicles]
    with pytest.raises(FaultError, match="unknown vehicle"):
        check_schedule(parse_faults(ctls=["recall:auv9@100"]), vehicles, 4000.0)
    for bad in ("launch:auv1@100", "recall@100", "add-spot:1:2@100", "drop-spot:x@5"):
        with pytest.raises(FaultError):
            parse_faults(ctls=[bad])


def test_an_added_spot_is_planned_and_treated_once_by_one_vehicle(problem, alone) -> None:
    xyz = problem.xyz[:problem.n_tasks]
    x, y = float(xyz[:, 0].mean()), float(xyz[:, 1].mean())
    r = simulate(problem, CONFIG, seed=1, faults=parse_faults(
        ctls=[f"add-spot:{x:.0f}:{y:.0f}:80@300"]))
    added = [e for e in r.events if e.kind == "added"]
    assert {e.id for e in added} == {"auv1", "auv2", "auv3"}
    (spot,) = {tuple(e.tasks) for e in added}  # one id fleet-wide
    treated = [e for e in r.events if e.kind == "cleared" and tuple(e.tasks) == spot]
    assert len(treated) == 1  # by one vehicle, once
    assert r.report.fleet.duplicate_treatments == 0 and r.report.fleet.vehicles_home == 3
    c = r.report.commands
    assert c is not None and set(c.sent[0].acked) == {"auv1", "auv2", "auv3"}
    assert c.sent[0].order == f"add-spot at {x:.0f},{y:.0f} priority 80" and c.refused == {}


def test_a_kill_after_an_add_spot_keeps_the_reference_replan_on_the_map(problem) -> None:
    # The perfect-information replan at a death is made on the map's spots: a survivor's
    # route holding the operator's spot (an index past them) must not break it.
    xyz = problem.xyz[:problem.n_tasks]
    x, y = float(xyz[:, 0].mean()), float(xyz[:, 1].mean())
    r = simulate(problem, CONFIG, seed=1, faults=parse_faults(
        ctls=[f"add-spot:{x:.0f}:{y:.0f}:80@300"], kills=["auv2@900"]))
    oracle = r.backend.oracle
    assert oracle["vid"] == "auv2" and oracle["priority"] > 0
    assert all(t < problem.n_tasks for t in oracle["cleared_before"])
    assert r.report.fleet.duplicate_treatments == 0
