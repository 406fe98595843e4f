"""Properties of the wire codec and the cleared-set CRDT, searched by Hypothesis.

Stated once, checked against generated counterexamples: every message within the limits
survives encoding (positions to the quantum), any byte string is either a valid message or a
`WireError` (never another exception), and cleared-set gossip under any loss, duplication
and order converges to the union and never un-clears a spot.
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from fleet_agent.cleared import ClearedSet
from fleet_agent.wire import (MAX_FRAME_BYTES, MAX_POSE_BYTES, POSE_STATES, Abort, Claim,
                              ClearedSegment, Codec, Digest, Pose, Release, WireError)

KEY = bytes(range(16))
CODEC = Codec(KEY, 5, 700, (-100.0, -100.0), 0.1)
seqs = st.integers(0, 2**32 - 1)
heard = st.integers(0, (1 << (2 * CODEC.n_vehicles)) - 1)
senders = st.integers(0, CODEC.n_vehicles - 1)
digests = st.builds(Digest, st.integers(0, 127), st.integers(0, 0xFFFF))
coords = st.floats(-100.0, -100.0 + 6000.0, allow_nan=False)

poses = st.builds(Pose, senders, seqs, st.tuples(coords, coords, st.floats(-3000.0, 3000.0)),
                  st.integers(-180, 179), st.sampled_from(POSE_STATES), digests, heard)
holdings = st.builds(
    lambda cls, s, q, t, ids, h: cls(s, q, t, tuple(ids), h),
    st.sampled_from([Claim, Release]), senders, seqs, seqs,
    st.lists(st.integers(0, CODEC.n_tasks - 1), min_size=1, max_size=CODEC.max_ids), heard)
aborts = st.builds(lambda s, q, t, h, who: Abort(s, q, t, h, None if who == s else who),
                   senders, seqs, seqs, heard, senders)


@st.composite
def segments(draw: st.DrawFn) -> ClearedSegment:
    seg = draw(st.integers(0, CODEC.n_segments - 1))
    size = CODEC._segment_bytes(seg)
    bits = draw(st.binary(min_size=size, max_size=size))
    return ClearedSegment(draw(senders), draw(seqs), draw(digests), seg, bits, draw(heard))


@settings(max_examples=300, deadline=None)
@given(st.one_of(poses, holdings, aborts, segments()))
def test_every_message_round_trips_within_its_limits(msg) -> None:
    frame = CODEC.encode(msg)
    assert len(frame) <= (MAX_POSE_BYTES if isinstance(msg, Pose) else MAX_FRAME_BYTES)
    back = CODEC.decode(frame)
    if isinstance(msg, Pose):
        assert all(abs(a - b) <= CODEC.unit_m / 2 + 1e-6 for a, b in zip(back.pos, msg.pos))
        assert (back.seq, back.yaw_deg, back.state, back.digest, back.heard) == \
            (msg.seq, msg.yaw_deg, msg.state, msg.digest, msg.heard)
    else:
        assert back == msg


@settings(max_examples=500, deadline=None)
@given(st.binary(max_size=80))
def test_any_bytes_are_a_message_or_a_wire_error(data: bytes) -> None:
    try:
        CODEC.decode(data)
    except WireError:
        pass


@settings(max_examples=300, deadline=None)
@given(st.one_of(poses, holdings, aborts), st.integers(0, 63), st.integers(1, 255))
def test_a_flipped_byte_is_always_refused(msg, where: int, flip: int) -> None:
    frame = bytearray(CODEC.encode(msg))
    frame[where % len(frame)] ^= flip
    try:
        CODEC.decode(bytes(frame))
    except WireError:
        return
    raise AssertionError("a corrupted frame was accepted")


N_TASKS = 700


@settings(max_examples=200, deadline=None)
@given(st.lists(st.frozensets(st.integers(0, N_TASKS - 1), max_size=40), min_size=2,
                max_size=4),
       st.lists(st.tuples(st.integers(0, 3), st.integers(0, 3), st.integers(0, 2),
                          st.booleans()), max_size=60))
def test_gossip_never_unclears_and_converges_to_the_union(cleared, deliveries) -> None:
    """Vehicle v starts with ``cleared[v]``; ``deliveries`` are (src, dst, segment, lost)
    in any order, repeated at will; afterwards one loss-free round of every segment."""
    sets = [ClearedSet(N_TASKS) for _ in cleared]
    for s, mine in zip(sets, cleared):
        s.update(mine)
    k = len(sets)
    for src, dst, seg, lost in deliveries:
        src, dst, seg = src % k, dst % k, seg % sets[0].n_segments
        before = set(sets[dst])
        if not lost:
            sets[dst].merge_segment(seg, sets[src].segment(seg))
        assert before <= set(sets[dst])  # grow-only: nothing is ever un-cleared
    for src in range(k):
        for seg in range(sets[src].n_segments):
            for dst in range(k):
                sets[dst].merge_segment(seg, sets[src].segment(seg))
    union = set().union(*cleared)
    for s in sets:
        assert set(s) == union and len(s) == len(union)
        assert s.digest() == sets[0].digest()
