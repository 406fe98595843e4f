"""What a web viewer page is showing: its time cursor, for measuring how far behind the mission
the dashboard is (the browser test and ``benchmarks/dashboard_bench.py``).

The page served by rerun-sdk keeps its viewer handle in ``window._handle``; the handle's
``viewer_state()`` returns the Viewer Control API's ``GetViewerStateResponse`` (protobuf,
``rerun/v1alpha1/viewer_control.proto``): every open recording with its timelines, their time
ranges, and its time cursor. The API is marked alpha upstream, so this reads only the few
fields it needs, by number, and returns None for anything it does not recognise.

`wall_behind_s` turns the cursor into wall seconds behind the mission clock. The clock's warp
is not constant (the operator slows it when hosts fall behind and holds it at warp 2 while an
agent plans), so the lag is read off the clock's own recent history, never divided by the
warp of the moment: a page 100 mission s behind at warp 60 is 1.7 s behind, even if the clock
is held at warp 2 when it is sampled.
"""

from __future__ import annotations

import statistics
from typing import Any, Iterator, Sequence

# Run in the page (Playwright's page.evaluate): the state as a list of byte values, or null
# while the viewer is still loading.
READ_STATE_JS = "() => window._handle ? Array.from(window._handle.viewer_state()) : null"

# Field numbers in rerun.viewer_control.v1alpha1 (GetViewerStateResponse and what it holds).
_RECORDINGS = 3  # GetViewerStateResponse.recordings: ViewerRecording
_STORE_ID = 1  # ViewerRecording.store_id: "Recording:<app id>:<recording id>"
_TIMELINES = 2  # ViewerRecording.timelines: ViewerTimeline
_CURSOR = 3  # ViewerRecording.current_time: TimeCursor
_TIMELINE = 1  # ViewerTimeline.timeline / TimeCursor.timeline: Timeline {name = 1}
_RANGE = 3  # ViewerTimeline.time_range: TimeRange {min = 1, max = 2}
_TIME = 3  # TimeCursor.time {value = 1}
_NS = 1e-9  # duration timelines count nanoseconds


def _varint(buf: bytes, i: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        byte = buf[i]
        i += 1
        value |= (byte & 0x7F) << shift
        shift += 7
        if not byte & 0x80:
            return value, i


def _fields(buf: bytes) -> Iterator[tuple[int, int | bytes]]:
    """``(field number, varint or bytes)`` of one protobuf message; fixed-width fields skipped."""
    i = 0
    while i < len(buf):
        key, i = _varint(buf, i)
        number, wire = key >> 3, key & 7
        if wire == 0:
            value, i = _varint(buf, i)
            yield number, value
        elif wire == 2:
            size, i = _varint(buf, i)
            if i + size > len(buf):
                raise ValueError("protobuf field runs past the end: cut short")
            yield number, buf[i:i + size]
            i += size
        elif wire in (1, 5):
            i += 8 if wire == 1 else 4
        else:
            raise ValueError(f"unsupported protobuf wire type {wire}")


def _signed(value: int) -> int:
    return value - (1 << 64) if value >= 1 << 63 else value


def _submessage(buf: bytes, number: int) -> bytes | None:
    for n, value in _fields(buf):
        if n == number and isinstance(value, bytes):
            return value
    return None


def _name(timeline: bytes | None) -> str | None:
    raw = _submessage(timeline, 1) if timeline is not None else None
    return raw.decode(errors="replace") if raw is not None else None


def _int(buf: bytes | None, number: int) -> int | None:
    if buf is None:
        return None
    for n, value in _fields(buf):
        if n == number and isinstance(value, int):
            return _signed(value)
    return None


def recording_times(state: bytes, timeline: str, application_id: str
                    ) -> list[tuple[str, float | None, float | None]]:
    """For each open recording of ``application_id``: ``(store id, time cursor, latest time
    logged)`` on ``timeline``, in seconds (None where the viewer has none yet)."""
    out = []
    try:
        for number, rec in _fields(bytes(state)):
            if number != _RECORDINGS or not isinstance(rec, bytes):
                continue
            store = (_submessage(rec, _STORE_ID) or b"").decode(errors="replace")
            if store.split(":")[:2] != ["Recording", application_id]:
                continue
            cursor = latest = None
            for n, value in _fields(rec):
                if n == _TIMELINES and isinstance(value, bytes) and \
                        _name(_submessage(value, _TIMELINE)) == timeline:
                    # an absent max is protobuf's default, 0
                    latest = (_int(_submessage(value, _RANGE), 2) or 0) * _NS
                if n == _CURSOR and isinstance(value, bytes) and \
                        _name(_submessage(value, _TIMELINE)) == timeline:
                    cursor_ns = _int(_submessage(value, _TIME), 1)
                    cursor = None if cursor_ns is None else cursor_ns * _NS
            out.append((store, cursor, latest))
    except (IndexError, ValueError):
        return []
    return out


def cursor_s(state: bytes | list[int] | None, timeline: str = "sim_time",
             application_id: str = "cotsfleet") -> float | None:
    """The time the page shows (its time cursor on ``timeline``), in seconds; None while it
    shows no recording of ``application_id`` or the state cannot be read."""
    if not state:
        return None
    cursors = [c for _, c, _ in recording_times(bytes(state), timeline, application_id)
               if c is not None]
    return max(cursors) if cursors else None


def wall_behind_s(trace: Sequence[tuple[float, float, float]], shown_s: float,
                  top_warp: float | None = None) -> float:
    """Wall seconds since the mission clock read ``shown_s`` (0 if it has not yet passed it).
    ``trace``: samples of the clock (wall s, mission s, warp), oldest first, the last one
    now. Between samples the clock is taken as linear. Before the first sample its history
    is unknown: it is taken to run at ``top_warp`` (the requested warp, which the clock never
    exceeds; default: the fastest of the trace), so a cursor older than the trace gives a
    lower bound: a page still loading reads as less behind, never more."""
    if not trace:
        raise ValueError("no clock sample")
    now_wall, now_mission = trace[-1][0], trace[-1][1]
    if shown_s >= now_mission:
        return 0.0
    for (w0, m0, _), (w1, m1, _) in zip(reversed(trace[:-1]), reversed(trace)):
        if m0 <= shown_s:  # and shown_s < m1: the clock passed it between these samples
            return now_wall - (w0 + (shown_s - m0) / (m1 - m0) * (w1 - w0))
    w0, m0, _ = trace[0]
    return now_wall - w0 + (m0 - shown_s) / (top_warp or max(w for _, _, w in trace))


def latency_figures(samples: Sequence[tuple[float, float, float, float | None]], end_s: float,
                    caught_up_s: float, top_warp: float) -> dict[str, Any]:
    """A live page's latency over a mission (the browser test and the dashboard bench).
    ``samples``: one per poll, (wall s since the page opened, mission clock, warp, time the
    page shows or None while it loads). Counted while the mission ran (clock up to ``end_s``);
    "steady" once the page first came within ``caught_up_s`` of the clock."""
    trace: list[tuple[float, float, float]] = []
    lat: list[tuple[float, float]] = []  # (wall s, latency s)
    for wall, now, warp, shown in samples:
        trace.append((wall, now, warp))
        if shown is not None and now <= end_s:
            lat.append((wall, wall_behind_s(trace, shown, top_warp)))
    caught = next((i for i, (_, x) in enumerate(lat) if x < caught_up_s), None)
    steady = [x for _, x in lat[caught:]] if caught is not None else []
    return {
        "first_shown_s": lat[0][0] if lat else None,
        "caught_up_s": lat[caught][0] if caught is not None else None,
        "latency_median_s": statistics.median(steady) if steady else None,
        "latency_max_s": max(steady) if steady else None,
        "latency_end_s": lat[-1][1] if lat else None,
        "latency_all_max_s": max((x for _, x in lat), default=None),
        "steady_samples": len(steady),
    }
