"""Membership evidence at fleet sizes beyond one heard window: the rotating window still
refreshes every peer's relayed evidence within a few cycles, and stays conservative."""

from __future__ import annotations

import math

from fleet_agent.membership import Membership
from fleet_agent.wire import HEARD_NEVER, HEARD_WINDOW, Codec, Heard, Pose, Digest


def test_relayed_evidence_reaches_every_peer_within_a_few_cycles() -> None:
    n, period = 40, 100.0
    a = Membership(n, 0, lost_after_s=450.0, period_s=period)
    for v in range(1, n):
        a.heard(v, 1000.0, 1000.5)  # vehicle 0 heard everyone at t = 1000
    b = Membership(n, 39, lost_after_s=450.0, period_s=period)
    codec = Codec(bytes(16), "run", n, 10)
    seen: set[int] = set()
    cycles = math.ceil(n / HEARD_WINDOW)
    for c in range(cycles):
        now = 1000.0 + 5.0 + c * period  # vehicle 0's slot in cycles 10, 11, 12
        field = a.heard_field(now)
        assert len(field.codes) <= HEARD_WINDOW
        frame = codec.encode(Pose(0, int(now), (0.0, 0.0, 0.0), 0, "transit", Digest(0, 0),
                                  field))
        got = codec.decode(frame).heard  # what travels is what is taken
        b.take_heard(0, got, now, now + 1.0)
        seen |= {v for v, _ in got.items(n)}
    assert seen == set(range(1, n))  # everyone but the sender, within ceil(40/16) cycles
    for v in range(1, 39):
        # Evidence never later than the truth (heard at 1000), and recent enough to matter.
        assert 1000.0 - 4 * period <= b.peers[v].evidence_s <= 1000.0


def test_the_senders_own_entry_and_unknown_peers_are_not_evidence() -> None:
    m = Membership(20, 3, lost_after_s=450.0, period_s=100.0)
    m.take_heard(5, Heard(0, (0,) * 16), sent_s=500.0, now_s=501.0)
    assert m.peers[5].evidence_s == 0.0  # the sender's own code proves nothing
    assert m.peers[4].evidence_s == 400.0  # sent minus one period
    assert m.peers[19].evidence_s == 0.0  # outside this window
    never = Heard(0, (HEARD_NEVER,) * 16)
    m.take_heard(6, never, sent_s=900.0, now_s=901.0)
    assert m.peers[4].evidence_s == 400.0
