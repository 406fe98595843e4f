"""A 24-vehicle fleet in process (three times the old wire's limit): one vehicle killed,
nothing treated twice, no false alarm, the dead vehicle detected by every survivor within
reach of it within the documented bound (docs/membership.md: `lost_after_cycles` + 2 of the
schedule's cycles, one of them for the proof), every frame within 64 bytes."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from cotsfleet.mission.faults import Fault
from cotsfleet.mission.inprocess import simulate
from fleet_agent.config import AgentConfig
from fleet_agent.cleared import ClearedSet
from fleet_agent.membership import detection_bound_s
from fleet_agent.outbox import Outbox, Slot
from fleet_agent.wire import MAX_FRAME_BYTES, NO_HEARD
from hfc_core.model.check import check_routes
from reef_sim.scenarios.area import AreaParams, generate_area_doc
from hfc_core.formats.scenario import problem_from_dict

KILL_S = 600.0


def test_24_vehicles_with_a_kill_treat_nothing_twice_and_detect_the_dead() -> None:
    doc = generate_area_doc(AreaParams(n_tasks=150, n_vehicles=24, area_m=1500.0,
                                       battery_s=1800.0), np.random.default_rng(3))
    problem = problem_from_dict(doc)
    config = AgentConfig()
    result = simulate(problem, config, seed=3, faults=[Fault("kill", KILL_S, "auv7")])
    fleet = result.report.fleet
    assert fleet.duplicate_treatments == 0
    assert fleet.vehicles_home == 23
    assert fleet.false_alarms == 0
    assert result.report.messages.largest_frame_bytes <= MAX_FRAME_BYTES
    routes = {v.id: [] for v in problem.vehicles}
    for e in result.events:
        if e.kind == "cleared":
            routes[e.id] += e.tasks
    assert check_routes(problem, routes) == []
    assert fleet.spots_cleared >= 0.8 * problem.n_tasks
    # Every survivor within reach of auv7 when it died declared it lost within
    # docs/membership.md's bound (lost_after_cycles + 3 of the longest cycles, + a slot).
    schedule = result.backend.fleet.schedule
    assert schedule is not None
    bound_s = detection_bound_s(schedule, config.lost_after_cycles, config.slot_s, KILL_S)
    where = result.backend.positions_at_kill["auv7"]
    near = [v for v, p in where.items() if v != "auv7"
            and np.hypot(p[0] - where["auv7"][0], p[1] - where["auv7"][1])
            <= 0.8 * config.hear_range_m]
    delays = fleet.detection_delay_s["auv7"]
    assert near and all(delays[v] is not None and delays[v] <= bound_s for v in near), \
        (bound_s, {v: delays[v] for v in near})


def test_cleared_pushes_rotate_over_every_segment() -> None:
    """With more than 256 spots the cleared set has several segments; unprompted pushes must
    visit all of them although poses take every other slot (a rotation by slot number over
    two segments pushed the same one forever, so a clear in the other was never repaired)."""
    outbox = Outbox(AgentConfig(), max_ids=41)
    know = SimpleNamespace(cleared=ClearedSet(600), treated=[], index=0)
    pushed = []
    for k in range(6):
        # a pose in every other slot, as pose_every_cycles = 2
        slot = Slot(60.0 * k, 0, NO_HEARD, know, lambda: 1, 2 * k + 1)  # type: ignore[arg-type]
        pushed.append(outbox._cleared(slot).segment)
    assert set(pushed) == set(range(know.cleared.n_segments))  # every one of them
