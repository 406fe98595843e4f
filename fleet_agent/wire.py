"""The acoustic wire protocol, version 3: compact, quantised, versioned, authenticated frames.

Layout of every frame (fixed binary fields, big-endian; `docs/wire.md` has the full table)::

    byte 0        version << 4 | kind
    byte 1        sender index (order of the scenario's vehicles; up to `MAX_VEHICLES`)
    bytes 2-5     seq: the send time in whole simulation seconds (uint32)
    byte 6        heard offset: the roster index of the first peer in the heard window
    next c bytes  heard codes, 2 bits each, for min(n, `HEARD_WINDOW`) peers from the offset
    next 8        every kind but POSE: the sender's disclosed key of its previous cycle
    body          kind-specific fixed fields (`_BODY`), then a tail (id list, bitmap)
    next 4        the sender's own tag (`fleet_bus.tesla`: its chain key of the frame's cycle)
    last 4        HMAC-SHA256 under the sender's run key over all before it (the fleet MAC)

The sequence number is strictly increasing per sender (replay protection) and a timestamp at
once, so no separate time field is needed: bumped by one when two frames would share a second.
The heard codes are the piggybacked, SWIM-style evidence `fleet_agent.membership` uses: how
long ago the sender last heard each peer of a window that rotates over the roster
(`heard_offset`), so every peer's evidence is carried at least every ceil(n / 16) frames of
each sender whatever the fleet size. Positions are decimetres from the scenario's south-west
corner (coarser only for fields wider than 6.5 km), depth in decimetres, yaw in whole degrees.
Task ids travel as their index in the scenario (one byte for up to 256 spots, else two).
The frame budget is the modem's (`fleet_bus.modem_port.ModemSpec.max_frame_bytes`, 64 bytes
on the emulated water): a claim carries as many ids and a cleared-set segment as many bits
as it leaves room for, and a pose is at most 32 bytes whatever the budget (a WHOI
Micro-Modem rate-0 frame). `Codec.max_size` gives the worst case of each kind; `encode`
refuses anything larger, and a codec whose budget cannot carry a kind the mission needs is
refused when it is made.

Keys: the fleet MAC key of sender ``s`` is derived from the fleet key, the run id and ``s``
(`sender_key`), so a frame recorded in one run fails the MAC in every other run; it keeps
outsiders out at once. Every vehicle holds the fleet key (it must check everyone), so the
fleet MAC cannot say which vehicle sent a frame: the sender's tag does, once the key of the
frame's cycle is disclosed (`fleet_bus.tesla`, delayed key disclosure). `decode` checks the
fleet MAC and returns what the tag check needs (`Sealed`); the agent holds the frame until
then.
"""

from __future__ import annotations

import hashlib
import hmac
import math
import struct
from dataclasses import dataclass
from enum import IntEnum
from typing import Callable, Sequence, Union

from fleet_bus.tesla import tag as tesla_tag
from hfc_core.model.problem import Problem

VERSION = 3
FLEET_MAC_BYTES = 4  # 2^-32 per frame an outsider forges, each costing a slot of airtime
TAG_BYTES = 4  # the sender's own tag (`fleet_bus.tesla`)
KEY_BYTES = 8  # a disclosed chain key
MAC_BYTES = FLEET_MAC_BYTES + TAG_BYTES
HEADER_BYTES = 7  # version|kind, sender, seq (4), heard offset; the heard codes follow
MAX_FRAME_BYTES = 64  # the emulated water's budget, the default (`fleet_bus.modem_port`)
MAX_POSE_BYTES = 32
MIN_FRAME_BYTES = 40  # a cleared segment of 64 spots with its disclosed key
MAX_VEHICLES = 255  # the sender index is one byte
MAX_TASKS = 65536  # a task id is at most two bytes
MAX_SEQ = 2**32 - 1
# A frame's seq is its send time on the shared mission clock, so one from further ahead of the
# receiver's clock than this is forged (an insider's way to push a sender's replay high-water
# mark to the end of time and silence it); the agent drops it as "future".
MAX_LEAD_S = 30
HEARD_WINDOW = 16  # peers whose heard code one frame carries (4 bytes)
# Around a claim's ids and a segment's bitmap: header 7, heard codes up to 4, a disclosed key
# 8, MACs 8, and the claim's time (4) or the segment's count, hash and number (4, one byte
# kept spare).
CLAIM_OVERHEAD_BYTES = 31
SEGMENT_OVERHEAD_BYTES = 32


def segment_bits(max_frame_bytes: int) -> int:
    """Spots one cleared-set segment covers in frames of ``max_frame_bytes`` (256 in 64)."""
    return 8 * (max_frame_bytes - SEGMENT_OVERHEAD_BYTES)


SEGMENT_BITS = segment_bits(MAX_FRAME_BYTES)
# "heard" codes 0, 1, 2: the peer was heard at most this many heartbeat periods (TDMA cycles)
# before the frame was sent; code 3: not within the last of them (or never).
HEARD_AGES = (1, 2, 4)
HEARD_NEVER = 3

# States a pose can report (telemetry names).
POSE_STATES = ("transit", "injecting", "returning", "home", "aborted")

# Why `decode` refused a frame (drop counters use these names).
DECODE_REASONS = ("short", "long", "version", "kind", "sender", "mac", "malformed")


def heard_window(n_vehicles: int) -> int:
    """How many heard codes a frame of an ``n_vehicles`` fleet carries."""
    return min(n_vehicles, HEARD_WINDOW)


def heard_offset(sender: int, cycle: int, n_vehicles: int) -> int:
    """The first roster index of the heard window ``sender`` reports in TDMA cycle ``cycle``.

    Consecutive cycles of one sender tile the roster, so each peer is covered at least every
    ceil(n / `HEARD_WINDOW`) cycles; senders are staggered, so in every cycle each peer is
    reported on by about a window's worth of senders rather than by all or none."""
    if n_vehicles <= HEARD_WINDOW:
        return 0
    return ((cycle + sender) * HEARD_WINDOW) % n_vehicles


def sender_key(fleet_key: bytes, run_id: str, sender: int) -> bytes:
    """The MAC key of ``sender`` in run ``run_id``: HMAC-SHA256 derivations (HKDF-expand
    style) from the fleet key, so one fleet key serves every run without a frame of one run
    ever verifying in another."""
    run_key = hmac.new(fleet_key, b"cotsfleet wire v2 run\x00" + run_id.encode("utf-8"),
                       hashlib.sha256).digest()
    return hmac.new(run_key, b"sender\x00" + bytes([sender]), hashlib.sha256).digest()


class Kind(IntEnum):
    POSE = 1  # heartbeat: position, state, peers heard, digest of the cleared set
    CLEARED = 2  # a segment of the cleared-set bitmap (grow-only set, full state)
    CLAIM = 3  # "I will treat these spots" (claim time, ids)
    RELEASE = 4  # "I no longer hold these spots" (release time, ids)
    ABORT = 5  # "vehicle s aborted at t": its claims die, its spots are free (s may be the
    # sender, or a vehicle whose abort the sender heard: aborts spread epidemically)
    FOUND = 6  # a COTS aggregation the map missed: its slot, position, priority, injection
    # time, and the digest of the sender's finds (gossiped until digests agree)
    KEY = 7  # nothing but the disclosed key: a sender with nothing else to say after a pose


class WireError(ValueError):
    """A frame `decode` refused; ``reason`` is one of `DECODE_REASONS`."""

    def __init__(self, reason: str, detail: str = "") -> None:
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason = reason


class WireSizeError(ValueError):
    """A message that cannot be encoded within its size limit."""


@dataclass(frozen=True)
class Heard:
    """Heard codes for a window of the roster: peer ``(offset + i) % n`` has ``codes[i]``
    (a `HEARD_AGES` index, or `HEARD_NEVER`). Trailing `HEARD_NEVER` codes are dropped, so
    equal evidence compares equal whatever the window's length."""

    offset: int = 0
    codes: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        codes = tuple(self.codes)
        while codes and codes[-1] == HEARD_NEVER:
            codes = codes[:-1]
        object.__setattr__(self, "codes", codes)

    def items(self, n_vehicles: int) -> list[tuple[int, int]]:
        """(peer index, code) for every code other than `HEARD_NEVER`."""
        return [((self.offset + i) % n_vehicles, c) for i, c in enumerate(self.codes)
                if c != HEARD_NEVER]


NO_HEARD = Heard()


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
    heard: Heard = NO_HEARD


@dataclass(frozen=True)
class ClearedSegment:
    sender: int
    seq: int
    digest: Digest  # of the sender's whole set
    segment: int
    bits: bytes  # bit i of byte j: task index segment * segment_bits + 8 j + i
    heard: Heard = NO_HEARD


@dataclass(frozen=True)
class HoldingChange:
    """The body of a claim or a release: ``sender`` takes or gives up ``tasks`` at ``t_s``."""

    sender: int
    seq: int
    t_s: int
    tasks: tuple[int, ...]
    heard: Heard = NO_HEARD


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
    heard: Heard = NO_HEARD
    subject: int | None = None  # the vehicle that aborted; None: the sender

    @property
    def who(self) -> int:
        return self.sender if self.subject is None else self.subject


@dataclass(frozen=True)
class Found:
    """A discovered aggregation (dynamic missions): ``slot`` is its task index (n + finder *
    slots per vehicle + counter, so two finders never name two finds alike), ``pos`` as
    quantised on the wire, priority and injection time in tenths (16 bits each); ``digest``
    summarises every find the sender knows (`fleet_agent.beliefs`)."""

    sender: int
    seq: int
    digest: Digest
    slot: int
    pos: tuple[float, float, float]
    priority: float
    service_s: float
    heard: Heard = NO_HEARD


@dataclass(frozen=True)
class Key:
    """A frame that only discloses its sender's key of the previous cycle."""

    sender: int
    seq: int
    heard: Heard = NO_HEARD


Message = Union[Pose, ClearedSegment, Claim, Release, Abort, Found, Key]
_KIND_OF = {Pose: Kind.POSE, ClearedSegment: Kind.CLEARED, Claim: Kind.CLAIM,
            Release: Kind.RELEASE, Abort: Kind.ABORT, Found: Kind.FOUND, Key: Kind.KEY}


@dataclass(frozen=True)
class Sealed:
    """A frame whose fleet MAC checked: its message, and what its sender's tag covers (``data``),
    the tag, and the key it discloses (None: a pose discloses none)."""

    msg: Message
    data: bytes
    tag: bytes
    disclosed: bytes | None
MAX_TENTHS = 65535  # a find's priority and injection time travel as tenths in 16 bits


def radio_kind(msg: Message) -> str:
    """The relay's queue class: a pose may be superseded by a newer one, nothing else."""
    return "pose" if isinstance(msg, Pose) else "data"


# Fixed fields after the header, per kind; a claim/release and a cleared segment end with a
# tail of bytes (task ids; the segment's bitmap).
_BODY = {
    Kind.POSE: struct.Struct(">HHhHBH"),  # x, y, z, yaw + 180 << 3 | state, count, hash16
    Kind.CLEARED: struct.Struct(">BHB"),  # count, hash16, segment; bitmap tail
    Kind.CLAIM: struct.Struct(">I"),  # claim time; id tail
    Kind.RELEASE: struct.Struct(">I"),  # release time; id tail
    Kind.ABORT: struct.Struct(">IB"),  # abort time, the vehicle that aborted
    # finds' count, hash16, slot, x, y, z, priority and injection time in tenths
    Kind.FOUND: struct.Struct(">BHHHHhHH"),
    Kind.KEY: struct.Struct(">"),  # nothing: the disclosed key is the frame
}
_HEAD = struct.Struct(">BBIB")  # version|kind, sender, seq, heard offset
_MIN_BODY = 0  # the smallest body of any kind: a KEY frame's


class Codec:
    """Encoder/decoder bound to one mission: the run's keys, roster size and geometry."""

    def __init__(self, key: bytes, run_id: str, n_vehicles: int, n_tasks: int,
                 origin_xy: tuple[float, float] = (0.0, 0.0), unit_m: float = 0.1,
                 found_from: int | None = None,
                 max_frame_bytes: int = MAX_FRAME_BYTES) -> None:
        if len(key) < 16:
            raise ValueError("fleet key must be at least 16 bytes")
        if not isinstance(run_id, str) or not run_id:
            raise ValueError("the wire keys need the mission's run id")
        if not 1 <= n_vehicles <= MAX_VEHICLES:
            raise ValueError(f"the wire format carries 1..{MAX_VEHICLES} vehicles")
        if not 0 <= n_tasks <= MAX_TASKS:
            raise ValueError(f"the wire format carries at most {MAX_TASKS} spots")
        if not MIN_FRAME_BYTES <= max_frame_bytes <= 4096:
            raise ValueError(f"the wire format needs frames of {MIN_FRAME_BYTES}..4096 bytes, "
                             f"the modem carries {max_frame_bytes}")
        self.run_id = run_id
        self.n_vehicles = n_vehicles
        self.n_tasks = n_tasks
        self.origin_xy = (float(origin_xy[0]), float(origin_xy[1]))
        self.unit_m = float(unit_m)
        self.max_frame_bytes = int(max_frame_bytes)
        self.max_pose_bytes = min(MAX_POSE_BYTES, self.max_frame_bytes)
        self.id_width = 1 if n_tasks <= 256 else 2
        self.max_ids = (self.max_frame_bytes - CLAIM_OVERHEAD_BYTES) // self.id_width
        self.segment_bits = segment_bits(self.max_frame_bytes)
        self.n_segments = max(1, math.ceil(n_tasks / self.segment_bits))
        # FOUND frames name slots found_from..n_tasks-1 (None: a mission without discovery)
        self.found_from = n_tasks if found_from is None else int(found_from)
        self.window = heard_window(n_vehicles)
        self.code_bytes = math.ceil(self.window / 4)
        # One keyed HMAC state per sender, copied per frame (255 key schedules once, not one
        # per frame).
        self._macs = [hmac.new(sender_key(key, run_id, s), digestmod=hashlib.sha256)
                      for s in range(n_vehicles)]
        kinds = [k for k in Kind if (k != Kind.FOUND or self.found_from < n_tasks)
                 and (k not in (Kind.CLAIM, Kind.RELEASE) or n_tasks > 0)]
        too_big = [k.name for k in kinds if len(self._pack(self.largest(k))) >
                   (self.max_pose_bytes if k == Kind.POSE else self.max_frame_bytes)]
        if too_big:
            raise ValueError(f"frames of {self.max_frame_bytes} bytes cannot carry "
                             f"{', '.join(too_big)} frames of this mission: use a modem (rate) "
                             "with larger frames")

    @staticmethod
    def for_problem(problem: Problem, key: bytes, run_id: str, margin_m: float = 100.0,
                    found_from: int | None = None,
                    max_frame_bytes: int = MAX_FRAME_BYTES) -> "Codec":
        """Origin at the south-west corner of everything in the scenario (``margin_m``
        margin: wider in dynamic missions, where finds may lie off the map); decimetres unless
        the field is wider than 6.5 km; frames of the modem's ``max_frame_bytes``."""
        xy = problem.xyz[:, :2]
        lo = xy.min(axis=0) - margin_m
        span = float((xy.max(axis=0) + margin_m - lo).max())
        unit = max(0.1, span / 65535.0)
        return Codec(key, run_id, problem.n_vehicles, problem.n_tasks,
                     (float(lo[0]), float(lo[1])), unit, found_from, max_frame_bytes)

    # -- encoding --------------------------------------------------------------------------

    def encode(self, msg: Message, chain_key: bytes = bytes(KEY_BYTES),
               disclosed: bytes = bytes(KEY_BYTES)) -> bytes:
        """The frame of ``msg``: tagged under the sender's ``chain_key`` of the frame's cycle,
        disclosing ``disclosed`` (its key of the cycle before; ignored for a pose)."""
        frame = self._pack(msg, chain_key, disclosed)
        kind = _KIND_OF[type(msg)]
        limit = self.max_pose_bytes if kind == Kind.POSE else self.max_frame_bytes
        if len(frame) > limit:
            raise WireSizeError(f"{kind.name} frame of {len(frame)} bytes exceeds {limit}")
        return frame

    def _pack(self, msg: Message, chain_key: bytes = bytes(KEY_BYTES),
              disclosed: bytes = bytes(KEY_BYTES)) -> bytes:
        kind = _KIND_OF[type(msg)]
        if not 0 <= msg.sender < self.n_vehicles:
            raise ValueError(f"sender index {msg.sender} outside the roster")
        if not 0 <= msg.seq <= MAX_SEQ:
            raise ValueError(f"sequence number {msg.seq} out of range")
        head = _HEAD.pack((VERSION << 4) | int(kind), msg.sender, msg.seq,
                          self._check_heard(msg.heard)) + self._pack_codes(msg.heard.codes)
        if kind != Kind.POSE:
            if len(disclosed) != KEY_BYTES:
                raise ValueError(f"a disclosed key is {KEY_BYTES} bytes")
            head += bytes(disclosed)
        data = head + self._body(kind, msg)
        data += tesla_tag(chain_key, data)
        return data + self._mac(msg.sender, data)

    def _check_heard(self, heard: Heard) -> int:
        if not 0 <= heard.offset < self.n_vehicles:
            raise ValueError(f"heard offset {heard.offset} outside the roster")
        if len(heard.codes) > self.window or \
                not all(isinstance(c, int) and 0 <= c <= HEARD_NEVER for c in heard.codes):
            raise ValueError(f"heard window holds 1..{self.window} codes of 0..{HEARD_NEVER}")
        return heard.offset

    def _pack_codes(self, codes: Sequence[int]) -> bytes:
        padded = list(codes) + [HEARD_NEVER] * (4 * self.code_bytes - len(codes))
        return bytes(sum(c << (2 * j) for j, c in enumerate(padded[i:i + 4]))
                     for i in range(0, len(padded), 4))

    def _body(self, kind: Kind, msg: Message) -> bytes:
        fmt = _BODY[kind]
        if isinstance(msg, Pose):
            x, y, z = self.quantise(msg.pos)
            yaw = int(round(msg.yaw_deg)) % 360
            yaw = yaw - 360 if yaw >= 180 else yaw
            return fmt.pack(x, y, z, (yaw + 180) << 3 | POSE_STATES.index(msg.state),
                            msg.digest.count & 0x7F, msg.digest.hash16 & 0xFFFF)
        if isinstance(msg, ClearedSegment):
            if not 0 <= msg.segment < self.n_segments:
                raise ValueError(f"segment {msg.segment} outside the set")
            if len(msg.bits) != self._segment_bytes(msg.segment):
                raise ValueError("segment bitmap has the wrong length")
            return fmt.pack(msg.digest.count & 0x7F, msg.digest.hash16 & 0xFFFF,
                            msg.segment) + bytes(msg.bits)
        if isinstance(msg, HoldingChange):
            if not 0 < len(msg.tasks) <= self.max_ids:
                raise WireSizeError(f"a claim carries 1..{self.max_ids} spots, "
                                    f"got {len(msg.tasks)}")
            if not 0 <= msg.t_s <= msg.seq:
                raise ValueError("claim time out of range (after the frame was sent)")
            return fmt.pack(msg.t_s) + self._pack_ids(msg.tasks)
        if isinstance(msg, Key):
            return b""
        if isinstance(msg, Found):
            if not 0 <= msg.slot < self.n_tasks:  # decode also checks it is a find's slot
                raise ValueError(f"find slot {msg.slot} outside the scenario")
            prio, service = round(msg.priority * 10), round(msg.service_s * 10)
            if not (0 <= prio <= MAX_TENTHS and 0 <= service <= MAX_TENTHS):
                raise WireSizeError("find priority or injection time beyond 6553.5")
            return fmt.pack(msg.digest.count & 0x7F, msg.digest.hash16 & 0xFFFF, msg.slot,
                            *self.quantise(msg.pos), prio, service)
        if not 0 <= msg.who < self.n_vehicles:
            raise ValueError(f"abort subject {msg.who} outside the roster")
        if not 0 <= msg.t_s <= MAX_SEQ:
            raise ValueError("abort time out of range")
        return fmt.pack(msg.t_s, msg.who)

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
        bits = min(self.segment_bits, self.n_tasks - segment * self.segment_bits)
        return max(1, math.ceil(bits / 8))

    def _mac(self, sender: int, data: bytes) -> bytes:
        h = self._macs[sender].copy()
        h.update(data)
        return h.digest()[:FLEET_MAC_BYTES]

    # -- decoding --------------------------------------------------------------------------

    def decode(self, frame: bytes) -> Message:
        """The message in ``frame`` (fleet MAC checked), or `WireError` naming why not."""
        return self.unseal(frame).msg

    def unseal(self, frame: bytes) -> Sealed:
        """The frame with its fleet MAC checked, or `WireError` naming why it was refused.

        Only the first two bytes are looked at before the MAC is checked: nothing
        unauthenticated reaches the field parser."""
        frame = bytes(frame)
        head_len = HEADER_BYTES + self.code_bytes
        if len(frame) < 2:
            raise WireError("short", f"{len(frame)} bytes")
        if len(frame) > self.max_frame_bytes:
            raise WireError("long", f"{len(frame)} bytes")
        version, kind_no, sender = frame[0] >> 4, frame[0] & 0x0F, frame[1]
        if version != VERSION:  # before the length: an old frame counts as old, whatever size
            raise WireError("version", str(version))
        try:
            kind = Kind(kind_no)
        except ValueError:
            raise WireError("kind", str(kind_no)) from None
        if sender >= self.n_vehicles:
            raise WireError("sender", str(sender))
        key_len = 0 if kind == Kind.POSE else KEY_BYTES
        if len(frame) < head_len + key_len + _MIN_BODY + MAC_BYTES:
            raise WireError("short", f"{len(frame)} bytes")
        signed = frame[:-FLEET_MAC_BYTES]
        if not hmac.compare_digest(self._mac(sender, signed), frame[-FLEET_MAC_BYTES:]):
            raise WireError("mac")
        _, _, seq, offset = _HEAD.unpack_from(frame)
        if offset >= self.n_vehicles:
            raise WireError("malformed", "heard offset outside the roster")
        heard = Heard(offset, self._unpack_codes(frame[HEADER_BYTES:head_len]))
        disclosed = frame[head_len:head_len + key_len] if key_len else None
        body = frame[head_len + key_len:-MAC_BYTES]
        fmt = _BODY[kind]
        if len(body) < fmt.size:
            raise WireError("malformed", "body too short")
        msg = _PARSE[kind](self, sender, seq, heard, fmt.unpack_from(body), body[fmt.size:])
        return Sealed(msg, signed[:-TAG_BYTES], signed[-TAG_BYTES:], disclosed)

    def _unpack_codes(self, raw: bytes) -> tuple[int, ...]:
        codes = [b >> (2 * j) & 3 for b in raw for j in range(4)]
        if any(c != HEARD_NEVER for c in codes[self.window:]):
            raise WireError("malformed", "heard codes beyond the window")
        return tuple(codes[:self.window])

    def _pose(self, sender: int, seq: int, heard: Heard, f: tuple, tail: bytes) -> Pose:
        x, y, z, yaw_state, count, h16 = f
        yaw, state = (yaw_state >> 3) - 180, yaw_state & 7
        if tail or not (yaw < 180 and state < len(POSE_STATES) and count < 128):
            raise WireError("malformed", "pose field out of range")
        return Pose(sender, seq, self.dequantise(x, y, z), yaw, POSE_STATES[state],
                    Digest(count, h16), heard)

    def _cleared(self, sender: int, seq: int, heard: Heard, f: tuple,
                 tail: bytes) -> ClearedSegment:
        count, h16, segment = f
        if not (count < 128 and segment < self.n_segments
                and len(tail) == self._segment_bytes(segment)):
            raise WireError("malformed", "cleared segment out of range")
        return ClearedSegment(sender, seq, Digest(count, h16), segment, tail, heard)

    def _holding(self, cls: type[HoldingChange], sender: int, seq: int, heard: Heard,
                 f: tuple, tail: bytes) -> HoldingChange:
        w = self.id_width
        if not (tail and len(tail) % w == 0 and len(tail) // w <= self.max_ids):
            raise WireError("malformed", "claim out of range")
        tasks = tuple(int.from_bytes(tail[i:i + w], "little") for i in range(0, len(tail), w))
        if any(t >= self.n_tasks for t in tasks):
            raise WireError("malformed", "unknown spot")
        if f[0] > seq:  # newest claim wins a conflict: a claim dated after its frame is forged
            raise WireError("malformed", "claim dated after its frame")
        return cls(sender, seq, f[0], tasks, heard)

    def _abort(self, sender: int, seq: int, heard: Heard, f: tuple, tail: bytes) -> Abort:
        t_s, who = f
        if tail or who >= self.n_vehicles:
            raise WireError("malformed", "abort out of range")
        return Abort(sender, seq, t_s, heard, None if who == sender else who)

    def _key(self, sender: int, seq: int, heard: Heard, f: tuple, tail: bytes) -> Key:
        if tail:
            raise WireError("malformed", "a key frame carries nothing else")
        return Key(sender, seq, heard)

    def _found(self, sender: int, seq: int, heard: Heard, f: tuple, tail: bytes) -> Found:
        count, h16, slot, x, y, z, prio, service = f
        if tail or not (count < 128 and self.found_from <= slot < self.n_tasks):
            raise WireError("malformed", "find out of range")
        return Found(sender, seq, Digest(count, h16), slot, self.dequantise(x, y, z),
                     prio / 10, service / 10, heard)

    # -- limits ----------------------------------------------------------------------------

    def largest(self, kind: Kind) -> Message:
        """The largest message of ``kind`` this codec can produce (for the size test)."""
        top = self.n_vehicles - 1
        far = (self.origin_xy[0] + 65535 * self.unit_m, self.origin_xy[1] + 65535 * self.unit_m,
               -32768 * self.unit_m)
        digest = Digest(127, 0xFFFF)
        heard = Heard(top, (0,) * self.window)
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
        if kind == Kind.FOUND:
            return Found(top, MAX_SEQ, digest, self.n_tasks - 1, far, MAX_TENTHS / 10,
                         MAX_TENTHS / 10, heard)
        if kind == Kind.KEY:
            return Key(top, MAX_SEQ, heard)
        return Abort(top, MAX_SEQ, MAX_SEQ, heard, top - 1 if top else None)

    def max_size(self, kind: Kind) -> int:
        """The worst-case frame size of ``kind`` under this codec, bytes."""
        return len(self.encode(self.largest(kind)))


_PARSE: dict[Kind, Callable[..., Message]] = {
    Kind.POSE: Codec._pose,
    Kind.CLEARED: Codec._cleared,
    Kind.CLAIM: lambda c, *a: c._holding(Claim, *a),
    Kind.RELEASE: lambda c, *a: c._holding(Release, *a),
    Kind.ABORT: Codec._abort,
    Kind.FOUND: Codec._found,
    Kind.KEY: Codec._key,
}
