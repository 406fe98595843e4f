"""Value checks shared by every decoder of the bus: one NaN or a string where a number
belongs must cost one dropped message, never a crashed process."""

from __future__ import annotations

import math
from typing import Any

import msgpack

MAX_PAYLOAD_BYTES = 1 << 20  # nothing on the bus is larger; a bigger payload is garbage


def unpack_map(payload: bytes, what: str) -> dict[str, Any]:
    """A msgpack map, or ValueError."""
    if len(payload) > MAX_PAYLOAD_BYTES:
        raise ValueError(f"{what}: {len(payload)} bytes is more than any {what}")
    try:
        doc = msgpack.unpackb(payload, raw=False, strict_map_key=False)
    except Exception as exc:  # msgpack raises several unrelated types on garbage
        raise ValueError(f"{what}: not msgpack: {exc!r}") from None
    if not isinstance(doc, dict):
        raise ValueError(f"{what}: payload must be a map")
    return doc


def number(value: Any, what: str) -> float:
    """A finite int or float (never a bool)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{what}: expected a number, got {value!r}")
    out = float(value)
    if not math.isfinite(out):
        raise ValueError(f"{what}: must be finite, got {value!r}")
    return out


def integer(value: Any, what: str, lo: int | None = None, hi: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ValueError(f"{what}: expected an integer, got {value!r}")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise ValueError(f"{what}: {value} outside {lo}..{hi}")
    return int(value)


def text(value: Any, what: str, max_len: int = 256) -> str:
    if not isinstance(value, str) or len(value) > max_len:
        raise ValueError(f"{what}: expected a string of at most {max_len} characters")
    return value


def ids(value: Any, what: str, max_len: int = 1 << 16) -> list[int]:
    """A list of integer ids."""
    if not isinstance(value, (list, tuple)) or len(value) > max_len:
        raise ValueError(f"{what}: expected a list of ids")
    return [integer(v, what) for v in value]


def point(value: Any, what: str) -> tuple[float, float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ValueError(f"{what}: expected [x, y, z]")
    return (number(value[0], what), number(value[1], what), number(value[2], what))


def str_map(value: Any, what: str, kind: type, max_len: int = 4096) -> dict:
    """A map of short strings to values of ``kind`` (ints are not bools here)."""
    if not isinstance(value, dict) or len(value) > max_len or not all(
            isinstance(k, str) and len(k) <= 256 and isinstance(v, kind)
            and not isinstance(v, bool) for k, v in value.items()):
        raise ValueError(f"{what}: expected a map of str -> {kind.__name__}")
    return dict(value)
