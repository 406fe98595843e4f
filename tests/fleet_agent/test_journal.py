"""The journal survives torn writes and keeps every complete record."""

from __future__ import annotations

from pathlib import Path

from fleet_agent.journal import MAGIC, Journal, MemoryJournal, decode_records, encode_record


def test_records_round_trip_and_append_after_reopen(tmp_path: Path) -> None:
    path = tmp_path / "auv1.journal"
    with Journal(path) as j:
        assert j.records == []
        j.append({"k": "clr", "ids": [1, 2]}, durable=True)
        j.append({"k": "ckpt", "pos": [1.5, 2.0, -3.0]})
    with Journal(path) as j:
        assert j.records == [{"k": "clr", "ids": [1, 2]}, {"k": "ckpt", "pos": [1.5, 2.0, -3.0]}]
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
        j.append({"k": "clr", "ids": [99]})  # appends after the clean prefix
        j.close()
        assert Journal(path).records[-1] == {"k": "clr", "ids": [99]}


def test_a_corrupt_record_stops_reading_there() -> None:
    good = MAGIC + encode_record({"a": 1}) + encode_record({"b": 2})
    bad = bytearray(good)
    bad[-1] ^= 0xFF
    assert decode_records(bytes(bad))[0] == [{"a": 1}]
    assert decode_records(b"garbage")[0] == []


def test_memory_journal_reopens_like_a_file() -> None:
    j = MemoryJournal()
    j.append({"k": "x"})
    assert j.reopen().records == [{"k": "x"}]
