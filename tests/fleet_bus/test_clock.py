"""The mission clock: on the monotonic clock, deaf to wall-clock steps, corrections slewed in;
the NTP-like time exchange; slowed down mid-mission without a jump, followed by every
process. Injected monotonic and wall clocks throughout: deterministic."""

from __future__ import annotations

import json
from pathlib import Path

import msgpack
import pytest

from cotsfleet.commands.run import run_warnings
from cotsfleet.mission.report_model import MissionReport
from fleet_bus.clock import MissionClock, OffsetFilter, WallWatch, WarpClock, time_sample
from fleet_bus.mission import ClockAnswer, ClockRecord, answer_clock
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


# -- the mission clock on the monotonic clock ------------------------------------------------

class Steps:
    """A wall clock that steps: ``mono + gap``, the gap changed by the test."""

    def __init__(self, mono: Wall, gap: float = 1.7e9) -> None:
        self.mono, self.gap = mono, gap

    def __call__(self) -> float:
        return self.mono.t + self.gap


def test_a_wall_clock_step_changes_no_mission_time_and_is_counted() -> None:
    """The issue's case: +2 s then -2 s of one host's wall clock at warp 60. The wall-clock
    form moves mission time by 120 s each way; the monotonic one does not move at all."""
    mono = Wall(100.0)
    wall = Steps(mono)
    stepped = MissionClock(100.0, 60.0, mono=mono, wall=wall)
    steady = MissionClock(100.0, 60.0, mono=mono)
    old = WarpClock(wall(), 60.0, wall)
    watch = WallWatch(mono, wall)
    seen = []
    for step in (0.0, 2.0, 0.0, -2.0, 0.0):
        wall.gap += step
        mono.t += 1.0
        seen.append((stepped.now(), steady.now(), old.now()))
        assert watch.check() == (step or None)
    assert [s for s, _, _ in seen] == [s for _, s, _ in seen] == [60.0, 120.0, 180.0, 240.0, 300.0]
    assert [round(o) for _, _, o in seen] == [60, 240, 300, 240, 300]  # the old clock jumps
    assert watch.steps == 2 and watch.stepped_s == 0.0 and watch.last_step_s == -2.0


def test_ntp_slewing_of_the_wall_clock_is_not_a_step() -> None:
    mono = Wall(0.0)
    wall = Steps(mono)
    watch = WallWatch(mono, wall)
    for _ in range(3600):  # an hour of 500 ppm slewing, looked at every second
        mono.t += 1.0
        wall.gap += 0.0005
        assert watch.check() is None
    assert watch.steps == 0


def test_an_offset_measured_after_the_start_is_slewed_in_never_stepped_back() -> None:
    mono = Wall(10.0)
    clock = MissionClock(11.0, 60.0, mono=mono, max_slew=0.5)
    clock.steer(0.25)  # before the start: applied at once
    assert clock.now() == pytest.approx(-45.0) and clock.correction_s == 0.0
    mono.t += 1.0
    assert clock.now() == pytest.approx(15.0)
    clock.steer(-1.75)  # the reference is 2 s behind what we thought: 120 mission s
    assert clock.now() == pytest.approx(15.0) and clock.correction_s == pytest.approx(120.0)
    last = clock.now()
    for _ in range(50):  # at half the pace until the correction is gone (4 s)
        mono.t += 0.1
        now = clock.now()
        assert now > last and now - last >= 0.1 * 60.0 * 0.5 - 1e-9
        last = now
    assert clock.correction_s == 0.0
    assert clock.now() == pytest.approx((mono.t - 1.75 - 11.0) * 60.0)


def test_a_record_that_came_late_is_slewed_in() -> None:
    """A process that missed a hold (warp 60 -> 2) for a second: it is 58 mission s ahead;
    it does not step back, it runs slower until it is on the operator's time."""
    mono = Wall(0.0)
    operator = MissionClock(0.0, 60.0, mono=mono)
    late = MissionClock(0.0, 60.0, mono=mono)
    mono.t = 10.0
    record = operator.at_warp(2.0)
    operator.follow(*record)
    mono.t = 11.0
    assert late.now() - operator.now() == pytest.approx(58.0)
    before = late.now()
    assert late.follow(*record)
    assert late.now() == pytest.approx(before)
    ahead = []  # 58 s to slew at half of warp 2: 58 s
    for _ in range(130):
        mono.t += 0.5
        ahead.append(late.now() - operator.now())
    assert all(b <= a for a, b in zip(ahead, ahead[1:])) and ahead[-1] == 0.0
    assert not late.follow(*record)  # the same record again changes nothing


def test_mission_time_of_an_arrival_and_dates() -> None:
    mono = Wall(50.0)
    clock = MissionClock(50.0, 10.0, mono=mono, wall=Steps(mono, 1000.0))
    stamp = clock.stamp()
    mono.t += 2.0
    assert clock.sim_of(stamp) == pytest.approx(0.0) and clock.now() == pytest.approx(20.0)
    assert clock.wall_of(30.0) == pytest.approx(1000.0 + 53.0)
    assert clock.wall_delay(30.0) == pytest.approx(3.0) and clock.wall_delay(-1.0) == 0.0
    assert clock.epoch_unix == pytest.approx(1050.0)
    with pytest.raises(ValueError):
        clock.steer(float("nan"))


def test_the_time_exchange_is_ntp_and_the_least_delay_wins() -> None:
    # the reference is 5 s ahead; the query takes 10 ms, the answer 30 ms, 1 ms held
    s = time_sample(100.000, 105.010, 105.011, 100.041)
    assert s.delay_s == pytest.approx(0.040) and s.offset_s == pytest.approx(4.990)
    f = OffsetFilter(window=3)
    f.add(s)
    f.add(time_sample(101.0, 106.002, 106.003, 101.005))  # 4 ms round trip
    assert f.best().offset_s == pytest.approx(5.0)
    f.add(time_sample(102.0, float("nan"), 107.0, 102.1))  # garbage is not a sample
    assert len(f) == 2
    for i in range(3):  # the window moves on: the good sample is forgotten
        f.add(time_sample(110.0 + i, 115.05 + i, 115.05 + i, 110.1 + i))
    assert len(f) == 3 and f.best().delay_s == pytest.approx(0.1)


def test_a_clock_answer_carries_the_record_and_the_exchange_times() -> None:
    record = ClockRecord(1.7e9, 60.0, 4, epoch_ref=123.5, held_by=("auv2",))
    assert ClockRecord.decode(record.encode()) == record
    answer = answer_clock(record.encode(), "n=abc123", 200.0, lambda: 200.001)
    got = ClockAnswer.decode(answer)
    assert got.record == record and got.nonce == "abc123"
    assert (got.ref_received, got.ref_answered) == (200.0, 200.001)
    assert answer_clock(record.encode(), "", 200.0, lambda: 200.001) == record.encode()
    legacy = ClockRecord(1000.0, 60.0)  # no reference epoch: read on this host's wall clock
    assert legacy.timing(mono=lambda: 10.0, wall=lambda: 990.0) == (20.0, 60.0, 0)
    for bad in ({"epoch_unix": 1.0, "warp": 1.0, "held_by": "auv1"},
                {"epoch_unix": 1.0, "warp": 1.0, "epoch_ref": float("inf")},
                {"epoch_unix": 1.0, "warp": 1.0, "nonce": "x", "ref_received": "now"}):
        with pytest.raises(ValueError):
            ClockAnswer.decode(msgpack.packb(bad))


def test_the_launcher_names_stepped_hosts_expired_holds_and_crashes() -> None:
    doc = json.loads((Path(__file__).parents[1] / "cotsfleet" / "data" / "reports" /
                      "run7-kill.report.json").read_text())
    doc["clock"] = {"warp": 60.0, "wall_steps": {"auv2": 2},
                    "holds_expired": {"auv3": 1}, "holds_refused": {"auv3": 8}}
    doc["fleet"]["false_alarms"] = 0
    doc["crashes"] = [{"name": "ground_station", "t_s": 600.0, "action": "restart",
                       "why": "ground_station exited with -9: ", "code": -9}]
    doc["saved"] = {"events": 3, "events_total": 9, "events_error": "[Errno 28]"}
    lines = run_warnings(MissionReport.from_dict(doc))
    assert "auv2's host stepped 2 time(s)" in lines[0] and "{'auv3': 1}" in lines[1]
    assert lines[2] == "t=600 s: ground_station exited with -9:  (started again)"
    assert "3 of 9 events" in lines[3] and len(lines) == 4
