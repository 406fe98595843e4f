"""The warp clock: slowed down mid-mission without a jump, and followed by every process."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from cotsfleet.commands.run import run_warnings
from fleet_bus.clock import WarpClock
from fleet_bus.mission import ClockRecord
from fleet_bus.telemetry import decode_busy, encode_busy

REPORTS = Path(__file__).parents[1] / "cotsfleet" / "data" / "reports"


class Wall:
    def __init__(self, t: float) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


def test_a_slowdown_continues_mission_time_without_a_jump() -> None:
    wall = Wall(1000.0)
    clock = WarpClock(990.0, 60.0, wall)
    assert clock.now() == pytest.approx(600.0)
    epoch, warp, seq = clock.at_warp(30.0)
    assert seq == 1
    assert clock.follow(epoch, warp, seq)
    assert clock.now() == pytest.approx(600.0)  # the same instant, the same mission time
    wall.t += 2.0
    assert clock.now() == pytest.approx(660.0)  # from now on at the new pace
    assert clock.wall_of(660.0) == pytest.approx(wall.t)


def test_only_a_newer_record_is_followed() -> None:
    wall = Wall(1000.0)
    a, b = WarpClock(990.0, 60.0, wall), WarpClock(990.0, 60.0, wall)
    first = a.at_warp(40.0)
    a.follow(*first)
    second = a.at_warp(20.0)
    assert b.follow(*second) and not b.follow(*first)  # reordered: the older one is ignored
    assert b.warp == 20.0
    with pytest.raises(ValueError):
        b.follow(0.0, float("nan"), 9)
    assert b.warp == 20.0 and b.seq == second[2]


def test_the_clock_record_carries_its_sequence_and_refuses_nonsense() -> None:
    rec = ClockRecord(12.5, 30.0, 3)
    assert ClockRecord.decode(rec.encode()) == rec
    with pytest.raises(ValueError):
        ClockRecord(12.5, -1.0, 0)
    with pytest.raises(ValueError):
        ClockRecord(12.5, 30.0, -2)


def _report(false_alarms: int, clock: dict):
    """A run's report (tests/cotsfleet/data) with these false alarms and this clock."""
    from cotsfleet.mission.report_model import MissionReport

    doc = json.loads((REPORTS / "run7-kill.report.json").read_text())
    doc["fleet"]["false_alarms"] = false_alarms
    return MissionReport.from_dict({**doc, "clock": clock})


def test_the_launcher_warns_of_false_alarms_and_a_slowed_clock() -> None:
    quiet = _report(0, {"warp": 60.0, "slowdowns": []})
    assert run_warnings(quiet) == []
    loud_clock = {"warp": 240.0, "final_warp": 117.6, "effective_warp": 131.2,
                  "max_lag_s": 9.5, "slowdowns": [{"t_s": 300.0, "warp": 168.0},
                                                  {"t_s": 330.0, "warp": 117.6}]}
    lines = run_warnings(_report(2, loud_clock))
    assert len(lines) == 2 and "2 false alarm" in lines[0] and "slowed to 117.6" in lines[1]
    eased = _report(0, {**loud_clock, "final_warp": 240.0,
                        "speedups": [{"t_s": 500.0, "warp": 240.0}], "slots_late": 3})
    lines = run_warnings(eased)
    assert "slowed to 117.6, back up to 240" in lines[0] and "3 frame(s)" in lines[1]


def test_the_busy_flag_is_one_byte_and_nothing_else():
    assert decode_busy(encode_busy(True)) is True and decode_busy(encode_busy(False)) is False
    for bad in (b"", b"\x02", b"\x01\x00", b"busy"):
        with pytest.raises(ValueError):
            decode_busy(bad)
