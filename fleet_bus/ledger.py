"""Telemetry folded once: what the operator knows about the fleet from statuses and events.

The mission runner (either backend), the mission report and the ground station all read the
fleet through one `FleetLedger`: the newest status of each vehicle, the event log, and every
spot each vehicle reported treating (its statuses and its ``cleared`` events: a vehicle
killed between two statuses still announced its last treatment).
"""

from __future__ import annotations

from fleet_bus.telemetry import FINAL_STATES, Event, Status

MAX_EVENTS = 1_000_000  # a mission's whole log; beyond, the oldest are dropped and counted


class FleetLedger:
    def __init__(self) -> None:
        self.statuses: dict[str, Status] = {}
        self.events: list[Event] = []
        self.treated_by: dict[str, set[int]] = {}
        self.cleared: set[int] = set()  # spots some vehicle treated (each once)
        self.treatments = 0
        self.events_dropped = 0

    def add_status(self, s: Status) -> bool:
        """Fold ``s`` in (treatments are cumulative: safe in any order); True if it is the
        vehicle's newest status."""
        self.add_treated(s.id, s.treated)
        old = self.statuses.get(s.id)
        if old is not None and s.t_s < old.t_s:
            return False
        self.statuses[s.id] = s
        return True

    def add_event(self, e: Event) -> None:
        if len(self.events) >= MAX_EVENTS:
            self.events.pop(0)
            self.events_dropped += 1
        self.events.append(e)
        if e.kind == "cleared":
            self.add_treated(e.id, e.tasks)

    def add_treated(self, vid: str, tasks: list[int]) -> None:
        mine = self.treated_by.setdefault(vid, set())
        for t in tasks:
            if t not in mine:
                mine.add(t)
                self.cleared.add(t)
                self.treatments += 1

    def state_of(self, vid: str) -> str | None:
        s = self.statuses.get(vid)
        return None if s is None else s.state

    def all_final(self, vehicles: list[str], dead: set[str]) -> bool:
        """Every vehicle home, aborted or dead."""
        return all(v in dead or self.state_of(v) in FINAL_STATES for v in vehicles)

    def duplicates(self) -> int:
        """Treatments beyond the first of each spot."""
        return self.treatments - len(self.cleared)
