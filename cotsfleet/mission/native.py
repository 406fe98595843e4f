"""``python -m cotsfleet.mission.native PROGRAM ARGS...``: a program that does not watch its
parent (a MOOS-IvP app) started as a child that dies with the launcher.

The launcher's Python children end themselves when it dies (`fleet_bus.process`); a native
program does not. This asks the kernel to send it SIGTERM when the launcher dies
(``PR_SET_PDEATHSIG``, kept across ``execve``), checks the launcher is still its parent (it
may have died before the request: then it never starts), and becomes the program (same pid,
same process group: the launcher's SIGTERM and SIGKILL reach it as they reach any child).
Linux only, like ``PR_SET_PDEATHSIG`` (elsewhere the program runs without it, said once).
"""

from __future__ import annotations

import ctypes
import os
import shutil
import signal
import sys

_PR_SET_PDEATHSIG = 1


def main(argv: list[str]) -> int:
    if not argv:
        print("usage: python -m cotsfleet.mission.native PROGRAM [ARGS...]", file=sys.stderr)
        return 2
    program = shutil.which(argv[0])
    if program is None:
        print(f"native: {argv[0]} is not on PATH", file=sys.stderr)
        return 127
    parent = os.environ.get("COTSFLEET_PARENT_PID", "")
    try:
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):
        print(f"native: {argv[0]} will not die with its parent on this platform",
              file=sys.stderr)
    if parent.isdigit() and os.getppid() != int(parent):
        return 1  # the launcher is already gone
    sys.stdout.flush()
    os.execv(program, [argv[0], *argv[1:]])  # argv[0] as given: a MOOS app reads its name
    return 127  # not reached


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
