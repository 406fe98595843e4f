"""The operator's hand on the shared clock (`ClockControl`): deterministic, with injected wall
clocks and the records it would put on the bus collected in a list."""

from __future__ import annotations

import pytest

from cotsfleet.mission.clock_control import SLOW_HOLD_WALL_S, ClockControl
from cotsfleet.mission.pacing import HOLD_LIMIT_WALL_S, HOLD_WARP, SUSTAINED_STATUSES
from fleet_bus.mission import ClockAnswer, ClockRecord
from fleet_bus.telemetry import Status

WARP, BOUND_S = 60.0, 1.25


class Wall:
    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


def control() -> tuple[ClockControl, Wall, list[ClockRecord]]:
    wall, sent = Wall(), []
    c = ClockControl(WARP, BOUND_S, lambda b: sent.append(ClockRecord.decode(b)),
                     out=lambda line: None, wall=wall, unix=wall)
    c.start(0.0)
    return c, wall, sent


def status(vid: str, t_s: float, lag_s: float) -> Status:
    return Status(t_s=t_s, id=vid, state="transit", pos=(0.0, 0.0, 0.0), battery_s=1.0,
                  t_diff_s=0.0, route=[], treated=[], cleared_known=0,
                  priority_collected=0.0, distance_m=0.0, lag_s=lag_s)


def test_a_planning_agent_holds_the_clock_and_gives_the_warp_back():
    c, wall, sent = control()
    wall.t += 10.0  # mission 600 s
    c.busy("auv1", True)
    assert c.held and c.clock.warp == HOLD_WARP
    assert c.clock.now() == pytest.approx(600.0)  # no jump
    wall.t += 0.5
    c.busy("auv1", False)
    assert not c.held and c.clock.warp == WARP
    assert c.clock.now() == pytest.approx(601.0)  # half a wall second at warp 2
    assert [r.warp for r in sent] == [HOLD_WARP, WARP] and [r.seq for r in sent] == [1, 2]
    assert ClockRecord.decode(c.record) == sent[-1]  # the record served is the newest one
    report = c.report()
    assert report["holds"] == 1 and report["held_wall_s"] == pytest.approx(0.5)


def test_a_host_that_stays_behind_slows_the_clock_but_not_during_a_hold():
    c, wall, sent = control()
    late = [[status("auv1", 5.0 * i, 10.0)] for i in range(1, SUSTAINED_STATUSES + 1)]
    c.busy("auv2", True)
    for statuses in late:
        wall.t += 1.0
        c.pace(statuses)
    assert [r.warp for r in sent] == [HOLD_WARP] and not c.slowdowns  # planning: not pace
    c.busy("auv2", False)
    for i in range(SUSTAINED_STATUSES):  # the watch restarted after the hold
        wall.t += 1.0
        c.pace([status("auv1", 100.0 + 5.0 * i, 10.0)])
    assert len(c.slowdowns) == 1 and c.clock.warp < WARP and sent[-1].warp == c.clock.warp
    wall.t += SLOW_HOLD_WALL_S / 2  # no second change before the statuses show the first
    c.pace([status("auv1", 200.0, 10.0)])
    assert len(c.slowdowns) == 1


def test_a_hold_never_released_expires_and_the_warp_comes_back():
    c, wall, sent = control()
    c.busy("auv1", True)
    wall.t += HOLD_LIMIT_WALL_S + 0.1
    c.pace([])
    assert not c.held and c.clock.warp == WARP


def test_the_answer_is_the_newest_record_timed_on_the_reference():
    c, wall, sent = control()
    c.busy("auv1", True)
    answer = ClockAnswer.decode(c.answer("n=q1"))
    assert answer.record == sent[-1] and answer.record.held_by == ("auv1",)
    assert answer.nonce == "q1" and answer.ref_received == answer.ref_answered == wall.t
    assert answer.record.epoch_ref is not None


def test_a_host_whose_wall_clock_stepped_is_named_once_per_step():
    lines: list[str] = []
    mono, gap = Wall(), [1.7e9]
    c = ClockControl(WARP, BOUND_S, lambda b: None, out=lines.append, wall=mono,
                     unix=lambda: mono.t + gap[0])
    c.start(0.0)
    stepped = status("auv2", 5.0, 0.0)
    stepped.counters["clock_wall_steps"] = 1
    c.pace([status("auv1", 5.0, 0.0), stepped])
    c.pace([stepped])  # the same count again: already named
    gap[0] += 2.0  # the operator's own wall clock steps
    mono.t += 1.0
    before = c.clock.now()
    c.pace([])
    assert c.clock.now() == pytest.approx(before)  # mission time unmoved
    assert c.report()["wall_steps"] == {"auv2": 1, "operator": 1}
    assert len(lines) == 2 and "auv2's host stepped" in lines[0] and "+2.0 s" in lines[1]


def test_an_insiders_renewed_hold_expires_and_is_reported():
    c, wall, sent = control()
    for _ in range(11):  # busy=1 every 5 s for 55 s
        c.busy("auv3", True)
        wall.t += 5.0
        c.pace([])
    report = c.report()  # held 10 s, refused for 40 s (8 flags), held again from 50 s
    assert report["holds"] == 2 and report["holds_expired"] == {"auv3": 1}
    assert report["holds_refused"] == {"auv3": 8} and c.held
    assert report["held_wall_s"] == pytest.approx(10.0)
