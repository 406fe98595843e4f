"""Cleared-set CRDT, replay window, failure detector and the claim rule."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from fleet_agent.cleared import ClearedSet
from fleet_agent.membership import ABORTED, ALIVE, HOME, LOST, SUSPECT, Membership
from fleet_agent.negotiation import Holdings
from fleet_agent.replay import WINDOW, ReplayWindow
from fleet_agent.wire import HEARD_NEVER, SEGMENT_BITS, Heard


# -- cleared set ------------------------------------------------------------------------------

@pytest.mark.parametrize("n_tasks", [1, 90, SEGMENT_BITS, SEGMENT_BITS + 1, 1000])
@pytest.mark.parametrize("seed", range(5))
def test_gossip_converges_under_loss_duplication_and_reordering(n_tasks: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    sets = [ClearedSet(n_tasks) for _ in range(4)]
    truth: set[int] = set()
    for _ in range(60):  # each vehicle clears spots and gossips random segments
        v = int(rng.integers(4))
        t = int(rng.integers(n_tasks))
        sets[v].add(t)
        truth.add(t)
        inflight = []
        for src in range(4):
            seg = int(rng.integers(sets[src].n_segments))
            inflight += [(src, seg, sets[src].segment(seg))] * int(rng.integers(0, 3))
        rng.shuffle(inflight)
        for src, seg, data in inflight:
            if rng.random() < 0.3:
                continue  # lost
            for dst in range(4):
                if dst != src:
                    sets[dst].merge_segment(seg, data)
    for _ in range(3):  # anti-entropy rounds without loss: everyone pushes every segment
        for src in range(4):
            for seg in range(sets[src].n_segments):
                for dst in range(4):
                    sets[dst].merge_segment(seg, sets[src].segment(seg))
    for s in sets:
        assert set(s) == truth
        assert s.digest() == sets[0].digest()
        assert len(s) == len(truth)
        # membership (one byte per spot) agrees with the bitmap the wire carries
        on_wire = {seg * s.segment_bits + 8 * j + i for seg in range(s.n_segments)
                   for j, byte in enumerate(s.segment(seg)) for i in range(8) if byte >> i & 1}
        assert {t for t in range(-2, n_tasks + 2) if t in s} == on_wire == truth


def test_a_merge_never_unclears() -> None:
    s = ClearedSet(90)
    s.update([1, 2, 3])
    assert s.merge_segment(0, bytes(12)) == []
    assert set(s) == {1, 2, 3}
    assert s.merge_segment(0, ClearedSet(90).segment(0)) == []


def test_news_in_a_segment_is_what_this_set_lacks_and_changes_nothing() -> None:
    s, theirs = ClearedSet(300, segment_bits=128), ClearedSet(300, segment_bits=128)
    s.update([130, 140])
    theirs.update([129, 130, 255, 140])
    assert s.news_in(1, theirs.segment(1)) == [129, 255]
    assert sorted(s) == [130, 140]
    assert s.news_in(9, b"\xff" * 16) == []  # a segment beyond the set: nothing, no error
    assert s.merge_segment(1, theirs.segment(1)) == [129, 255] and len(s) == 4


def test_digest_tells_sets_apart_and_is_order_free() -> None:
    a, b = ClearedSet(90), ClearedSet(90)
    a.update([5, 9, 40])
    b.update([40, 5, 9])
    assert a.digest() == b.digest()
    b.add(41)
    assert a.digest() != b.digest()
    assert a.missing_from(0, b.segment(0)) is False
    assert b.missing_from(0, a.segment(0)) is True


# -- replay window ----------------------------------------------------------------------------

def test_replay_window_accepts_each_sequence_number_once() -> None:
    w = ReplayWindow()
    assert w.accept(1, 100)
    assert not w.accept(1, 100)
    assert w.accept(1, 98)  # late but inside the window, and new
    assert not w.accept(1, 98)
    assert w.accept(1, 101)
    assert not w.accept(1, 101 - WINDOW)  # too old to tell
    assert w.accept(2, 5)  # senders are independent


def test_replay_window_restored_after_restart_refuses_old_frames() -> None:
    w = ReplayWindow()
    for s in (10, 11, 12):
        w.accept(0, s)
    fresh = ReplayWindow()
    fresh.restore(w.high_water())
    assert not fresh.accept(0, 12) and not fresh.accept(0, 3)
    assert fresh.accept(0, 13)


# -- failure detector -------------------------------------------------------------------------

def never_heard(*peers: int, n: int = 3) -> Heard:
    """A heard window over the whole roster whose sender heard none of ``peers`` (code 0,
    heard within one period, for everyone else)."""
    return Heard(0, tuple(HEARD_NEVER if v in peers else 0 for v in range(n)))


def test_silence_alone_makes_a_suspect_that_keeps_its_work() -> None:
    m = Membership(3, 0, lost_after_s=30.0, period_s=7.5)
    m.heard(1, 10.0, 11.0)
    m.heard(2, 10.0, 11.0)
    assert m.check(39.9) == []
    assert m.next_deadline_s() == 40.0
    assert sorted(m.check(40.0)) == [1, 2]
    assert m.status(1) == SUSPECT and m.alive(1)  # its claims still count
    assert m.check(10_000.0) == []  # total silence: suspects forever, never lost
    assert m.heard(1, 50.0, 51.0) is False  # a frame of its own clears the suspicion...
    assert m.status(1) == ALIVE  # ... and nothing had been taken, so nothing is "revived"


def test_a_second_observer_confirms_a_silence_and_a_frame_revives_the_lost() -> None:
    m = Membership(3, 0, lost_after_s=30.0, period_s=7.5)
    m.heard(1, 10.0, 11.0)
    m.heard(2, 38.0, 39.0)
    assert m.check(40.0) == [1]
    # vehicle 2's frame was sent before the suspicion began: no confirmation
    assert m.confirm(2, never_heard(1, 2), sent_s=38.0, now_s=40.5) == []
    # a frame sent after it saying vehicle 2 heard vehicle 1 recently is no confirmation
    assert m.confirm(2, never_heard(2), sent_s=42.0, now_s=43.0) == []
    assert m.confirm(2, never_heard(1, 2), sent_s=45.0, now_s=46.0) == [1]
    assert m.status(1) == LOST and not m.alive(1)
    assert m.heard(1, 50.0, 51.0) is True  # heard after it was declared lost: revived
    assert m.status(1) == ALIVE


def test_the_suspect_cannot_confirm_its_own_silence() -> None:
    m = Membership(2, 0, lost_after_s=30.0, period_s=7.5)
    assert m.check(30.0) == [1]
    assert m.confirm(1, never_heard(0, 1, n=2), sent_s=31.0, now_s=32.0) == []
    assert m.status(1) == SUSPECT


def test_relayed_evidence_delays_suspicion_but_stale_evidence_never_revives() -> None:
    m = Membership(3, 0, lost_after_s=30.0, period_s=7.5)
    m.heard(1, 10.0, 11.0)
    m.heard(2, 40.0, 41.0)
    m.relayed(1, 25.0, now_s=26.0)  # vehicle 2 heard vehicle 1 later than we did
    assert m.check(45.0) == []
    assert m.check(55.0) == [1]
    assert m.relayed(1, 24.0, now_s=56.0) is False  # older than what we had: still suspect
    assert m.status(1) == SUSPECT
    assert m.confirm(2, never_heard(1, 2), sent_s=57.0, now_s=58.0) == [1]
    assert m.relayed(1, 24.0, now_s=60.0) is False  # stale: still lost
    assert m.relayed(1, 59.0, now_s=70.0) is True  # heard after we declared it: revived


def test_heard_field_carries_ages_and_yields_conservative_evidence() -> None:
    a = Membership(3, 0, lost_after_s=30.0, period_s=10.0)
    a.heard(1, 100.0, 101.0)
    a.heard(2, 85.0, 86.0)
    field = a.heard_field(104.0)
    # self: never; vehicle 1 heard 4 s ago (code 0: <= 1 period); vehicle 2 19 s ago (code 1)
    assert (field.offset, field.codes) == (0, (3, 0, 1))
    b = Membership(3, 2, lost_after_s=30.0, period_s=10.0)
    b.take_heard(0, field, sent_s=104.0, now_s=105.0)
    assert b.peers[1].evidence_s == 94.0  # sent minus one period: never later than the truth
    assert b.peers[0].evidence_s == 0.0  # the sender's own entry is not evidence


def test_abort_and_home_are_final() -> None:
    m = Membership(3, 0, lost_after_s=30.0, period_s=7.5)
    assert m.mark(1, ABORTED, 5.0)
    m.heard(1, 6.0, 6.5)
    assert m.status(1) == ABORTED
    assert m.mark(2, HOME, 7.0)
    assert m.check(1000.0) == []


# -- claims -----------------------------------------------------------------------------------

def test_initial_plan_is_everyones_claim_at_time_zero() -> None:
    h = Holdings(6, [[0, 1], [2], [3]])
    everyone = lambda v: True  # noqa: E731
    assert h.holders(everyone) == {0: 0, 1: 0, 2: 1, 3: 2}
    h.apply(1, 100, [0, 4], True)
    assert h.holder(0, everyone) == 0  # a later claim never beats a live plan owner
    assert h.holder(4, everyone) == 1
    assert h.holder(0, lambda v: v != 0) == 1  # ... but a claim dies with its claimer


def test_conflicting_claims_resolve_the_same_whatever_the_arrival_order() -> None:
    claims = [(0, 50, [7, 8], True), (1, 40, [8, 9], True), (2, 40, [9, 7], True),
              (1, 60, [8], False), (2, 30, [7], True), (0, 70, [9], True)]
    results = set()
    for order in itertools.permutations(claims):
        h = Holdings(10, [[], [], []])
        for v, t, tasks, c in order:
            h.apply(v, t, tasks, c)
        results.add(tuple(sorted(h.holders(lambda v: True).items())))
    assert len(results) == 1
    assert dict(next(iter(results))) == {7: 2, 8: 0, 9: 1}


def test_release_frees_a_spot_and_a_newer_claim_retakes_it() -> None:
    h = Holdings(3, [[0], []])
    everyone = lambda v: True  # noqa: E731
    h.apply(0, 10, [0], False)
    assert h.holder(0, everyone) is None
    h.apply(0, 5, [0], True)  # older than the release: ignored
    assert h.holder(0, everyone) is None
    h.apply(1, 20, [0], True)
    assert h.holder(0, everyone) == 1


def test_the_initial_plan_is_shared_but_each_vehicles_records_are_its_own() -> None:
    routes = [[0, 1], [2], [3]]
    a, b = Holdings(6, routes), Holdings(6, [list(r) for r in routes])
    def everyone(v: int) -> bool:
        return True

    assert a.base is b.base  # one copy of the plan's claims per process
    a.apply(0, 50, [1], False)
    a.apply(1, 60, [4, 1], True)
    assert a.holders(everyone) == {0: 0, 1: 1, 2: 1, 3: 2, 4: 1}
    assert a.claimed_by(1) == [1, 2, 4]  # the plan's spots in route order, then later claims
    assert a.claimed_by(0) == [0]
    assert b.holders(everyone) == {0: 0, 1: 0, 2: 1, 3: 2}  # untouched by a's records
    assert b.claimed_by(1) == [2] and b.records() == []


def test_a_spot_in_two_initial_routes_goes_to_the_lower_index_then_the_other() -> None:
    h = Holdings(3, [[0], [0, 1]])
    def everyone(v: int) -> bool:
        return True

    assert h.holder(0, everyone) == 0
    h.apply(0, 10, [0], False)
    assert h.holder(0, everyone) == 1  # its time-0 claim stands
    assert h.claimed_by(0) == [] and h.claimed_by(1) == [0, 1]


def test_a_find_is_its_finders_from_its_found_until_it_claims_or_releases_it() -> None:
    h = Holdings(10, [[0], [1], [2]])
    everyone = lambda v: True  # noqa: E731
    h.found(7, 2)
    assert h.holder(7, everyone) == 2 and h.reserved_by(2) == [7]
    assert h.claim_time(7, 2) == 0 and h.claimed_by(2) == [2]  # held, not yet taken on
    h.apply(0, 40, [7], True)  # a peer that heard the FOUND and not the finder's claim
    assert h.holder(7, everyone) == 2
    assert h.holder(7, lambda v: v != 2) == 0  # it dies with its finder
    assert h.holder(7, lambda v: v == 2, found=False) is None  # a finder gone home: not held
    h.apply(2, 30, [7], True)  # the finder's claim in its own time: the earliest wins
    assert h.holder(7, everyone) == 2 and h.reserved_by(2) == [] and h.claimed_by(2) == [2, 7]
    h.apply(2, 50, [7], False)  # given up: the peer's claim stands
    assert h.holder(7, everyone) == 0
    h.found(7, 1)  # named once: a second naming changes nothing
    assert h.holder(7, lambda v: v != 0) is None


def test_the_finders_hold_resolves_the_same_whatever_the_arrival_order() -> None:
    # 5: a peer's claim against the finder's hold (the hold wins, FOUND first or last); 8: the
    # finder's own claim in its own time, later than a peer's; 9: the finder's release
    events = [("found", 5, 2), ("apply", 0, 10, [5], True),
              ("found", 8, 1), ("apply", 0, 20, [8], True), ("apply", 1, 25, [8], True),
              ("found", 9, 0), ("apply", 0, 30, [9], False), ("apply", 2, 35, [9], True)]
    results = set()
    for order in itertools.permutations(events):
        h = Holdings(10, [[], [], []])
        for e in order:
            if e[0] == "found":
                h.found(e[1], e[2])
            else:
                h.apply(*e[1:])
        results.add(tuple(sorted(h.holders(lambda v: True).items())))
    assert results == {((5, 2), (8, 0), (9, 2))}
