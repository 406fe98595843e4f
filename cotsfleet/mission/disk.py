"""A full disk costs a mission what it must, never its report.

`DiskReserve` sets space aside in the run dir when a mission starts (a file of zeros: a
"ballast file", as the operators of databases keep one) and gives it back when the mission
ends, just before the event log and the report are written: whatever filled the disk
meanwhile (the agents' journals, the logs), those last writes have room. `cut_to_whole_lines`
keeps a log that a write failed in the middle of readable: its last, cut line is dropped.
"""

from __future__ import annotations

import os
from pathlib import Path

CHUNK = 1 << 20


class DiskReserve:
    """``take`` sets ``size_bytes`` aside at ``path``; ``give_back`` frees it (idempotent)."""

    NAME = ".disk-reserve"

    def __init__(self, path: Path, size_bytes: int) -> None:
        self.path, self.size_bytes = Path(path), max(0, int(size_bytes))
        self.held = 0
        self.error = ""

    def take(self) -> bool:
        """Write the reserve (real blocks, not a sparse file); False if the disk could not
        give all of it (what it could give is kept)."""
        if not self.size_bytes:
            return True
        zeros = bytes(CHUNK)
        try:
            with open(self.path, "wb") as fh:
                while self.held < self.size_bytes:
                    n = min(CHUNK, self.size_bytes - self.held)
                    fh.write(zeros[:n])
                    fh.flush()
                    os.fsync(fh.fileno())
                    self.held += n
        except OSError as exc:
            self.error = str(exc)
            try:
                self.held = self.path.stat().st_size
            except OSError:
                self.held = 0
            return False
        return True

    def give_back(self) -> int:
        """Free the reserve; the bytes given back."""
        freed, self.held = self.held, 0
        try:
            self.path.unlink()
        except FileNotFoundError:
            pass
        except OSError as exc:
            self.error = str(exc)
        return freed


def cut_to_whole_lines(path: Path) -> None:
    """Drop a cut last line of ``path`` (a write that failed half-way); best effort, since
    shrinking a file needs no new block."""
    try:
        with open(path, "rb+") as fh:
            data = fh.read()
            end = data.rfind(b"\n") + 1
            if end < len(data):
                fh.truncate(end)
    except OSError:
        pass
