"""Reading a web viewer page's time cursor from its viewer-control state (protobuf)."""

from __future__ import annotations

from pathlib import Path

import pytest

from ground_station.viewer_state import cursor_s, recording_times

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
