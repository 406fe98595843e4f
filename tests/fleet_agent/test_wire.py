"""The wire codec (version 2): size limits of every kind at 3, 32 and 255 vehicles, round
trips, the run- and sender-bound MAC, and refusal of hostile input."""

from __future__ import annotations

import hashlib
import hmac
import math
import struct

import msgpack
import numpy as np
import pytest

from fleet_agent.wire import (FLEET_MAC_BYTES, HEADER_BYTES, HEARD_NEVER, HEARD_WINDOW,
                              KEY_BYTES, MAC_BYTES, TAG_BYTES,
                              MAX_FRAME_BYTES, MAX_POSE_BYTES, MAX_VEHICLES, VERSION, Abort,
                              Claim, ClearedSegment, Codec, Digest, Heard, Kind, Pose, Release,
                              WireError, WireSizeError, heard_offset, heard_window, sender_key)

KEY = bytes(range(16))
RUN = "run-a"


def codecs() -> list[Codec]:
    # Small and large rosters and fields: the limits must hold for all of them.
    return [Codec(KEY, RUN, 3, 90), Codec(KEY, RUN, 8, 256), Codec(KEY, RUN, 8, 257),
            Codec(KEY, RUN, 1, 1), Codec(KEY, RUN, 17, 321), Codec(KEY, RUN, 24, 600),
            Codec(KEY, RUN, 32, 600), Codec(KEY, RUN, 32, 65536, (-5000.0, -5000.0), 0.2),
            Codec(KEY, RUN, 255, 256), Codec(KEY, RUN, MAX_VEHICLES, 65536)]


@pytest.mark.parametrize("codec", codecs(), ids=lambda c: f"k{c.n_vehicles}-n{c.n_tasks}")
@pytest.mark.parametrize("kind", list(Kind), ids=lambda k: k.name)
def test_largest_message_of_every_kind_fits(codec: Codec, kind: Kind) -> None:
    if kind == Kind.FOUND:  # finds exist only in dynamic missions: slots from found_from on
        codec = Codec(KEY, RUN, codec.n_vehicles, codec.n_tasks, codec.origin_xy, codec.unit_m,
                      found_from=codec.n_tasks - 1)
    frame = codec.encode(codec.largest(kind))
    assert len(frame) == codec.max_size(kind) <= MAX_FRAME_BYTES
    if kind == Kind.POSE:
        assert len(frame) <= MAX_POSE_BYTES
    assert codec.decode(frame) == codec.largest(kind) or kind == Kind.POSE
    assert codec.decode(frame) == codec.decode(frame)  # decodes, deterministic


def test_the_limits_at_32_and_255_vehicles() -> None:
    for n in (32, 255):
        codec = Codec(KEY, RUN, n, 65536)
        assert codec.max_size(Kind.POSE) <= MAX_POSE_BYTES
        assert max(codec.max_size(k) for k in Kind) <= MAX_FRAME_BYTES
        assert codec.window == HEARD_WINDOW  # the heard field no longer grows with the fleet


def test_a_fleet_beyond_the_wire_limit_is_refused() -> None:
    with pytest.raises(ValueError, match="1..255"):
        Codec(KEY, RUN, MAX_VEHICLES + 1, 90)
    with pytest.raises(ValueError, match="run id"):
        Codec(KEY, "", 3, 90)


def test_an_oversized_claim_is_refused() -> None:
    codec = Codec(KEY, RUN, 3, 90)
    with pytest.raises(WireSizeError):
        codec.encode(Claim(0, 1, 1, tuple(range(codec.max_ids + 1))))


@pytest.mark.parametrize("n", [3, 32, 255])
def test_round_trip_of_every_kind(n: int) -> None:
    codec = Codec(KEY, RUN, n, 700, (-100.0, -100.0))
    top = n - 1
    window = (0, 2, 1, 3, 0, 0, 1, 2, 0, 1, 2, 3, 0, 1, 2, 0)[:codec.window]
    msgs = [
        Pose(top, 1234, (512.3, 77.7, -12.4), -45, "injecting", Digest(17, 0xBEEF),
             Heard(top, window)),
        ClearedSegment(0, 99, Digest(3, 7), 2, bytes(codec._segment_bytes(2) - 1) + b"\x03",
                       Heard(0, window[:2])),
        Claim(top, 5, 4, (1, 2, 699), Heard(n // 2, window)),
        Release(0, 6, 5, (699,)),
        Abort(top, 1200, 1199, Heard(1 % n, (0,))),
        Abort(0, 1210, 1199, subject=top) if n > 1 else Abort(0, 1210, 1199),
    ]
    for m in msgs:
        back = codec.decode(codec.encode(m))
        if isinstance(m, Pose):
            assert back.pos == pytest.approx(m.pos, abs=0.05 + 1e-9)
            assert (back.seq, back.yaw_deg, back.state, back.heard, back.digest) == \
                (m.seq, m.yaw_deg, m.state, m.heard, m.digest)
        else:
            assert back == m


def test_typical_pose_is_well_under_the_limit() -> None:
    codec = Codec(KEY, RUN, 3, 90, (-100.0, -100.0))
    frame = codec.encode(Pose(2, 3599, (999.9, 999.9, -18.0), 179, "transit",
                              Digest(90, 65535), Heard(0, (0, 1, 3))))
    assert len(frame) <= 27  # a pose discloses no key: it has no room for one


def test_forged_frame_fails_the_mac() -> None:
    ours, theirs = Codec(KEY, RUN, 3, 90), Codec(b"x" * 16, RUN, 3, 90)
    with pytest.raises(WireError) as err:
        ours.decode(theirs.encode(Abort(1, 10, 10)))
    assert err.value.reason == "mac"


@pytest.mark.parametrize("n", [3, 32, 255])
def test_a_frame_of_another_run_fails_the_mac(n: int) -> None:
    """Same fleet key, next run: a recorded frame is refused, however fresh its seq."""
    last_run, this_run = Codec(KEY, "run-a", n, 90), Codec(KEY, "run-b", n, 90)
    frame = last_run.encode(Abort(n - 1, 10**6, 10**6))
    assert last_run.decode(frame).seq == 10**6
    with pytest.raises(WireError) as err:
        this_run.decode(frame)
    assert err.value.reason == "mac"


def test_a_frame_cannot_be_passed_off_as_another_senders() -> None:
    codec = Codec(KEY, RUN, 32, 90)
    frame = bytearray(codec.encode(Pose(5, 10, (0.0, 0.0, 0.0), 0, "home", Digest(0, 0))))
    frame[1] = 6  # same bytes, another sender: that sender's key does not sign them
    with pytest.raises(WireError) as err:
        codec.decode(bytes(frame))
    assert err.value.reason == "mac"


def test_sender_keys_differ_per_sender_and_per_run() -> None:
    keys = {sender_key(KEY, run, s) for run in ("a", "b") for s in range(MAX_VEHICLES)}
    assert len(keys) == 2 * MAX_VEHICLES


def test_every_flipped_bit_is_caught() -> None:
    codec = Codec(KEY, RUN, 32, 90)
    frame = codec.encode(Claim(2, 77, 70, (3, 4, 5), Heard(16, (0, 1))))
    for i in range(len(frame) * 8):
        bad = bytearray(frame)
        bad[i // 8] ^= 1 << (i % 8)
        with pytest.raises(WireError):
            codec.decode(bytes(bad))


def _signed(codec: Codec, body: bytes, kind: Kind = Kind.POSE, sender: int = 0,
            seq: int = 1, offset: int = 0, codes: bytes | None = None) -> bytes:
    """A frame with a valid fleet MAC around whatever header fields and body we ask for (a
    disclosed key of zeros and a tag of zeros where the layout has them)."""
    codes = b"\xff" * codec.code_bytes if codes is None else codes
    key = b"" if kind == Kind.POSE else bytes(KEY_BYTES)
    data = struct.pack(">BBIB", VERSION << 4 | int(kind), sender, seq, offset) + codes + key
    data += body + bytes(TAG_BYTES)
    mac = hmac.new(sender_key(KEY, RUN, sender), data, hashlib.sha256).digest()
    return data + mac[:FLEET_MAC_BYTES]


POSE_OK = struct.pack(">HHhHBH", 1, 2, -3, 180 << 3 | 1, 5, 6)


@pytest.mark.parametrize("kind,body,extra", [
    (Kind.POSE, struct.pack(">HHhHBH", 1, 2, 3, 360 << 3, 0, 0), {}),  # yaw out of range
    (Kind.POSE, struct.pack(">HHhHBH", 1, 2, 3, 180 << 3 | 6, 0, 0), {}),  # unknown state
    (Kind.POSE, struct.pack(">HHhHBH", 1, 2, 3, 180 << 3, 128, 0), {}),  # digest count
    (Kind.POSE, POSE_OK + b"\x00", {}),  # trailing data
    (Kind.POSE, POSE_OK[:-1], {}),  # body too short
    (Kind.POSE, POSE_OK, {"offset": 3}),  # heard window starts outside the roster
    (Kind.POSE, POSE_OK, {"codes": b"\x3f"}),  # a code for a 4th vehicle of 3
    (Kind.CLEARED, struct.pack(">BHB", 1, 2, 0) + bytes(11), {}),  # segment one byte short
    (Kind.CLEARED, struct.pack(">BHB", 1, 2, 1) + bytes(12), {}),  # no such segment
    (Kind.CLAIM, struct.pack(">I", 7) + bytes([90]), {}),  # unknown spot
    (Kind.CLAIM, struct.pack(">I", 7) + bytes(34), {}),  # more ids than a claim may hold
    (Kind.ABORT, struct.pack(">IB", 7, 3), {}),  # subject outside the roster
    (Kind.ABORT, struct.pack(">IB", 7, 1) + b"\x00", {}),  # trailing data
])
def test_authentic_but_malformed_bodies_are_refused(kind: Kind, body: bytes, extra) -> None:
    codec = Codec(KEY, RUN, 3, 90)
    assert codec.decode(_signed(codec, POSE_OK)).pos == codec.dequantise(1, 2, -3)
    with pytest.raises(WireError) as err:
        codec.decode(_signed(codec, body, kind, **extra))
    assert err.value.reason == "malformed"
    with pytest.raises(WireError) as err:  # a release of no spot
        codec.decode(_signed(codec, struct.pack(">I", 7), Kind.RELEASE))
    assert err.value.reason == "malformed"
    with pytest.raises(WireError) as err:  # a key frame with a body
        codec.decode(_signed(codec, b"\x00", Kind.KEY))
    assert err.value.reason == "malformed"


def test_a_version_1_frame_is_refused_as_such() -> None:
    """What a v1 agent sent (msgpack body, 4-byte MAC over the fleet key) is counted as an
    old version, not as a forgery or garbage."""
    head = bytes((1 << 4 | int(Kind.POSE), 0))
    body = msgpack.packb([3599, 0b111111, 65535, 65535, -32768, -180, 4, 127, 65535])
    v1 = head + body + hmac.new(KEY, head + body, hashlib.sha256).digest()[:4]
    with pytest.raises(WireError) as err:
        Codec(KEY, RUN, 3, 90).decode(v1)
    assert err.value.reason == "version"


@pytest.mark.parametrize("frame,reason", [
    (b"", "short"), (b"\x31", "short"), (bytes([0x31, 0]) + bytes(13), "short"),
    (bytes(65), "long"), (bytes([0x15, 0]), "version"),
    (bytes([0x11, 0]) + bytes(20), "version"), (bytes([0x21, 0]) + bytes(20), "version"),
    (bytes([0x39, 0]) + bytes(20), "kind"), (bytes([0x31, 3]) + bytes(20), "sender"),
    (bytes([0x31, 0]) + bytes(20), "mac"),
])
def test_header_checks_name_their_reason(frame: bytes, reason: str) -> None:
    with pytest.raises(WireError) as err:
        Codec(KEY, RUN, 3, 90).decode(frame)
    assert err.value.reason == reason


def test_random_garbage_only_ever_raises_wire_errors() -> None:
    codec = Codec(KEY, RUN, 32, 90)
    rng = np.random.default_rng(7)
    for _ in range(5000):
        frame = rng.bytes(int(rng.integers(0, 80)))
        with pytest.raises(WireError):
            codec.decode(frame)


@pytest.mark.parametrize("n", [1, 3, 16, 17, 24, 32, 100, 255])
def test_heard_windows_cover_every_peer_every_few_cycles(n: int) -> None:
    """Each sender's windows over ceil(n / 16) consecutive cycles tile the roster, and in
    every cycle the senders together report on every vehicle."""
    span = math.ceil(n / HEARD_WINDOW)
    w = heard_window(n)
    for sender in range(n):
        for start in range(3):
            covered = {(heard_offset(sender, c, n) + i) % n
                       for c in range(start, start + span) for i in range(w)}
            assert covered == set(range(n))
    for cycle in range(3):
        assert {(heard_offset(s, cycle, n) + i) % n for s in range(n) for i in range(w)} \
            == set(range(n))


def test_heard_drops_trailing_never_codes() -> None:
    assert Heard(2, (0, HEARD_NEVER, 1, HEARD_NEVER, HEARD_NEVER)) == Heard(2, (0, HEARD_NEVER, 1))
    assert Heard(4, (0, 3, 1)).items(5) == [(4, 0), (1, 1)]


def test_header_layout_is_what_docs_say() -> None:
    codec = Codec(KEY, RUN, 32, 90)
    frame = codec.encode(Abort(7, 0x01020304, 5, Heard(9, (0, 1, 2))))
    assert frame[0] == VERSION << 4 | int(Kind.ABORT) and frame[1] == 7
    assert frame[2:6] == bytes([1, 2, 3, 4]) and frame[6] == 9
    assert frame[HEADER_BYTES] == 0b11100100  # codes 0, 1, 2, never: 2 bits each, low first
    assert frame[HEADER_BYTES + 4:HEADER_BYTES + 4 + KEY_BYTES] == bytes(KEY_BYTES)  # disclosed
    assert len(frame) == HEADER_BYTES + 4 + KEY_BYTES + 5 + MAC_BYTES


def test_the_frame_budget_is_the_modems() -> None:
    """A modem with larger frames carries more ids per claim and more spots per segment; one
    whose frames cannot carry what the mission needs is refused when the codec is made."""
    wide = Codec(KEY, "run", 3, 1000, max_frame_bytes=256)
    assert wide.max_ids == (256 - 31) // 2 and wide.segment_bits == 8 * (256 - 32)
    assert max(wide.max_size(k) for k in Kind) <= 256 and wide.max_size(Kind.POSE) <= 32
    small = Codec(KEY, "run", 3, 90, max_frame_bytes=40)  # the smallest the wire takes
    assert small.max_size(Kind.CLAIM) <= 40 and small.segment_bits == 64
    assert Codec(KEY, "run", 3, 200, found_from=90, max_frame_bytes=40).max_size(
        Kind.FOUND) <= 40  # 3 vehicles: one byte of heard codes, a find fits 39 bytes
    with pytest.raises(ValueError, match="FOUND"):  # 20 vehicles: four bytes, 42 in all
        Codec(KEY, "run", 20, 200, found_from=90, max_frame_bytes=40)
    with pytest.raises(ValueError, match="needs frames"):  # rate 0: no room for a segment
        Codec(KEY, "run", 3, 90, max_frame_bytes=32)
    big = wide.encode(Claim(0, 5, 5, tuple(range(wide.max_ids))))
    with pytest.raises(WireError, match="long"):
        Codec(KEY, "run", 3, 1000).decode(big)  # the water's 64-byte codec refuses it
