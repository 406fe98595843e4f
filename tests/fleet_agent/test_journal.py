"""The journal survives torn writes and damage: a damaged record costs that record only, a
damaged magic is not a new vehicle, the damaged file is kept aside and the loss reported."""

from __future__ import annotations

from pathlib import Path

import pytest

from fleet_agent.journal import MAGIC, Journal, MemoryJournal, decode_records, encode_record, \
    read_image

RECORDS = [{"k": "clr", "ids": [i], "pad": "x" * (i % 7)} for i in range(20)]


def image(records=RECORDS) -> bytes:
    return MAGIC + b"".join(encode_record(r) for r in records)


def offsets(records=RECORDS) -> list[int]:
    out, pos = [], len(MAGIC)
    for r in records:
        out.append(pos)
        pos += len(encode_record(r))
    return out


def test_records_round_trip_and_append_after_reopen(tmp_path: Path) -> None:
    path = tmp_path / "auv1.journal"
    with Journal(path) as j:
        assert j.records == []
        j.append({"k": "clr", "ids": [1, 2]}, durable=True)
        j.append({"k": "ckpt", "pos": [1.5, 2.0, -3.0]})
    with Journal(path) as j:
        assert j.records == [{"k": "clr", "ids": [1, 2]}, {"k": "ckpt", "pos": [1.5, 2.0, -3.0]}]
        assert j.damage is None and j.kept_aside is None
        j.append({"k": "abort", "t": 5.0})
    assert len(Journal(path).records) == 3


def test_a_torn_tail_is_cut_and_the_prefix_kept(tmp_path: Path) -> None:
    path = tmp_path / "j"
    with Journal(path) as j:
        for i in range(5):
            j.append({"k": "clr", "ids": [i]})
    data = path.read_bytes()
    for cut in range(len(MAGIC), len(data)):
        path.write_bytes(data[:cut])
        j = Journal(path)
        n = len(j.records)
        assert [r["ids"] for r in j.records] == [[i] for i in range(n)]
        assert j.kept_aside is None  # a write cut short is not damage
        j.append({"k": "clr", "ids": [99]})  # appends after the clean prefix
        j.close()
        assert Journal(path).records[-1] == {"k": "clr", "ids": [99]}


@pytest.mark.parametrize("where", ["head", "middle", "tail"])
def test_one_flipped_byte_costs_one_record(tmp_path: Path, where: str) -> None:
    data = bytearray(image())
    starts = offsets()
    victim = {"head": 0, "middle": 10, "tail": len(RECORDS) - 1}[where]
    # a byte of the victim's payload, or of its length field (the resync case)
    for at in (starts[victim] + 12, starts[victim] + 4):
        bad = bytearray(data)
        bad[at] ^= 0x5A
        path = tmp_path / f"{where}-{at}.journal"
        path.write_bytes(bytes(bad))
        j = Journal(path)
        expected = [r for i, r in enumerate(RECORDS) if i != victim]
        assert j.records == expected
        # at the tail a length made larger than the file looks like a write cut short
        assert j.damage is not None or (where == "tail" and j.torn_bytes)
        if j.damage is not None:
            assert j.kept_aside is not None and j.kept_aside.read_bytes() == bytes(bad)
            assert "bytes unreadable" in j.describe_damage()
        j.append({"k": "after"})
        j.close()
        again = Journal(path)  # the rewritten journal is clean: damage reported once
        assert again.records == [*expected, {"k": "after"}] and again.damage is None


def test_a_damaged_magic_is_not_a_new_vehicle(tmp_path: Path) -> None:
    path = tmp_path / "auv2.journal"
    bad = bytearray(image())
    bad[0:4] = b"\x00\x00\x00\x00"
    path.write_bytes(bytes(bad))
    j = Journal(path)
    assert j.records == RECORDS  # every record behind the damaged header is still there
    assert j.damage is not None and j.damage.damaged == [(0, 4)]
    assert j.kept_aside == tmp_path / "auv2.journal.damaged-1"
    j.close()
    assert Journal(path).records == RECORDS


def test_garbage_in_the_middle_is_skipped() -> None:
    starts = offsets()
    data = image()
    cut = starts[7]
    bad = data[:cut] + b"\xc5JR" + bytes(range(200)) + data[cut:]  # a false sync mark too
    img = read_image(bad)
    assert img.records == RECORDS and img.damaged_bytes == 203
    assert decode_records(b"garbage")[0] == []


def test_memory_journal_reopens_like_a_file() -> None:
    j = MemoryJournal()
    j.append({"k": "x"})
    assert j.reopen().records == [{"k": "x"}]
    damaged = bytearray(j.data)
    damaged[-1] ^= 1
    assert MemoryJournal(bytes(damaged)).records == []
