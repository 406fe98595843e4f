"""The agent's append-only journal: what it cleared, what it knows, where it was.

File layout: the 4-byte magic ``CFJ1``, then records, each ``u32 length | u32 CRC-32 |
msgpack map`` (little-endian). A process killed mid-write leaves at most one torn record at
the end: reading stops at the first record that is short or fails its CRC, and opening for
append cuts that tail off, so the journal stays a clean prefix of what was written.

Durability: every record is flushed to the OS at once (it survives the process being
killed); records marked durable (own treatments, claims, abort) are also fsync'ed (they
survive the machine).
"""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path
from typing import Any, BinaryIO

import msgpack

MAGIC = b"CFJ1"
_HEAD = struct.Struct("<II")
MAX_RECORD = 1 << 20


def encode_record(doc: dict[str, Any]) -> bytes:
    payload = msgpack.packb(doc, use_bin_type=True)
    return _HEAD.pack(len(payload), zlib.crc32(payload)) + payload


def decode_records(data: bytes) -> tuple[list[dict[str, Any]], int]:
    """The records of a journal image and the length of its valid prefix."""
    if not data.startswith(MAGIC):
        return [], 0
    records: list[dict[str, Any]] = []
    pos = len(MAGIC)
    while pos + _HEAD.size <= len(data):
        length, crc = _HEAD.unpack_from(data, pos)
        end = pos + _HEAD.size + length
        if length > MAX_RECORD or end > len(data):
            break
        payload = data[pos + _HEAD.size:end]
        if zlib.crc32(payload) != crc:
            break
        try:
            doc = msgpack.unpackb(payload, raw=False, strict_map_key=False)
        except Exception:  # msgpack raises several unrelated types on garbage
            break
        if not isinstance(doc, dict):
            break
        records.append(doc)
        pos = end
    return records, pos


class Journal:
    """A journal file: `records` holds what was there when opened."""

    def __init__(self, path: str | Path, fsync: bool = True) -> None:
        self.path = Path(path)
        self.fsync = fsync
        data = self.path.read_bytes() if self.path.exists() else b""
        self.records, valid = decode_records(data)
        self.torn_bytes = len(data) - valid if valid else 0
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._fh: BinaryIO = open(self.path, "r+b" if valid else "wb")
        if valid:
            self._fh.truncate(valid)
            self._fh.seek(valid)
        else:
            self._fh.write(MAGIC)
            self._flush(True)

    def append(self, doc: dict[str, Any], durable: bool = False) -> None:
        self._fh.write(encode_record(doc))
        self._flush(durable)

    def _flush(self, durable: bool) -> None:
        self._fh.flush()
        if durable and self.fsync:
            os.fsync(self._fh.fileno())

    def close(self) -> None:
        if not self._fh.closed:
            self._flush(True)
            self._fh.close()

    def __enter__(self) -> "Journal":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class MemoryJournal:
    """The same byte format in memory (the in-process simulation's vehicles)."""

    def __init__(self, data: bytes = b"") -> None:
        self.records, valid = decode_records(data)
        self.data = bytearray(data[:valid] if valid else MAGIC)

    def append(self, doc: dict[str, Any], durable: bool = False) -> None:
        self.data += encode_record(doc)

    def reopen(self) -> "MemoryJournal":
        """What a restarted process would read back."""
        return MemoryJournal(bytes(self.data))
