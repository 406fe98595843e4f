"""Properties of the wire codec and the cleared-set CRDT, searched by Hypothesis.

Stated once, checked against generated counterexamples: every message within the limits
survives encoding (positions to the quantum) at 5, 32 and 255 vehicles, no frame verifies
under another run's keys, any byte string is either a valid message or a
`WireError` (never another exception), and cleared-set gossip under any loss, duplication
and order converges to the union and never un-clears a spot.
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from fleet_agent.cleared import ClearedSet
from fleet_agent.wire import (HEARD_NEVER, MAX_FRAME_BYTES, MAX_POSE_BYTES, MAX_VEHICLES,
                              POSE_STATES, Abort, Claim, ClearedSegment, Codec, Digest, Heard,
                              Message, Pose, Release, WireError)

KEY = bytes(range(16))
# A small fleet (one window covers everyone), 32 vehicles (two windows), the wire's limit.
CODECS = [Codec(KEY, "run-p", 5, 700, (-100.0, -100.0), 0.1),
          Codec(KEY, "run-p", 32, 700, (-100.0, -100.0), 0.1),
          Codec(KEY, "run-p", MAX_VEHICLES, 200, (-100.0, -100.0), 0.1)]
seqs = st.integers(0, 2**32 - 1)
digests = st.builds(Digest, st.integers(0, 127), st.integers(0, 0xFFFF))
coords = st.floats(-100.0, -100.0 + 6000.0, allow_nan=False)


@st.composite
def messages(draw: st.DrawFn, codec: Codec, kinds: tuple[str, ...]) -> Message:
    """Any message ``codec`` can carry, of one of ``kinds``."""
    n = codec.n_vehicles
    sender = draw(st.integers(0, n - 1))
    heard = Heard(draw(st.integers(0, n - 1)),
                  tuple(draw(st.lists(st.integers(0, HEARD_NEVER), max_size=codec.window))))
    seq = draw(seqs)
    kind = draw(st.sampled_from(kinds))
    if kind == "pose":
        pos = draw(st.tuples(coords, coords, st.floats(-3000.0, 3000.0)))
        return Pose(sender, seq, pos, draw(st.integers(-180, 179)),
                    draw(st.sampled_from(POSE_STATES)), draw(digests), heard)
    if kind == "holding":
        cls = draw(st.sampled_from([Claim, Release]))
        ids = draw(st.lists(st.integers(0, codec.n_tasks - 1), min_size=1,
                            max_size=codec.max_ids))
        return cls(sender, seq, draw(st.integers(0, seq)), tuple(ids), heard)  # dated <= sent
    if kind == "abort":
        who = draw(st.integers(0, n - 1))
        return Abort(sender, seq, draw(seqs), heard, None if who == sender else who)
    seg = draw(st.integers(0, codec.n_segments - 1))
    size = codec._segment_bytes(seg)
    bits = draw(st.binary(min_size=size, max_size=size))
    return ClearedSegment(sender, seq, draw(digests), seg, bits, heard)


ALL = ("pose", "holding", "abort", "segment")


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_every_message_round_trips_within_its_limits(data: st.DataObject) -> None:
    codec = data.draw(st.sampled_from(CODECS))
    msg = data.draw(messages(codec, ALL))
    frame = codec.encode(msg)
    assert len(frame) <= (MAX_POSE_BYTES if isinstance(msg, Pose) else MAX_FRAME_BYTES)
    back = codec.decode(frame)
    if isinstance(msg, Pose):
        assert all(abs(a - b) <= codec.unit_m / 2 + 1e-6 for a, b in zip(back.pos, msg.pos))
        assert (back.seq, back.yaw_deg, back.state, back.digest, back.heard) == \
            (msg.seq, msg.yaw_deg, msg.state, msg.digest, msg.heard)
    else:
        assert back == msg


@settings(max_examples=500, deadline=None)
@given(st.sampled_from(CODECS), st.binary(max_size=80))
def test_any_bytes_are_a_message_or_a_wire_error(codec: Codec, data: bytes) -> None:
    try:
        codec.decode(data)
    except WireError:
        pass


@settings(max_examples=300, deadline=None)
@given(st.data(), st.integers(0, 63), st.integers(1, 255))
def test_a_flipped_byte_is_always_refused(data: st.DataObject, where: int, flip: int) -> None:
    codec = data.draw(st.sampled_from(CODECS))
    frame = bytearray(codec.encode(data.draw(messages(codec, ("pose", "holding", "abort")))))
    frame[where % len(frame)] ^= flip
    try:
        codec.decode(bytes(frame))
    except WireError:
        return
    raise AssertionError("a corrupted frame was accepted")


@settings(max_examples=100, deadline=None)
@given(st.data())
def test_no_frame_verifies_in_another_run(data: st.DataObject) -> None:
    codec = data.draw(st.sampled_from(CODECS))
    other = Codec(KEY, "run-q", codec.n_vehicles, codec.n_tasks, codec.origin_xy, codec.unit_m)
    frame = codec.encode(data.draw(messages(codec, ALL)))
    try:
        other.decode(frame)
    except WireError as exc:
        assert exc.reason == "mac"
        return
    raise AssertionError("a frame of one run was accepted in another")


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
