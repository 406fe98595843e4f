"""The disk reserve the launcher keeps for its report, and a log cut by a failed write."""

from __future__ import annotations

from pathlib import Path

from cotsfleet.mission.disk import DiskReserve, cut_to_whole_lines


def test_the_reserve_holds_real_blocks_and_gives_them_back(tmp_path: Path) -> None:
    reserve = DiskReserve(tmp_path / DiskReserve.NAME, 3 << 20)
    assert reserve.take() and reserve.held == 3 << 20
    assert (tmp_path / DiskReserve.NAME).stat().st_blocks * 512 >= 3 << 20  # not sparse
    assert reserve.give_back() == 3 << 20 and not (tmp_path / DiskReserve.NAME).exists()
    assert reserve.give_back() == 0  # twice is harmless


def test_a_disk_that_cannot_hold_the_reserve_says_so(tmp_path: Path) -> None:
    reserve = DiskReserve(tmp_path / "nowhere" / DiskReserve.NAME, 1 << 20)
    assert not reserve.take() and reserve.error and reserve.held == 0
    full = DiskReserve(Path("/dev/full"), 1 << 20)  # every write: ENOSPC
    assert not full.take() and "No space left" in full.error


def test_a_cut_last_line_is_dropped(tmp_path: Path) -> None:
    log = tmp_path / "events.jsonl"
    log.write_text('{"a": 1}\n{"b": 2}\n{"c": ')
    cut_to_whole_lines(log)
    assert log.read_text() == '{"a": 1}\n{"b": 2}\n'
    cut_to_whole_lines(tmp_path / "missing")  # nothing there: nothing to do
