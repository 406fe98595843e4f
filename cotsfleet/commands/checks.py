"""What every command checks in what a user gives it, before any work starts (a mission of
a minute must not fail at its end because of a typo): where it may write, and that a
scenario has something to plan.

Output paths: a file is written into a directory that exists (never a directory created on the
user's behalf: a typo in ``--rrd /nonexsitent/m.rrd`` is a typo, not a request); a directory
option (``--out``, ``--run-dir``, ``-o DIR``) may name a new directory, whose parent exists.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from cotsfleet.errors import UsageError

if TYPE_CHECKING:
    from hfc_core.model.problem import Problem


def output_file(path: str | Path | None, flag: str) -> Path | None:
    """``path`` if a file can be written there, else `UsageError` saying why in one line."""
    if path is None:
        return None
    target = Path(path)
    if target.is_dir():
        raise UsageError(f"{flag} {path}: is a directory, not a file")
    parent = target.parent
    if not parent.is_dir():
        what = "not a directory" if parent.exists() else "no such directory"
        raise UsageError(f"{flag} {path}: {what} {str(parent)!r}")
    return target


def output_dir(path: str | Path | None, flag: str) -> Path | None:
    """``path`` if it is a directory, or a new one can be made there (its parent exists),
    else `UsageError`."""
    if path is None:
        return None
    target = Path(path)
    if target.exists() and not target.is_dir():
        raise UsageError(f"{flag} {path}: not a directory")
    if not target.exists() and not target.parent.is_dir():
        raise UsageError(f"{flag} {path}: no such directory {str(target.parent)!r}")
    return target


def json_output(path: str | Path | None, flag: str) -> Path | None:
    """`output_file` for a report's JSON, whose Markdown and figures are named after it:
    it must end in ``.json``."""
    target = output_file(path, flag)
    if target is not None and target.suffix != ".json":
        raise UsageError(f"{flag} {path}: a report's file name ends in .json (its Markdown "
                         "and figures are named after it)")
    return target


def require_spots(problem: "Problem", source: str | Path) -> None:
    """A scenario without a COTS spot has nothing to plan, simulate or compare: one line, not
    a planner's traceback."""
    if problem.n_tasks == 0:
        raise UsageError(f"{source}: the scenario has no COTS spot, so there is nothing to "
                         "plan (give it tasks, e.g. cotsfleet scenario --tasks 90)")
