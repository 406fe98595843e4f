"""``RUN_DIR/run.json``: where a running mission's launcher can be reached, for `cotsfleet ctl`.

The launcher writes it once the mission clock runs and removes it when the mission closes:
its run id, the local endpoint of its router, its process id (a record left by a launcher
that was killed is recognised as stale) and the run's credentials (the operator's
directory is ``credentials/operator``). Nothing secret: the record points at the
credentials, which stay readable by their owner only.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

RUN_RECORD = "run.json"


class NoMission(ValueError):
    """No mission is running in a run dir (the message says why, in one line)."""


@dataclass(frozen=True)
class RunRecord:
    run_id: str
    endpoint: str  # the router, as this host reaches it
    pid: int  # the launcher's
    credentials: str  # the run's credentials root
    vehicles: tuple[str, ...]

    @property
    def operator_dir(self) -> Path:
        return Path(self.credentials) / "operator"


def write_run_record(run_dir: Path, record: RunRecord) -> None:
    """Written whole or not at all (a reader never sees half a record)."""
    tmp = run_dir / f".{RUN_RECORD}.tmp"
    tmp.write_text(json.dumps({"run_id": record.run_id, "endpoint": record.endpoint,
                               "pid": record.pid, "credentials": record.credentials,
                               "vehicles": list(record.vehicles)}), encoding="utf-8")
    os.replace(tmp, run_dir / RUN_RECORD)


def remove_run_record(run_dir: Path) -> None:
    try:
        (run_dir / RUN_RECORD).unlink()
    except FileNotFoundError:
        pass


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process: alive
        return True
    return True


def read_run_record(run_dir: Path) -> RunRecord:
    """The record of the mission running in ``run_dir``; `NoMission` if there is none."""
    path = Path(run_dir) / RUN_RECORD
    if not Path(run_dir).is_dir():
        raise NoMission(f"{run_dir}: no such run dir")
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
        record = RunRecord(str(doc["run_id"]), str(doc["endpoint"]), int(doc["pid"]),
                           str(doc["credentials"]), tuple(str(v) for v in doc["vehicles"]))
    except FileNotFoundError:
        raise NoMission(f"no mission is running in {run_dir} (no {RUN_RECORD}: not started "
                        "yet, or over)") from None
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise NoMission(f"{path}: not a run record ({exc})") from None
    if record.pid <= 0 or not _alive(record.pid):
        raise NoMission(f"the mission of {run_dir} is over (its launcher, pid {record.pid}, "
                        "is gone)")
    return record
