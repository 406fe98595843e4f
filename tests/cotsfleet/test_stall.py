"""A stalled host (the ``stall`` fault) in the in-process simulation, deterministic: the
agent of auv1 is frozen half of every 8 s for 300 s, as the multi-process pacing test does
with SIGSTOP. Its frames go out late but dated at their slots, so its peers never hear a
silent vehicle: no false alarm, nothing treated twice, the same mission."""

from __future__ import annotations

import numpy as np
import pytest

from cotsfleet.mission.faults import STALL_PERIOD_S, Fault, FaultError, check_schedule, \
    parse_faults
from cotsfleet.mission.inprocess import simulate
from fleet_agent.config import AgentConfig
from fleet_agent.radio import Radio, Slots
from reef_sim.scenarios.field import GeneratorParams, generate_doc
from hfc_core.formats.scenario import problem_from_dict


def test_thaw_times_follow_the_period() -> None:
    f = Fault("stall", 100.0, "auv1", 20.0)
    half = STALL_PERIOD_S / 2
    assert f.thaw_at(99.9) is None  # before
    assert f.thaw_at(100.0) == 100.0 + half  # frozen first
    assert f.thaw_at(100.0 + half) is None  # then runs
    assert f.thaw_at(100.0 + STALL_PERIOD_S + 1.0) == 100.0 + STALL_PERIOD_S + half
    assert f.thaw_at(118.5) == 120.0  # the last frozen half is cut at the end
    assert f.thaw_at(120.0) is None
    assert Fault("kill", 100.0, "auv1").thaw_at(100.0) is None
    # the running half, as the process backend's SIGCONT/SIGSTOP thread reads it
    assert f.stall_phase(100.0 + half) == (False, 100.0 + STALL_PERIOD_S)
    assert f.stall_phase(119.0) == (True, 120.0)
    assert f.stall_phase(120.0) is None


def test_stall_specs_and_schedule() -> None:
    [f] = parse_faults(stalls=["auv1@300+120"])
    assert (f.kind, f.vid, f.t_s, f.value) == ("stall", "auv1", 300.0, 120.0)
    assert f.describe() == "stall auv1 for 120 s at t=300 s"
    assert parse_faults(stalls=["auv1@300"])[0].value == 300.0
    with pytest.raises(FaultError, match="lasts > 0"):
        Fault("stall", 1.0, "auv1", 0.0)
    with pytest.raises(FaultError, match="dead then"):
        check_schedule([Fault("kill", 10.0, "auv1"), Fault("stall", 20.0, "auv1", 5.0)],
                       ["auv0", "auv1"], 1000.0)


def test_a_late_host_dates_its_frame_at_the_slot_it_missed() -> None:
    radio = Radio(Slots(1, 3, 2.5), AgentConfig(), max_ids=41, now=0.0)
    opening = radio.next_slot_s()  # slot 1 of cycle 0: 2.5 s + 5 % of a slot
    assert radio.take_slot(opening + 0.1) == (opening + 0.1, 0)  # in time: sent now
    second = radio.next_slot_s()
    assert second == pytest.approx(opening + 7.5)
    assert radio.take_slot(second + 4.0) == (second, 0)  # too late to send now: dated
    third = radio.next_slot_s()
    # frozen past four of its slots: the latest is dated, the three before went by unused
    assert radio.take_slot(third + 3 * 7.5 + 2.0) == (pytest.approx(third + 22.5), 3)
    assert radio.next_slot_s() == pytest.approx(third + 30.0)


@pytest.fixture(scope="module")
def stalled():
    doc = generate_doc(GeneratorParams(name="stalled", n_tasks=30, n_vehicles=3, size_m=600.0,
                                       battery_s=1500.0, service_s=60.0),
                       np.random.default_rng(5))
    problem = problem_from_dict(doc)
    calm = simulate(problem, AgentConfig(), seed=5).report
    stall = simulate(problem, AgentConfig(), seed=5,
                     faults=[Fault("stall", 300.0, "auv1", 300.0)]).report
    return calm, stall


def test_a_stalled_host_is_not_a_silent_vehicle(stalled) -> None:
    calm, stall = stalled
    starved = next(v for v in stall.vehicles if v.id == "auv1")
    assert starved.counters.get("slots_late", 0) > 10  # it did run late, slot after slot
    f = stall.fleet
    assert f.false_alarms == 0 and f.duplicate_treatments == 0
    assert f.vehicles_home == 3
    assert f.priority >= 0.97 * calm.fleet.priority
