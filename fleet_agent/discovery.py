"""What an agent does with what its camera shows, in a dynamic mission (the map is a prior).

One part of the agent (`fleet_agent.agent`), one idea: the reef as the vehicle learns it.
Sightings and the ends of looks come in as vehicle reports (`fleet_bus.vehicle_port`: the
camera's `Sighted` and `Looked`); finds come in as FOUND frames. It keeps the beliefs (`fleet_agent.beliefs`) and the working problem the
vehicle and the planner use in step with them, names new finds and owes them to the fleet,
folds aliases, and turns the end of a look into an empty spot (cleared for everyone) or an
injection. Nothing here runs in a mission without a hidden reef.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fleet_agent.beliefs import UNKNOWN
from fleet_agent.io_types import Outputs
from fleet_agent.motion import Inspected
from fleet_agent.records import Clear, FoundSpot
from fleet_agent.wire import MAX_TENTHS, Found
from fleet_bus.telemetry import position_detail
from fleet_bus.vehicle_port import Looked, Sighted

if TYPE_CHECKING:
    from fleet_agent.agent import Agent


class Discovery:
    """The agent's beliefs about the reef, kept and acted on (see the module docstring)."""

    def __init__(self, agent: "Agent") -> None:
        self.a = agent
        self.version = -1  # the beliefs' version the vehicle and planner work on

    def where(self, task: int) -> str:
        """A find's position for the log ("x,y,z" m): the world's bookkeeping names the
        aggregation treated by where it is; predicted spots need nothing (their task says)."""
        b = self.a.know.beliefs
        if b is None or task < b.n:
            return ""
        return position_detail(tuple(self.a.know.problem.xyz[task]))

    def rebind(self) -> None:
        """Beliefs changed: the vehicle and the planner work on the new working problem."""
        b = self.a.know.beliefs
        if b is None or b.version == self.version:
            return
        self.version = b.version
        self.a.problem = b.problem
        self.a.own.rebind(b.problem)

    def settled(self, now: float) -> None:
        """A find that finished settling may now be planned: look for work."""
        b = self.a.know.beliefs
        due = None if b is None else b.next_settle_s(self.a.t)
        if due is not None and due <= now and self.a.config.discovery:
            self.a.decide.coop_soon = True
            self.a.decide.dirty = True

    def on_looked(self, r: Looked, out: Outputs) -> None:
        """A look ended: learn what is there, then inject it or move on (`OwnVehicle`)."""
        b, own = self.a.know.beliefs, self.a.own
        if b is None or not self.a.decide.active or own.inspecting != r.task:
            self.a.count("inspection_stale")  # the look was abandoned meanwhile
            return
        if r.present:
            b.learn(r.task, True, r.priority, r.service_s)
        ev = own.looked(r.task, r.service_s if r.present else None, r.t_s)
        if ev is not None:
            self.a.decide.dirty = True
            self.on_inspected(ev, out)

    def on_sighted(self, seen: Sighted, now: float, out: Outputs) -> None:
        b = self.a.know.beliefs
        if b is None or not self.a.decide.active:
            self.a.count("sensed_ignored")
            return
        if not self.a.config.discovery:
            self.a.count("sightings_ignored")
            return
        what = b.match(seen.pos)
        if what is None:
            self._discover(seen, now, out)
        elif what[0] == "task" and b.state[what[1]] == UNKNOWN \
                and what[1] not in self.a.know.cleared:
            b.learn(what[1], True, seen.priority, seen.service_s)
            self.a.decide.dirty = True

    def _discover(self, seen: Sighted, now: float, out: Outputs) -> None:
        """An aggregation the map missed: name it, tell the fleet, plan it once settled."""
        b, codec = self.a.know.beliefs, self.a.fleet.codec
        assert b is not None
        slot = b.own_slot()
        if slot is None:
            self.a.count("finds_dropped")
            return
        # What the fleet will know: the wire's figures, so every vehicle plans the same find.
        pos = codec.dequantise(*codec.quantise(seen.pos))
        rho = min(round(seen.priority * 10), MAX_TENTHS) / 10
        service = min(round(seen.service_s * 10), MAX_TENTHS) / 10
        if not b.add_find(slot, pos, rho, service, now):
            self.a.count("finds_refused")  # on land once on the wire's grid: nobody could go
            return
        self.a.count("finds")
        self.a.decide.dirty = True
        out.record(FoundSpot(now, slot, pos, rho, service, durable=True))
        self.a.radio.queue_find(slot)
        out.event(now, "found", [slot], detail=f"{self.where(slot)} rho {rho:g}")

    def on_found(self, msg: Found, now: float, out: Outputs) -> None:
        b = self.a.know.beliefs
        if b is None:
            self.a.count("drop_found_static")
            return
        conflicts, refused = b.conflicts, b.refused
        if b.add_find(msg.slot, msg.pos, msg.priority, msg.service_s, now):
            self.a.decide.dirty = True
            out.record(FoundSpot(now, msg.slot, msg.pos, msg.priority, msg.service_s))
        elif b.conflicts != conflicts:
            self.a.count("drop_found_conflict")
        elif b.refused != refused:
            self.a.count("drop_found_on_land")
        if msg.digest != b.digest():
            self.a.radio.owe_finds(self.a.know, msg.digest)
        self.fold_aliases(now, out)

    def fold_aliases(self, now: float, out: Outputs) -> None:
        """An aggregation treated under an alias is treated: its find is cleared too."""
        b, cleared = self.a.know.beliefs, self.a.know.cleared
        if b is None:
            return
        new = [h for s, h in b.alias.items() if s in cleared and h not in cleared]
        for h in set(new):
            cleared.add(h)
            out.record(Clear(now, (h,), own=False))
            self.a.decide.dirty = True

    def on_inspected(self, ev: Inspected, out: Outputs) -> None:
        b, know = self.a.know.beliefs, self.a.know
        if b is None:
            return
        if not ev.present:
            b.learn(ev.task, False)
            if know.cleared.add(ev.task):  # empty: done for everyone (grow-only, gossiped)
                self.a.radio.push_cleared = 2
                out.record(Clear(ev.t_s, (ev.task,), own=False))
            out.event(ev.t_s, "empty", [ev.task])
            if self.a.config.discovery:
                self.a.decide.coop_soon = True  # the time it freed goes to other work
            return
        out.event(ev.t_s, "inspected", [ev.task],
                  detail="present" if ev.treating else "present, beyond the battery")
        if not ev.treating:
            self.a.decide.hold([ev.task], False, ev.t_s, out)
