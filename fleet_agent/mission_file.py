"""The mission on a file: what an agent on board loads before the dive, with no operator.

On the bus the operator serves the mission record (`fleet_bus.mission.Mission`: scenario,
seed, run id). On board there is no operator under water, so the same record is written to a
file beforehand (by `cotsfleet run` in its run directory, or by `cotsfleet credentials DIR
--scenario S` beside each vehicle's credentials), with the one thing the bus would otherwise
give: when mission time 0 is (``start_unix``, the dive's start on the vehicles' clocks, UTC
seconds), the epoch every vehicle's TDMA slots are counted from::

    {"format": "cotsfleet-mission/1", "run_id": "...", "seed": 0, "start_unix": 1.7e9,
     "scenario": {...the scenario document...}}

The fleet key stays in the agent config (``fleet_key_hex``) or the environment, the signing
keys in the credentials directory: a mission file holds no secret.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from fleet_bus.mission import Mission

FORMAT = "cotsfleet-mission/1"
MAX_BYTES = 64 << 20  # a scenario of thousands of spots is a few MB; more is not a mission


class MissionFileError(ValueError):
    """A mission file that cannot be read or is not one (said in one line)."""


def mission_doc(mission: Mission, start_unix: float | None = None) -> dict[str, Any]:
    doc: dict[str, Any] = {"format": FORMAT, "run_id": mission.run_id, "seed": mission.seed,
                           "start_unix": start_unix, "scenario": mission.scenario}
    return doc


def write_mission_file(path: str | Path, mission: Mission,
                       start_unix: float | None = None) -> Path:
    """Write ``mission`` (and when it starts, if known) to ``path``; returns the path."""
    if start_unix is not None and not math.isfinite(start_unix):
        raise MissionFileError(f"start must be a finite unix time, got {start_unix}")
    path = Path(path)
    path.write_text(json.dumps(mission_doc(mission, start_unix)), encoding="utf-8")
    return path


def read_mission_file(path: str | Path) -> tuple[Mission, float | None]:
    """The mission in ``path`` and its start (None: not set in the file)."""
    path = Path(path)
    try:
        if path.stat().st_size > MAX_BYTES:
            raise MissionFileError(f"{path}: larger than {MAX_BYTES >> 20} MB")
        doc = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise MissionFileError(f"cannot read {path}: {exc.strerror or exc}") from None
    except json.JSONDecodeError as exc:
        raise MissionFileError(f"{path}: not JSON ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise MissionFileError(f"{path}: not a mission file (format {FORMAT!r})")
    try:
        mission = Mission.from_doc(doc)  # the bus record's own check
    except (ValueError, TypeError) as exc:
        raise MissionFileError(f"{path}: {exc}") from None
    start = doc.get("start_unix")
    if start is not None and not (isinstance(start, (int, float)) and math.isfinite(start)):
        raise MissionFileError(f"{path}: start_unix must be a unix time or null")
    return mission, None if start is None else float(start)
