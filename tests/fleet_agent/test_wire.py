"""The wire codec: size limits of every kind, round trips, and refusal of hostile input."""

from __future__ import annotations

import hashlib
import hmac

import msgpack
import numpy as np
import pytest

from fleet_agent.wire import (MAC_BYTES, MAX_FRAME_BYTES, MAX_POSE_BYTES, Abort, Claim,
                              ClearedSegment, Codec, Digest, Kind, Pose, Release, WireError,
                              WireSizeError)

KEY = bytes(range(16))


def codecs() -> list[Codec]:
    # Small and large rosters and fields: the limits must hold for all of them.
    return [Codec(KEY, 3, 90), Codec(KEY, 8, 256), Codec(KEY, 8, 257), Codec(KEY, 1, 1),
            Codec(KEY, 8, 65536, (-5000.0, -5000.0), 0.2), Codec(KEY, 8, 321)]


@pytest.mark.parametrize("codec", codecs(), ids=lambda c: f"k{c.n_vehicles}-n{c.n_tasks}")
@pytest.mark.parametrize("kind", list(Kind), ids=lambda k: k.name)
def test_largest_message_of_every_kind_fits(codec: Codec, kind: Kind) -> None:
    frame = codec.encode(codec.largest(kind))
    assert len(frame) <= MAX_FRAME_BYTES
    if kind == Kind.POSE:
        assert len(frame) <= MAX_POSE_BYTES
    assert codec.decode(frame) == codec.decode(frame)  # decodes, deterministic


def test_an_oversized_claim_is_refused() -> None:
    codec = Codec(KEY, 3, 90)
    with pytest.raises(WireSizeError):
        codec.encode(Claim(0, 1, 1, tuple(range(codec.max_ids + 1))))


def test_round_trip_of_every_kind() -> None:
    codec = Codec(KEY, 3, 90, (-100.0, -100.0))
    msgs = [
        Pose(1, 1234, (512.3, 77.7, -12.4), -45, "injecting", Digest(17, 0xBEEF), 0b110011),
        ClearedSegment(2, 99, Digest(3, 7), 0, bytes(12)[:11] + b"\x03", 0b001111),
        Claim(0, 5, 4, (1, 2, 89), 0b111100),
        Release(0, 6, 5, (89,)),
        Abort(2, 1200, 1199, 0b000001),
        Abort(0, 1210, 1199, 0, subject=2),  # passed on by another vehicle
    ]
    for m in msgs:
        back = codec.decode(codec.encode(m))
        if isinstance(m, Pose):
            assert back.pos == pytest.approx(m.pos, abs=0.05 + 1e-9)
            assert (back.yaw_deg, back.state, back.heard, back.digest) == \
                (m.yaw_deg, m.state, m.heard, m.digest)
        else:
            assert back == m


def test_typical_pose_is_well_under_the_limit() -> None:
    codec = Codec(KEY, 3, 90, (-100.0, -100.0))
    frame = codec.encode(Pose(2, 3599, (999.9, 999.9, -18.0), 179, "transit",
                              Digest(90, 65535), 0b111111))
    assert len(frame) <= 30


def test_forged_frame_fails_the_mac() -> None:
    ours, theirs = Codec(KEY, 3, 90), Codec(b"x" * 16, 3, 90)
    frame = theirs.encode(Abort(1, 10, 10))
    with pytest.raises(WireError) as err:
        ours.decode(frame)
    assert err.value.reason == "mac"


def test_every_flipped_bit_is_caught() -> None:
    codec = Codec(KEY, 3, 90)
    frame = codec.encode(Claim(2, 77, 70, (3, 4, 5)))
    for i in range(len(frame) * 8):
        bad = bytearray(frame)
        bad[i // 8] ^= 1 << (i % 8)
        with pytest.raises(WireError):
            codec.decode(bytes(bad))


def _signed(body: bytes, kind: int = 1, sender: int = 0) -> bytes:
    head = bytes(((1 << 4) | kind, sender))
    return head + body + hmac.new(KEY, head + body, hashlib.sha256).digest()[:MAC_BYTES]


@pytest.mark.parametrize("body", [
    msgpack.packb([1, 2, 3]),  # wrong field count
    msgpack.packb({"a": 1}),  # not an array
    msgpack.packb([1, 0, 0, 0, 0, 400, 0, 0, 0]),  # yaw out of range
    msgpack.packb([1, 0, 0, 0, 0, 0, 9, 0, 0]),  # unknown state
    msgpack.packb([1, 64, 0, 0, 0, 0, 0, 0, 0]),  # heard bits outside a 3-vehicle roster
    msgpack.packb([1.5, 0, 0, 0, 0, 0, 0, 0, 0]),  # float seq
    msgpack.packb([True, 0, 0, 0, 0, 0, 0, 0, 0]),  # bool is not an int
    b"\xc1",  # never-used msgpack byte
    msgpack.packb([1, 0, 0, 0, 0, 0, 0, 0, 0]) + b"\x00",  # trailing data
])
def test_authentic_but_malformed_bodies_are_refused(body: bytes) -> None:
    with pytest.raises(WireError) as err:
        Codec(KEY, 3, 90).decode(_signed(body))
    assert err.value.reason == "malformed"


def test_claims_of_unknown_spots_are_malformed() -> None:
    body = msgpack.packb([1, 0, 1, bytes([90])], use_bin_type=True)
    with pytest.raises(WireError) as err:
        Codec(KEY, 3, 90).decode(_signed(body, kind=int(Kind.CLAIM)))
    assert err.value.reason == "malformed"


@pytest.mark.parametrize("frame,reason", [
    (b"", "short"), (b"\x11\x00\x90", "short"), (bytes(65), "long"),
    (bytes([0x21, 0]) + bytes(10), "version"), (bytes([0x19, 0]) + bytes(10), "kind"),
    (bytes([0x11, 3]) + bytes(10), "sender"), (bytes([0x11, 0]) + bytes(10), "mac"),
])
def test_header_checks_name_their_reason(frame: bytes, reason: str) -> None:
    with pytest.raises(WireError) as err:
        Codec(KEY, 3, 90).decode(frame)
    assert err.value.reason == reason


def test_random_garbage_only_ever_raises_wire_errors() -> None:
    codec = Codec(KEY, 3, 90)
    rng = np.random.default_rng(7)
    for _ in range(5000):
        frame = rng.bytes(int(rng.integers(0, 80)))
        with pytest.raises(WireError):
            codec.decode(frame)
