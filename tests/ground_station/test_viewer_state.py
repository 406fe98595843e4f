"""Reading a web viewer page's time cursor from its viewer-control state (protobuf)."""

from __future__ import annotations

from pathlib import Path

import pytest

from ground_station.viewer_state import cursor_s, latency_figures, recording_times, wall_behind_s

# window._handle.viewer_state() of rerun 0.41's web viewer, showing a warp-60 mission
STATE = (Path(__file__).parent / "data" / "viewer_state_rerun_0.41.bin").read_bytes()


def test_a_real_state_gives_the_cursor_and_the_latest_time_on_sim_time():
    ((store, cursor, latest),) = recording_times(STATE, "sim_time", "cotsfleet")
    assert store.startswith("Recording:cotsfleet:")
    assert cursor == pytest.approx(321.0656, abs=1e-3) and latest == pytest.approx(cursor)
    assert cursor_s(list(STATE)) == cursor  # as page.evaluate returns it


@pytest.mark.parametrize("state, timeline, app", [
    (STATE, "log_time", "cotsfleet"),  # another timeline
    (STATE, "sim_time", "other-app"),  # another application's recording
    (b"", "sim_time", "cotsfleet"),  # the page still loading
    (None, "sim_time", "cotsfleet"),
    (b"\xff\xff\xff", "sim_time", "cotsfleet"),  # not protobuf
    (STATE[: len(STATE) // 2], "sim_time", "cotsfleet"),  # cut short
])
def test_anything_else_is_none(state, timeline, app):
    assert cursor_s(state, timeline, app) is None


def test_the_lag_is_read_off_the_clock_history_not_the_warp_of_the_moment():
    """At warp 60 the page trails by 90 mission s (1.5 wall s); then an agent plans and the
    clock is held at warp 2: half a wall second later the page is 2 s behind, not 45.5
    ((121 - 30) / 2, the mission lag over the warp of the moment)."""
    trace = [(0.0, 0.0, 60.0), (1.0, 60.0, 60.0), (2.0, 120.0, 60.0)]
    assert wall_behind_s(trace, 30.0) == pytest.approx(1.5)
    trace.append((2.5, 121.0, 2.0))  # held since 2.0 wall s
    assert wall_behind_s(trace, 30.0) == pytest.approx(2.0)
    assert wall_behind_s(trace, 120.5) == pytest.approx(0.25)
    assert wall_behind_s(trace, 121.0) == pytest.approx(0.0)
    assert wall_behind_s(trace, 500.0) == pytest.approx(0.0)  # ahead counts as caught up


def test_a_cursor_older_than_the_history_is_a_lower_bound_at_the_top_warp():
    trace = [(10.0, 600.0, 60.0), (11.0, 660.0, 60.0)]
    assert wall_behind_s(trace, 0.0) == pytest.approx(1.0 + 10.0)
    held = [(5.0, 600.0, 2.0)]  # the first sample taken during a hold
    assert wall_behind_s(held, 540.0, top_warp=60.0) == pytest.approx(1.0)
    with pytest.raises(ValueError):
        wall_behind_s([], 0.0)


def test_a_clock_that_stood_still_between_samples_is_not_counted_twice():
    trace = [(0.0, 50.0, 60.0), (1.0, 100.0, 60.0), (2.0, 100.0, 60.0)]
    assert wall_behind_s(trace, 100.0) == 0.0 and wall_behind_s(trace, 101.0) == 0.0
    assert wall_behind_s(trace, 75.0) == pytest.approx(1.5)


def test_latency_figures_count_from_the_first_caught_up_sample_while_the_mission_ran():
    samples = [(1.0, 60.0, 60.0, None),  # the page still loading
               (2.0, 120.0, 60.0, 0.0),  # 2 s behind at the top warp: before the trace
               (3.0, 180.0, 60.0, 150.0),  # 0.5 s
               (3.5, 181.0, 2.0, 150.0),  # held: 1.0 s, not (181 - 150) / 2
               (4.0, 240.0, 60.0, 239.0),  # past the mission's end: not counted
               ]
    f = latency_figures(samples, end_s=200.0, caught_up_s=1.5, top_warp=60.0)
    assert f["first_shown_s"] == 2.0 and f["caught_up_s"] == 3.0 and f["steady_samples"] == 2
    assert f["latency_max_s"] == pytest.approx(1.0) and f["latency_all_max_s"] == 2.0
    assert f["latency_end_s"] == pytest.approx(1.0)
