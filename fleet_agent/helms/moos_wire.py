"""The MOOS wire protocol (MOOS V10, as MOOSDB speaks it): messages, packets, the handshake.

Learned from core-moos (`libMOOS/Comms/MOOSMsg.cpp`, `MOOSCommPkt.cpp`, `MOOSCommClient.cpp`,
`MOOSAsyncCommClient.cpp`), written here; pure, no sockets. Everything is little-endian.

A *message* (`CMOOSMsg::Serialize`)::

    int32 length (of the whole message, this field included) | int32 id | char type |
    char data type | str source | str source aux | str community | str key |
    float64 time | float64 double value | float64 double value 2 | str string value

where ``str`` is an int32 byte count and the bytes. A *packet* (`CMOOSCommPkt::Serialize`)::

    int32 length (of the whole packet) | int32 message count | uint8 compressed (0) | messages

A client opens with the 32-byte protocol string (NUL padded), then a packet holding one
`DATA` message whose key is ``"asynchronous"`` (asking the DB to push mail as it arrives) and
whose string is the client's name; the DB answers with `WELCOME` (its string says
``"asynchronous"`` when it will push) or `POISON` (the reason in its string).

Time stamps are MOOS time: unix seconds times ``MOOSTimeWarp`` (`MOOSLocalTime`).
Decoding never trusts a length: a bad one raises `WireError`, which the client counts.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

PROTOCOL = b"ELKS CAN'T DANCE 2/8/10"
PROTOCOL_BYTES = 32
ASYNC_KEY = "asynchronous"

# Message types (MOOSMsg.h).
NOTIFY, REGISTER, UNREGISTER = "N", "R", "U"
NULL, DATA, POISON, WELCOME, TIMING, TERMINATE = ".", "i", "K", "W", "T", "^"
# Data types.
DOUBLE, STRING, BINARY = "D", "S", "B"

# A packet larger than this is refused: MOOSDB mail for one helm is kilobytes; a length beyond
# it is a corrupt stream or a hostile peer, and must not make us allocate it.
MAX_PACKET_BYTES = 4 * 1024 * 1024
_HEAD = struct.Struct("<iib")  # packet length, message count, compressed flag
_MSG_HEAD = struct.Struct("<iicc")  # message length, id, type, data type
_DOUBLES = struct.Struct("<ddd")
_INT = struct.Struct("<i")


class WireError(ValueError):
    """Bytes that are not a MOOS packet (the stream cannot be trusted after it)."""


@dataclass(frozen=True)
class MoosMsg:
    """One MOOS message. ``value`` is a float for `DOUBLE`, a str for `STRING` (and bytes
    for `BINARY`); ``time`` is MOOS time (warped unix seconds)."""

    kind: str
    key: str
    value: float | str | bytes
    time: float = -1.0
    source: str = ""
    source_aux: str = ""
    community: str = ""
    value2: float = -1.0
    msg_id: int = -1
    # The string field as sent whatever the data type (a WELCOME is a double, the skew, that
    # also says "asynchronous" in its string).
    text: str = ""

    @property
    def data_type(self) -> str:
        if isinstance(self.value, bytes):
            return BINARY
        return STRING if isinstance(self.value, str) else DOUBLE

    @property
    def is_double(self) -> bool:
        return self.data_type == DOUBLE


def _str(raw: bytes) -> bytes:
    return _INT.pack(len(raw)) + raw


def encode_msg(msg: MoosMsg) -> bytes:
    if len(msg.kind) != 1:
        raise ValueError(f"message type must be one character, got {msg.kind!r}")
    dtype = msg.data_type
    if dtype == DOUBLE:
        dval, sval = float(msg.value), b""
    else:
        dval = -1.0
        sval = msg.value if isinstance(msg.value, bytes) else str(msg.value).encode()
    body = (
        _INT.pack(msg.msg_id) + msg.kind.encode("latin-1") + dtype.encode("latin-1")
        + _str(msg.source.encode()) + _str(msg.source_aux.encode())
        + _str(msg.community.encode()) + _str(msg.key.encode())
        + _DOUBLES.pack(msg.time, dval, msg.value2) + _str(sval)
    )
    return _INT.pack(len(body) + _INT.size) + body


def encode_packet(msgs: list[MoosMsg]) -> bytes:
    body = b"".join(encode_msg(m) for m in msgs)
    return _HEAD.pack(_HEAD.size + len(body), len(msgs), 0) + body


def handshake_bytes(name: str, now: float) -> bytes:
    """What a client sends first: the protocol string, then its name in a `DATA` message
    stamped ``now`` (MOOS time; the DB estimates the client's clock skew from it)."""
    return PROTOCOL.ljust(PROTOCOL_BYTES, b"\0") + encode_packet(
        [MoosMsg(DATA, ASYNC_KEY, name, time=now, source=name)])


def packet_length(head: bytes) -> int:
    """The whole packet's length from its first four bytes (checked against the bound)."""
    (n,) = _INT.unpack(head[:4])
    if n < _HEAD.size or n > MAX_PACKET_BYTES:
        raise WireError(f"packet length {n} outside {_HEAD.size}..{MAX_PACKET_BYTES}")
    return n


class _Reader:
    def __init__(self, buf: bytes, pos: int, end: int) -> None:
        self.buf, self.pos, self.end = buf, pos, end

    def take(self, n: int) -> bytes:
        if n < 0 or self.pos + n > self.end:
            raise WireError(f"field of {n} bytes runs past the message end")
        out = self.buf[self.pos:self.pos + n]
        self.pos += n
        return out

    def int32(self) -> int:
        return _INT.unpack(self.take(4))[0]

    def string(self) -> bytes:
        return self.take(self.int32())


def _text(raw: bytes) -> str:
    return raw.decode("utf-8", errors="replace")


def decode_msg(buf: bytes, pos: int, end: int) -> tuple[MoosMsg, int]:
    """The message at ``buf[pos:]`` (within ``end``) and the position after it."""
    if pos + _MSG_HEAD.size > end:
        raise WireError("truncated message header")
    length, msg_id, kind, dtype = _MSG_HEAD.unpack_from(buf, pos)
    stop = pos + length
    if length < _MSG_HEAD.size or stop > end:
        raise WireError(f"message length {length} does not fit the packet")
    r = _Reader(buf, pos + _MSG_HEAD.size, stop)
    source, source_aux, community, key = r.string(), r.string(), r.string(), r.string()
    t, dval, dval2 = _DOUBLES.unpack(r.take(_DOUBLES.size))
    sval = r.string()
    dtype_s = dtype.decode("latin-1")
    value: float | str | bytes
    if dtype_s == DOUBLE:
        value = dval
    elif dtype_s == STRING:
        value = _text(sval)
    elif dtype_s == BINARY:
        value = bytes(sval)
    else:
        raise WireError(f"unknown data type {dtype!r}")
    msg = MoosMsg(kind.decode("latin-1"), _text(key), value, t, _text(source),
                  _text(source_aux), _text(community), dval2, msg_id, _text(sval))
    return msg, stop


def decode_packet(buf: bytes) -> list[MoosMsg]:
    """Every message of one whole packet (``len(buf)`` is its declared length)."""
    if len(buf) < _HEAD.size:
        raise WireError("truncated packet header")
    length, count, compressed = _HEAD.unpack_from(buf, 0)
    if length != len(buf):
        raise WireError(f"packet says {length} bytes, holds {len(buf)}")
    if compressed:
        raise WireError("compressed packets are not supported (MOOSDB never sends them)")
    if count < 0 or count > length:
        raise WireError(f"implausible message count {count}")
    pos, out = _HEAD.size, []
    for _ in range(count):
        msg, pos = decode_msg(buf, pos, length)
        out.append(msg)
    return out


def moos_time(unix_s: float, warp: float) -> float:
    """MOOS time of a unix instant under ``MOOSTimeWarp`` ``warp`` (`MOOSLocalTime`)."""
    if not (math.isfinite(warp) and warp > 0):
        raise ValueError(f"MOOS time warp must be positive, got {warp}")
    return unix_s * warp
