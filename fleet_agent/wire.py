"""The acoustic wire protocol: compact, quantised, versioned, authenticated frames.

Layout of every frame::

    byte 0      version << 4 | kind
    byte 1      sender index (order of the scenario's vehicles)
    body        a msgpack array of small ints (and one bin for id lists / bitmaps)
    last 4      HMAC-SHA256(fleet key, header + body), truncated

Every body starts with ``[seq, heard, ...]``. The sequence number is the send time in whole
simulation seconds, bumped by one when two frames would share a second: strictly increasing
per sender (replay protection) and a timestamp at once, so no separate time field is needed.
``heard`` packs, two bits per vehicle index, how long ago the sender last heard each peer
(`HEARD_AGES`): the piggybacked, SWIM-style evidence `fleet_agent.membership` uses. Positions
are decimetres from the scenario's south-west corner (coarser only for fields wider than
6.5 km), depth in decimetres, yaw in whole degrees. Task ids travel as their index in the
scenario (one byte for up to 256 spots). Every frame is at most 64 bytes and a pose at most 32
(`max_size` computes the worst case of each kind; `encode` refuses anything larger).
"""

from __future__ import annotations

import hashlib
import hmac
import math
from dataclasses import dataclass
from enum import IntEnum
from typing import Sequence, Union

import msgpack

from hfc_core.problem import Problem

VERSION = 1
MAC_BYTES = 4
HEADER_BYTES = 2
MAX_FRAME_BYTES = 64
MAX_POSE_BYTES = 32
MAX_VEHICLES = 8  # two "heard" bits per vehicle stay within 16 bits
MAX_SEQ = 2**32 - 1
SEGMENT_BITS = 320  # tasks covered by one cleared-set bitmap segment (40 bytes)
MAX_ID_BYTES = 41  # room for task ids in a claim/release frame
# "heard" codes 0, 1, 2: the peer was heard at most this many heartbeat periods (TDMA cycles)
# before the frame was sent; code 3: not within the last of them (or never).
HEARD_AGES = (1, 2, 4)
HEARD_NEVER = 3

# States a pose can report (telemetry names).
POSE_STATES = ("transit", "injecting", "returning", "home", "aborted")

# Why `decode` refused a frame (drop counters use these names).
DECODE_REASONS = ("short", "long", "version", "kind", "sender", "mac", "malformed")


class Kind(IntEnum):
    POSE = 1  # heartbeat: position, state, peers heard, digest of the cleared set
    CLEARED = 2  # a segment of the cleared-set bitmap (grow-only set, full state)
    CLAIM = 3  # "I will treat these spots" (claim time, ids)
    RELEASE = 4  # "I no longer hold these spots" (release time, ids)
    ABORT = 5  # "vehicle s aborted at t": its claims die, its spots are free (s may be the
    # sender, or a vehicle whose abort the sender heard: aborts spread epidemically)


class WireError(ValueError):
    """A frame `decode` refused; ``reason`` is one of `DECODE_REASONS`."""

    def __init__(self, reason: str, detail: str = "") -> None:
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason = reason


class WireSizeError(ValueError):
    """A message that cannot be encoded within its size limit."""


@dataclass(frozen=True)
class Digest:
    """Summary of a cleared set: size mod 128 and a 16-bit order-free hash."""

    count: int
    hash16: int


@dataclass(frozen=True)
class Pose:
    sender: int
    seq: int
    pos: tuple[float, float, float]  # metres, as quantised on the wire
    yaw_deg: int
    state: str
    digest: Digest
    heard: int = 0  # 2 bits per vehicle index: `HEARD_AGES` code


@dataclass(frozen=True)
class ClearedSegment:
    sender: int
    seq: int
    digest: Digest  # of the sender's whole set
    segment: int
    bits: bytes  # bit i of byte j: task index segment * SEGMENT_BITS + 8 j + i
    heard: int = 0


@dataclass(frozen=True)
class HoldingChange:
    """The body of a claim or a release: ``sender`` takes or gives up ``tasks`` at ``t_s``."""

    sender: int
    seq: int
    t_s: int
    tasks: tuple[int, ...]
    heard: int = 0


@dataclass(frozen=True)
class Claim(HoldingChange):
    pass


@dataclass(frozen=True)
class Release(HoldingChange):
    pass


@dataclass(frozen=True)
class Abort:
    sender: int
    seq: int
    t_s: int
    heard: int = 0
    subject: int | None = None  # the vehicle that aborted; None: the sender

    @property
    def who(self) -> int:
        return self.sender if self.subject is None else self.subject


Message = Union[Pose, ClearedSegment, Claim, Release, Abort]
_KIND_OF = {Pose: Kind.POSE, ClearedSegment: Kind.CLEARED, Claim: Kind.CLAIM,
            Release: Kind.RELEASE, Abort: Kind.ABORT}


def radio_kind(msg: Message) -> str:
    """The relay's queue class: a pose may be superseded by a newer one, nothing else."""
    return "pose" if isinstance(msg, Pose) else "data"


class Codec:
    """Encoder/decoder bound to one mission: the fleet key, roster size and geometry."""

    def __init__(self, key: bytes, n_vehicles: int, n_tasks: int,
                 origin_xy: tuple[float, float] = (0.0, 0.0), unit_m: float = 0.1) -> None:
        if len(key) < 16:
            raise ValueError("fleet key must be at least 16 bytes")
        if not 1 <= n_vehicles <= MAX_VEHICLES:
            raise ValueError(f"the wire format carries 1..{MAX_VEHICLES} vehicles")
        if not 0 <= n_tasks <= 65536:
            raise ValueError("the wire format carries at most 65536 spots")
        self._key = bytes(key)
        self.n_vehicles = n_vehicles
        self.n_tasks = n_tasks
        self.origin_xy = (float(origin_xy[0]), float(origin_xy[1]))
        self.unit_m = float(unit_m)
        self.id_width = 1 if n_tasks <= 256 else 2
        self.max_ids = MAX_ID_BYTES // self.id_width
        self.n_segments = max(1, math.ceil(n_tasks / SEGMENT_BITS))

    @staticmethod
    def for_problem(problem: Problem, key: bytes) -> "Codec":
        """Origin at the south-west corner of everything in the scenario (100 m margin);
        decimetres unless the field is wider than 6.5 km."""
        xy = problem.xyz[:, :2]
        lo = xy.min(axis=0) - 100.0
        span = float((xy.max(axis=0) + 100.0 - lo).max())
        unit = max(0.1, span / 65535.0)
        return Codec(key, problem.n_vehicles, problem.n_tasks, (float(lo[0]), float(lo[1])), unit)

    # -- encoding --------------------------------------------------------------------------

    def encode(self, msg: Message) -> bytes:
        kind = _KIND_OF[type(msg)]
        if not 0 <= msg.sender < self.n_vehicles:
            raise ValueError(f"sender index {msg.sender} outside the roster")
        if not 0 <= msg.seq <= MAX_SEQ:
            raise ValueError(f"sequence number {msg.seq} out of range")
        if not 0 <= msg.heard < (1 << (2 * self.n_vehicles)):
            raise ValueError("heard field outside the roster")
        fields = self._fields(msg)
        body = msgpack.packb([fields[0], msg.heard, *fields[1:]], use_bin_type=True)
        head = bytes(((VERSION << 4) | int(kind), msg.sender))
        frame = head + body + self._mac(head + body)
        limit = MAX_POSE_BYTES if kind == Kind.POSE else MAX_FRAME_BYTES
        if len(frame) > limit:
            raise WireSizeError(f"{kind.name} frame of {len(frame)} bytes exceeds {limit}")
        return frame

    def _fields(self, msg: Message) -> list:
        if isinstance(msg, Pose):
            x, y, z = self.quantise(msg.pos)
            yaw = int(round(msg.yaw_deg)) % 360
            yaw = yaw - 360 if yaw >= 180 else yaw
            return [msg.seq, x, y, z, yaw, POSE_STATES.index(msg.state),
                    msg.digest.count & 0x7F, msg.digest.hash16 & 0xFFFF]
        if isinstance(msg, ClearedSegment):
            if not 0 <= msg.segment < self.n_segments:
                raise ValueError(f"segment {msg.segment} outside the set")
            if len(msg.bits) != self._segment_bytes(msg.segment):
                raise ValueError("segment bitmap has the wrong length")
            return [msg.seq, msg.digest.count & 0x7F, msg.digest.hash16 & 0xFFFF, msg.segment,
                    bytes(msg.bits)]
        if isinstance(msg, HoldingChange):
            if not 0 < len(msg.tasks) <= self.max_ids:
                raise WireSizeError(f"a claim carries 1..{self.max_ids} spots, got {len(msg.tasks)}")
            if not 0 <= msg.t_s <= MAX_SEQ:
                raise ValueError("claim time out of range")
            return [msg.seq, msg.t_s, self._pack_ids(msg.tasks)]
        if not 0 <= msg.who < self.n_vehicles:
            raise ValueError(f"abort subject {msg.who} outside the roster")
        return [msg.seq, msg.t_s, msg.who]

    def quantise(self, pos: Sequence[float]) -> tuple[int, int, int]:
        u = self.unit_m
        x = min(65535, max(0, round((pos[0] - self.origin_xy[0]) / u)))
        y = min(65535, max(0, round((pos[1] - self.origin_xy[1]) / u)))
        z = min(32767, max(-32768, round(pos[2] / u)))
        return int(x), int(y), int(z)

    def dequantise(self, x: int, y: int, z: int) -> tuple[float, float, float]:
        u = self.unit_m
        return (self.origin_xy[0] + x * u, self.origin_xy[1] + y * u, z * u)

    def _pack_ids(self, tasks: Sequence[int]) -> bytes:
        out = bytearray()
        for t in tasks:
            if not 0 <= t < self.n_tasks:
                raise ValueError(f"task index {t} outside the scenario")
            out += int(t).to_bytes(self.id_width, "little")
        return bytes(out)

    def _segment_bytes(self, segment: int) -> int:
        bits = min(SEGMENT_BITS, self.n_tasks - segment * SEGMENT_BITS)
        return max(1, math.ceil(bits / 8))

    def _mac(self, data: bytes) -> bytes:
        return hmac.new(self._key, data, hashlib.sha256).digest()[:MAC_BYTES]

    # -- decoding --------------------------------------------------------------------------

    def decode(self, frame: bytes) -> Message:
        """The message in ``frame``, or `WireError` naming why it was refused.

        Only the two header bytes are looked at before the MAC is checked: nothing
        unauthenticated reaches the msgpack parser."""
        frame = bytes(frame)
        if len(frame) < HEADER_BYTES + 1 + MAC_BYTES:
            raise WireError("short", f"{len(frame)} bytes")
        if len(frame) > MAX_FRAME_BYTES:
            raise WireError("long", f"{len(frame)} bytes")
        version, kind_no, sender = frame[0] >> 4, frame[0] & 0x0F, frame[1]
        if version != VERSION:
            raise WireError("version", str(version))
        try:
            kind = Kind(kind_no)
        except ValueError:
            raise WireError("kind", str(kind_no)) from None
        if sender >= self.n_vehicles:
            raise WireError("sender", str(sender))
        if not hmac.compare_digest(self._mac(frame[:-MAC_BYTES]), frame[-MAC_BYTES:]):
            raise WireError("mac")
        try:
            fields = msgpack.unpackb(frame[HEADER_BYTES:-MAC_BYTES], raw=False,
                                     strict_map_key=True, use_list=True)
            return self._message(kind, sender, fields)
        except WireError:
            raise
        except Exception as exc:  # msgpack raises several unrelated types on garbage
            raise WireError("malformed", repr(exc)) from None

    def _message(self, kind: Kind, sender: int, f: list) -> Message:
        arity = {Kind.POSE: 9, Kind.CLEARED: 6, Kind.CLAIM: 4, Kind.RELEASE: 4, Kind.ABORT: 4}
        if not isinstance(f, list) or len(f) != arity[kind]:
            raise WireError("malformed", "wrong field count")
        blob = f[-1] if kind in (Kind.CLEARED, Kind.CLAIM, Kind.RELEASE) else None
        ints = f[:-1] if blob is not None else f
        if not all(isinstance(v, int) and not isinstance(v, bool) for v in ints):
            raise WireError("malformed", "non-integer field")
        if blob is not None and not isinstance(blob, bytes):
            raise WireError("malformed", "expected a byte string")
        seq, heard, f = f[0], f[1], f[2:]
        if not 0 <= seq <= MAX_SEQ:
            raise WireError("malformed", "sequence number out of range")
        if not 0 <= heard < (1 << (2 * self.n_vehicles)):
            raise WireError("malformed", "heard field outside the roster")
        if kind == Kind.POSE:
            x, y, z, yaw, state, count, h16 = f
            if not (0 <= x <= 65535 and 0 <= y <= 65535 and -32768 <= z <= 32767
                    and -180 <= yaw < 180 and 0 <= state < len(POSE_STATES)
                    and 0 <= count < 128 and 0 <= h16 <= 0xFFFF):
                raise WireError("malformed", "pose field out of range")
            return Pose(sender, seq, self.dequantise(x, y, z), yaw, POSE_STATES[state],
                        Digest(count, h16), heard)
        if kind == Kind.CLEARED:
            count, h16, segment, bits = f
            if not (0 <= count < 128 and 0 <= h16 <= 0xFFFF and 0 <= segment < self.n_segments
                    and len(bits) == self._segment_bytes(segment)):
                raise WireError("malformed", "cleared segment out of range")
            return ClearedSegment(sender, seq, Digest(count, h16), segment, bits, heard)
        if kind in (Kind.CLAIM, Kind.RELEASE):
            t_s, raw = f
            w = self.id_width
            if not (0 <= t_s <= MAX_SEQ and raw and len(raw) % w == 0):
                raise WireError("malformed", "claim out of range")
            tasks = tuple(int.from_bytes(raw[i:i + w], "little") for i in range(0, len(raw), w))
            if any(t >= self.n_tasks for t in tasks):
                raise WireError("malformed", "unknown spot")
            return (Claim if kind == Kind.CLAIM else Release)(sender, seq, t_s, tasks, heard)
        t_s, who = f
        if not (0 <= t_s <= MAX_SEQ and 0 <= who < self.n_vehicles):
            raise WireError("malformed", "abort out of range")
        return Abort(sender, seq, t_s, heard, None if who == sender else who)

    # -- limits ----------------------------------------------------------------------------

    def largest(self, kind: Kind) -> Message:
        """The largest message of ``kind`` this codec can produce (for the size test)."""
        top = self.n_vehicles - 1
        far = (self.origin_xy[0] + 65535 * self.unit_m, self.origin_xy[1] + 65535 * self.unit_m,
               -32768 * self.unit_m)
        digest = Digest(127, 0xFFFF)
        heard = (1 << (2 * self.n_vehicles)) - 1
        if kind == Kind.POSE:
            return Pose(top, MAX_SEQ, far, -180, "aborted", digest, heard)
        if kind == Kind.CLEARED:
            sizes = [self._segment_bytes(s) for s in range(self.n_segments)]
            seg = max(range(self.n_segments), key=lambda s: (sizes[s], s))
            return ClearedSegment(top, MAX_SEQ, digest, seg, b"\xff" * sizes[seg], heard)
        if kind in (Kind.CLAIM, Kind.RELEASE):
            n = min(self.max_ids, self.n_tasks)
            ids = tuple(range(self.n_tasks - n, self.n_tasks))
            return (Claim if kind == Kind.CLAIM else Release)(top, MAX_SEQ, MAX_SEQ, ids, heard)
        return Abort(top, MAX_SEQ, MAX_SEQ, heard, max(0, top - 1))
