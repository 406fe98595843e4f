"""The agent's append-only journal: what it cleared, what it knows, where it was.

File layout: the 4-byte magic ``CFJ2``, then records, each framed on its own::

    b"\\xc5JR" (3-byte sync mark) | u32 length | u32 CRC-32 of (length, payload) | msgpack map

(little-endian). Damage costs only the records it touches: reading checks each record's CRC,
and after a bad one it looks for the next sync mark whose record checks out (resync), so one
flipped byte in the middle loses that record and nothing after it. A damaged magic does not
make the journal a new one either: the records behind it are read the same way.

A process killed mid-write leaves at most one torn record at the end: it is cut off when the
journal is opened for append. Any other unreadable bytes are damage: the file as found is
kept aside (``<name>.damaged-<n>``), the journal is rewritten with the records that could be
read, and `Journal.damage` says what was lost (the agent's ready line reports it).

Durability: every record is flushed to the OS at once (it survives the process being
killed); records marked durable (own treatments, claims, abort) are also fsync'ed (they
survive the machine).
"""

from __future__ import annotations

import os
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

import msgpack

MAGIC = b"CFJ2"
SYNC = b"\xc5JR"
_LEN = struct.Struct("<I")
_HEAD = struct.Struct("<3sII")  # sync, length, crc
MAX_RECORD = 1 << 20


def _crc(length: int, payload: bytes) -> int:
    return zlib.crc32(payload, zlib.crc32(_LEN.pack(length)))


def encode_record(doc: dict[str, Any]) -> bytes:
    payload = msgpack.packb(doc, use_bin_type=True)
    return _HEAD.pack(SYNC, len(payload), _crc(len(payload), payload)) + payload


@dataclass
class JournalImage:
    """What a journal's bytes hold: the readable records, in order, and where the rest was.
    ``valid`` is the length of the clean prefix (everything up to the last good record when
    nothing but a torn tail follows it)."""

    records: list[dict[str, Any]] = field(default_factory=list)
    damaged: list[tuple[int, int]] = field(default_factory=list)  # (offset, bytes) unreadable
    valid: int = 0
    torn_bytes: int = 0  # an incomplete last record (a write cut short): not damage

    @property
    def damaged_bytes(self) -> int:
        return sum(n for _, n in self.damaged)


def _record_at(data: bytes, pos: int) -> tuple[dict[str, Any], int] | None:
    """The record starting at ``pos`` and where it ends, if it checks out."""
    if pos + _HEAD.size > len(data):
        return None
    sync, length, crc = _HEAD.unpack_from(data, pos)
    end = pos + _HEAD.size + length
    if sync != SYNC or length > MAX_RECORD or end > len(data):
        return None
    payload = data[pos + _HEAD.size:end]
    if _crc(length, payload) != crc:
        return None
    try:
        doc = msgpack.unpackb(payload, raw=False, strict_map_key=False)
    except Exception:  # msgpack raises several unrelated types on garbage
        return None
    return (doc, end) if isinstance(doc, dict) else None


def _torn(data: bytes, pos: int) -> bool:
    """Whether the bytes from ``pos`` are one record whose write was cut short."""
    if len(data) - pos < _HEAD.size:
        return SYNC.startswith(data[pos:pos + len(SYNC)])
    sync, length, _ = _HEAD.unpack_from(data, pos)
    return sync == SYNC and length <= MAX_RECORD and pos + _HEAD.size + length > len(data)


def read_image(data: bytes) -> JournalImage:
    """Every record that can be read from ``data``, resynchronising after damage."""
    image = JournalImage()
    if not data:
        return image
    pos = len(MAGIC) if data.startswith(MAGIC) else 0
    if pos == 0:  # a damaged magic: count it, read on
        first = data.find(SYNC)
        image.damaged.append((0, len(data) if first < 0 else first))
        pos = len(data) if first < 0 else first
    image.valid = pos if not image.damaged else 0
    while pos < len(data):
        found = _record_at(data, pos)
        if found is not None:
            doc, pos = found
            image.records.append(doc)
            image.valid = pos
            continue
        nxt = data.find(SYNC, pos + 1)
        while nxt >= 0 and _record_at(data, nxt) is None:
            nxt = data.find(SYNC, nxt + 1)
        if nxt < 0 and _torn(data, pos):  # nothing readable after it: a write cut short
            image.torn_bytes = len(data) - pos
            break
        end = len(data) if nxt < 0 else nxt
        image.damaged.append((pos, end - pos))
        pos = end
    return image


def decode_records(data: bytes) -> tuple[list[dict[str, Any]], int]:
    """The records of a journal image and the length of its clean prefix."""
    image = read_image(data)
    return image.records, image.valid


class Journal:
    """A journal file: `records` holds what could be read when opened, `damage` what could
    not (None for a clean journal) and `kept_aside` where the damaged file was moved."""

    def __init__(self, path: str | Path, fsync: bool = True) -> None:
        self.path = Path(path)
        self.fsync = fsync
        data = self.path.read_bytes() if self.path.exists() else b""
        image = read_image(data)
        self.records = image.records
        self.torn_bytes = image.torn_bytes
        self.damage: JournalImage | None = image if image.damaged else None
        self.kept_aside: Path | None = None
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if image.damaged:
            # Keep the evidence, then start a clean file holding what could be read, so later
            # appends never sit behind damage.
            self.kept_aside = self._aside()
            os.replace(self.path, self.kept_aside)
            tmp = self.path.with_name(self.path.name + ".rewrite")
            with open(tmp, "wb") as fh:
                fh.write(MAGIC + b"".join(encode_record(r) for r in image.records))
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, self.path)
            image.valid = self.path.stat().st_size
        self._fh: BinaryIO = open(self.path, "r+b" if image.valid else "wb")
        if image.valid:
            self._fh.truncate(image.valid)
            self._fh.seek(image.valid)
        else:
            self._fh.write(MAGIC)
            self._flush(True)

    def _aside(self) -> Path:
        n = 1
        while (candidate := self.path.with_name(f"{self.path.name}.damaged-{n}")).exists():
            n += 1
        return candidate

    def describe_damage(self) -> str:
        """One line for the restart's report ("" for a clean journal)."""
        if self.damage is None:
            return f"journal: a torn last record ({self.torn_bytes} B) cut" if \
                self.torn_bytes else ""
        spots = ", ".join(f"{n} B at {off}" for off, n in self.damage.damaged[:5])
        more = f" and {len(self.damage.damaged) - 5} more" if len(self.damage.damaged) > 5 else ""
        return (f"journal damaged: {self.damage.damaged_bytes} bytes unreadable ({spots}{more}); "
                f"{len(self.records)} records kept; the damaged file is {self.kept_aside}")

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
        image = read_image(data)
        self.records = image.records
        self.data = bytearray(MAGIC + b"".join(encode_record(r) for r in image.records)
                              if image.damaged else (data[:image.valid] if image.valid
                                                     else MAGIC))

    def append(self, doc: dict[str, Any], durable: bool = False) -> None:
        self.data += encode_record(doc)

    def reopen(self) -> "MemoryJournal":
        """What a restarted process would read back."""
        return MemoryJournal(bytes(self.data))
