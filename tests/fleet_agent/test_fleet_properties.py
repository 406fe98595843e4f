"""Fleet properties on the in-process simulation, many seeds (paper preset, 3 AUVs, 1 h)."""

from __future__ import annotations

import functools

import pytest

from cotsfleet.mission.faults import Fault
from cotsfleet.mission.inprocess import InProcessBackend, SimResult, simulate
from fleet_agent.config import AgentConfig
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.model.check import check_routes
from hfc_core.model.problem import Problem
from reef_sim.scenarios.field import paper_preset_doc

CONFIG = AgentConfig()
CYCLE_S = CONFIG.slot_s * 3  # heartbeat period of a 3-AUV fleet
SEEDS = range(6)


@functools.lru_cache(maxsize=None)
def paper(seed: int) -> Problem:
    return problem_from_dict(paper_preset_doc(seed))


@functools.lru_cache(maxsize=None)
def run(seed: int, loss: float = 0.0,
        faults: tuple[Fault, ...] = ()) -> tuple[InProcessBackend, SimResult]:
    result = simulate(paper(seed), CONFIG, seed=seed, loss=loss, faults=faults)
    return result.backend, result


def executed_routes(problem: Problem, result: SimResult) -> dict[str, list[int]]:
    """Each vehicle's treated spots in the order it treated them (from the event log)."""
    routes: dict[str, list[int]] = {v.id: [] for v in problem.vehicles}
    for e in result.events:
        if e.kind == "cleared":
            routes[e.id] += e.tasks
    return routes


def assert_knowledge_converged(result: SimResult) -> None:
    """Every agent still running knows every spot anyone treated (nothing forgotten)."""
    treated = {t for s in result.statuses.values() for t in s.treated}
    for vid, agent in result.agents.items():
        if agent is not None:
            known = {agent.problem.tasks[t].id for t in agent.know.cleared}
            assert treated <= known, f"{vid} does not know {sorted(treated - known)}"


@pytest.mark.parametrize("seed", SEEDS)
def test_without_loss_no_spot_is_treated_twice_and_all_come_home(seed: int) -> None:
    problem = paper(seed)
    _, result = run(seed)
    fleet = result.report.fleet
    assert fleet.duplicate_treatments == 0
    assert fleet.vehicles_home == problem.n_vehicles
    for v in result.report.vehicles:
        assert v.home and v.t_diff_s >= 0.0  # arrived with battery to spare
        assert v.battery_used_s <= problem.vehicles[0].battery_s
    # The independent checker agrees: no spot twice, straight-line time within the battery.
    assert check_routes(problem, executed_routes(problem, result)) == []
    assert_knowledge_converged(result)
    assert fleet.false_alarms == 0
    assert result.report.messages.largest_frame_bytes <= 64


@pytest.mark.parametrize("seed", SEEDS)
def test_thirty_percent_extra_loss_costs_little(seed: int) -> None:
    _, lossless = run(seed)
    _, lossy = run(seed, 0.3)
    f = lossy.report.fleet
    assert f.duplicate_treatments <= 0.02 * f.treatments
    assert f.spots_cleared >= 0.9 * lossless.report.fleet.spots_cleared
    assert f.vehicles_home == 3
    assert_knowledge_converged(lossy)


@pytest.mark.parametrize("seed", SEEDS)
def test_silent_kill_is_detected_in_time_and_work_is_taken_over(seed: int) -> None:
    kill = Fault("kill", 1200.0, "auv2")  # one third of the one-hour mission
    sim, result = run(seed, 0.0, (kill,))
    delays = result.report.fleet.detection_delay_s["auv2"]
    assert set(delays) == {"auv1", "auv3"}
    for vid, delay in delays.items():  # docs/wire.md: 4 cycles, a confirmer, its proof
        assert delay is not None and delay <= 6 * CYCLE_S, (vid, delay)
    oracle = result.report.oracle
    assert oracle.ratio >= 0.85, oracle
    assert result.report.fleet.duplicate_treatments == 0
    assert result.report.fleet.vehicles_home == 2


@pytest.mark.parametrize("seed", SEEDS[:3])
def test_silent_kill_under_thirty_percent_loss(seed: int) -> None:
    _, result = run(seed, 0.3, (Fault("kill", 1200.0, "auv2"),))
    # a silence needs a second observer's frame to be confirmed, and the key that proves it:
    # under loss either can be lost once more
    for vid, delay in result.report.fleet.detection_delay_s["auv2"].items():
        assert delay is not None and delay <= 8 * CYCLE_S, (vid, delay)
    assert result.report.oracle.ratio >= 0.85


@pytest.mark.parametrize("seed", SEEDS[:3])
def test_announced_abort_is_known_at_once_and_taken_over(seed: int) -> None:
    _, result = run(seed, 0.0, (Fault("abort", 1200.0, "auv2"),))
    f = result.report.fleet
    for delay in f.detection_delay_s["auv2"].values():
        # the aborting AUV's next slot, and its next frame that proves it (`tesla`)
        assert delay is not None and delay <= 2 * CYCLE_S
    assert f.spots_taken_over > 0
    assert f.duplicate_treatments == 0
    auv2 = next(v for v in result.report.vehicles if v.id == "auv2")
    assert auv2.aborted and auv2.home  # it went straight home
    lost = [e for e in result.events if e.kind == "lost" and e.peer == "auv2"]
    assert lost and all(e.detail == "aborted" for e in lost)


@pytest.mark.parametrize("seed", SEEDS[:3])
def test_killed_agent_restarts_from_its_journal_without_forgetting(seed: int) -> None:
    faults = (Fault("kill", 1200.0, "auv2"), Fault("restart", 1500.0, "auv2"))
    sim, result = run(seed, 0.0, faults)
    status_at_kill, known_at_kill = sim.at_kill["auv2"]
    agent = result.agents["auv2"]
    assert agent is not None and agent.restarted
    assert known_at_kill <= set(agent.know.cleared)  # nothing it knew is forgotten
    treated = [agent.problem.tasks[t].id for t, _ in agent.know.treated]
    assert treated[: len(status_at_kill.treated)] == status_at_kill.treated
    assert len(treated) == len(set(treated))  # and it treats none of them again
    assert result.report.fleet.duplicate_treatments == 0
    assert result.report.fleet.vehicles_home == 3
    assert_knowledge_converged(result)


@pytest.mark.parametrize("seed", SEEDS[:3])
def test_partition_that_heals(seed: int) -> None:
    _, result = run(seed, 0.0, (Fault("partition", 1000.0, "auv1", 400.0),))
    f = result.report.fleet
    assert f.vehicles_home == 3
    # Cut off for 400 s, auv1 is presumed lost by the two that still hear each other, and
    # its spots are taken; healed, it is heard again and its spots go back. On a perfect
    # link a partition looks exactly like a death: the spots it would reach within
    # takeover_wait_s wait, a later one may be treated by both (one, in one seed of three).
    assert any(e.kind == "lost" and e.peer == "auv1" for e in result.events)
    assert any(e.kind == "takeover" and e.peer == "auv1" for e in result.events)
    assert any(e.kind == "revived" and e.peer == "auv1" for e in result.events)
    assert f.duplicate_treatments <= 1
    assert_knowledge_converged(result)


@pytest.mark.parametrize("seed", SEEDS[:3])
def test_total_silence_flies_the_initial_plans(seed: int) -> None:
    """No link at all: everyone is suspected, nobody is declared lost, nothing is taken,
    and the fleet collects exactly what its initial plans collect."""
    _, result = run(seed, 1.0)
    f = result.report.fleet
    assert f.duplicate_treatments == 0 and f.vehicles_home == 3
    assert f.priority == result.report.baseline.priority
    assert f.spots_cleared == result.report.baseline.spots
    assert any(e.kind == "suspect" for e in result.events)
    assert not any(e.kind in ("lost", "takeover") for e in result.events)


@pytest.mark.parametrize("loss", [0.5, 0.7, 0.9])
def test_heavy_loss_never_collects_less_than_the_plans_and_treats_nothing_twice(
        loss: float) -> None:
    for seed in SEEDS[:2]:
        _, result = run(seed, loss)
        f = result.report.fleet
        assert f.priority >= result.report.baseline.priority, (seed, loss)
        assert f.duplicate_treatments <= 0.01 * f.treatments, (seed, loss)
        assert f.vehicles_home == 3


@pytest.mark.parametrize("seed", SEEDS[:3])
def test_a_vehicle_declared_lost_that_comes_back_keeps_its_spots(seed: int) -> None:
    """auv2 cannot hear or be heard for 150 s (a partition of one); the others confirm its
    silence and take its spots, its next ones last. When it is heard again, its claims
    (the initial plan's, time 0) win: the takers drop those spots at once, none is treated
    twice, and no spot of its plan is left untreated."""
    faults = (Fault("partition", 600.0, "auv2", 150.0),)
    _, result = run(seed, 0.0, faults)
    ev = result.events
    lost_at = min(e.t_s for e in ev if e.kind == "lost" and e.peer == "auv2")
    revived_at = min(e.t_s for e in ev if e.kind == "revived" and e.peer == "auv2")
    assert 600.0 < lost_at < revived_at <= 750.0 + 5 * CYCLE_S
    assert any(e.kind == "takeover" and e.peer == "auv2" for e in ev)
    f = result.report.fleet
    assert f.duplicate_treatments == 0 and f.vehicles_home == 3
    plan = set(result.backend.fleet.base_routes[1])
    treated = {result.backend.problem.task_index[t] for e in ev if e.kind == "cleared"
               for t in e.tasks}
    assert plan <= treated
