"""Series thinning: which samples become rows."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from ground_station.series import Policy, SeriesThinner


def drawn(thinner: SeriesThinner, samples, path="x") -> list[tuple[float, float]]:
    out = []
    for t, v in samples:
        out += [(s.t_s, s.value) for s in thinner.offer(path, t, v)]
    return out


def test_a_steady_slope_is_drawn_by_heartbeat_only():
    thinner = SeriesThinner(lambda _: Policy(tolerance=60.0, heartbeat_s=30.0, corners=True))
    got = drawn(thinner, [(t, 1000.0 - t) for t in range(0, 100, 2)])
    assert [t for t, _ in got] == [0, 30, 60, 90]
    assert [(s.t_s, s.value) for s in thinner.flush()] == [(98, 902.0)]
    assert thinner.flush() == []


def test_a_jump_is_drawn_with_the_sample_before_it():
    thinner = SeriesThinner(lambda _: Policy(tolerance=5.0, corners=True))
    got = drawn(thinner, [(0, 10.0), (4, 11.0), (8, 12.0), (12, 50.0), (16, 50.0)])
    assert got == [(0, 10.0), (8, 12.0), (12, 50.0)]


def test_counts_step_without_corners():
    thinner = SeriesThinner(lambda _: Policy())
    got = drawn(thinner, [(0, 0.0), (1, 0.0), (2, 1.0), (3, 1.0), (40, 1.0)])
    assert got == [(0, 0.0), (2, 1.0), (40, 1.0)]


def test_a_minimum_interval_holds_changes_back_until_due():
    thinner = SeriesThinner(lambda _: Policy(min_interval_s=5.0))
    assert drawn(thinner, [(0, 1.0), (1, 2.0), (2, 3.0)]) == [(0, 1.0)]
    assert thinner.due(4.0) == []
    assert [(s.t_s, s.value) for s in thinner.due(5.0)] == [(2, 3.0)]
    assert thinner.due(20.0) == []  # nothing new held back
    assert drawn(thinner, [(6, 4.0), (7.5, 5.0)]) == [(7.5, 5.0)]


def test_late_samples_change_nothing():
    thinner = SeriesThinner(lambda _: Policy())
    assert drawn(thinner, [(10, 1.0), (5, 7.0)]) == [(10, 1.0)]
    assert thinner.last("x") == 1.0 and thinner.last("y") is None


@given(st.lists(st.tuples(st.floats(0, 1e4), st.floats(-1e3, 1e3)), min_size=1, max_size=60),
       st.floats(0, 50), st.floats(0, 60), st.floats(0, 10), st.booleans())
def test_rows_are_in_time_order_and_end_on_the_newest_sample(samples, tol, heartbeat, gap,
                                                             corners):
    thinner = SeriesThinner(lambda _: Policy(tol, heartbeat, gap, corners))
    samples = sorted(samples, key=lambda s: s[0])
    rows = drawn(thinner, samples)
    rows += [(s.t_s, s.value) for s in thinner.due(samples[-1][0])]
    rows += [(s.t_s, s.value) for s in thinner.flush()]
    times = [t for t, _ in rows]
    assert times == sorted(times)
    newest = max(t for t, _ in samples)
    assert rows[-1][0] == newest
    assert rows[-1][1] in [v for t, v in samples if t == newest]
    assert set(rows) <= set(samples)
