"""The ground station proper: one mission, one recording, samples in, drawings out.

Free of Zenoh so tests drive it in-process with real payload bytes and a real recording.
"""

from __future__ import annotations

import sys
import traceback
from collections import Counter

import numpy as np
import rerun as rr

from fleet_bus.link import BROADCAST, INTRUDER, LinkRecord
from fleet_bus.mission import Mission
from ground_station import inputs, rerun_log
from ground_station.mapview import MapLayers, map_layers
from ground_station.state import FleetPicture, Tuning
from hfc_core.model.errors import ScenarioError

APPLICATION_ID = "cotsfleet"


def empty_layers() -> MapLayers:
    return MapLayers((), np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros(0), ())


def mission_layers(mission: Mission) -> tuple[MapLayers, str]:
    """The mission's map, or an empty one (and why) if its scenario cannot be drawn."""
    try:
        return map_layers(mission.scenario), ""
    except (ScenarioError, ValueError, TypeError) as exc:
        return empty_layers(), f"scenario cannot be drawn: {exc}"


def mission_markdown(mission: Mission, layers: MapLayers) -> str:
    """A short card: what the legend view beside it does not say (colours are there)."""
    name = mission.scenario.get("name", "?") if isinstance(mission.scenario, dict) else "?"
    current = layers.current.field.kind if layers.current is not None else "still water"
    return (
        f"**{name}**\n\n"
        f"{len(layers.vehicle_ids)} vehicles, {len(layers.spot_ids)} spots\n\n"
        f"current: {current}\n\n"
        f"seed {mission.seed}\n\n"
        f"run {mission.run_id}\n"
    )


class GroundStation:
    """Folds samples of one mission into one recording; never raises on bad input."""

    def __init__(self, mission: Mission, rec: rr.RecordingStream,
                 layers: tuple[MapLayers, str] | None = None, tuning: Tuning = Tuning()) -> None:
        self.mission = mission
        self.rec = rec
        shown, problem = layers if layers is not None else mission_layers(mission)
        self.picture = FleetPicture(shown, tuning)
        self.dashboard = rerun_log.RerunDashboard(
            rec, color_of=lambda vid: self.picture.vehicles[vid].color
            if vid in self.picture.vehicles else None,
            arrow_m=rerun_log.arrow_length_m(shown))
        self.roster = frozenset(mission.roster())
        self.dropped: Counter[str] = Counter()  # kind of input -> samples dropped
        self.handled = 0
        rerun_log.log_map(rec, shown, live=True)
        rerun_log.log_legend(rec, shown)
        rerun_log.log_text(rec, mission_markdown(mission, shown))
        self.dashboard.draw(self.picture.initial())
        if problem:
            self.rec.log("events", rr.TextLog(problem, level="ERROR"))

    def handle(self, key: str, payload: bytes) -> bool:
        """Fold and log one sample; False (and counted) if it was dropped."""
        try:
            vid, record = inputs.decode(key, payload)
        except ValueError:
            return self._drop(key, "malformed")
        if not self._known(vid, record):
            return self._drop(key, "unknown_vehicle")
        try:
            self.dashboard.draw(self.picture.apply(vid, record))
        except Exception:  # a bug must cost one sample, not the operator's dashboard
            if self.dropped["error"] < 3:
                traceback.print_exc(file=sys.stderr)
            return self._drop(key, "error")
        self.handled += 1
        return True

    def close(self) -> None:
        """The mission is over (or the station stops): draw what was held back, so the
        recording ends on the newest values."""
        self.dashboard.draw(self.picture.flush())

    def _known(self, vid: str, record: inputs.Record) -> bool:
        """Ids of the mission's roster only (and the link's intruder or broadcast ends):
        the picture keeps state per vehicle, so unknown ids must not grow it."""
        if not self.roster:
            return True
        if isinstance(record, LinkRecord):
            ends = {INTRUDER, BROADCAST} | self.roster
            return record.src in ends and record.dst in ends
        return vid in self.roster

    def refused(self, reason: str, n: int) -> None:
        """``n`` samples refused before decoding (not signed by their rightful sender)."""
        why = f"auth_{reason}"
        self.dropped[why] += n
        self.dashboard.draw(self.picture.offer(f"ground_station/dropped/{why}",
                                               self.picture.now_s, float(self.dropped[why])))

    def _drop(self, key: str, why: str) -> bool:
        kind = key.split("/")[1] if key.count("/") >= 2 else "unknown"
        self.dropped[why] += 1
        self.dropped[f"{why}:{kind}"] += 1
        self.dashboard.draw(self.picture.offer(f"ground_station/dropped/{why}",
                                               self.picture.now_s, float(self.dropped[why])))
        return False
