"""The fleet picture: telemetry folded into what the operator sees (pure, no I/O, no clock).

`FleetPicture.apply(vid, record)` takes one validated record (`ground_station.inputs`) and
returns the drawings it changes (`ground_station.drawing`), stamped with the record's own
simulation time so a recording is the same whatever the wall clock did. Statuses carry
cumulative state (route, treated, claims), so a ground station that joins late or restarts
rebuilds the whole picture from the next status of every vehicle.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from fleet_bus.ledger import FleetLedger
from fleet_bus.link import BROADCAST, LinkRecord
from fleet_bus.telemetry import Event, Status, Truth
from ground_station import palette
from ground_station.drawing import (
    Drawing, LinkClear, LinkLine, LogLine, Mark, Pose, Route, Scalar, Spots, Trail,
)
from ground_station.inputs import Record
from ground_station.mapview import MapLayers

STOPPED = ("aborted", "dead")  # states in which a vehicle's route is abandoned
FINISHED = ("home",)
LOGGED_STATES = (*STOPPED, *FINISHED, "returning")  # transit <-> injecting would flood the log
WARN_EVENTS = {"abort": "WARN", "lost": "WARN", "claim_lost": "WARN", "takeover": "INFO"}


@dataclass
class _Vehicle:
    vid: str
    color: palette.Rgb
    rendezvous: tuple[float, float] | None
    xy: tuple[float, float] | None = None
    yaw_deg: float = 0.0
    state: str = ""
    last_heard_s: float = -math.inf
    last_truth_s: float = -math.inf
    status: Status | None = None
    trail: list[tuple[float, float]] = field(default_factory=list)
    lost_by: set[str] = field(default_factory=set)  # peers that declared it lost
    silent: bool = False
    mark: str = ""


@dataclass(frozen=True)
class Tuning:
    link_ttl_s: float = 20.0  # how long a message line stays on the map
    trail_step_m: float = 10.0  # trail resolution
    silent_after_s: float = 120.0  # no truth/status for this long while others report: dead?
    counter_heartbeat_s: float = 30.0  # an unchanged count is repeated this often, not more


class FleetPicture:
    """Everything the dashboard knows about the mission, and what changed."""

    def __init__(self, layers: MapLayers, tuning: Tuning = Tuning()) -> None:
        self.layers = layers
        self.tuning = tuning
        self.vehicles: dict[str, _Vehicle] = {}
        for vid in layers.vehicle_ids:
            self._vehicle(vid)
        # what the fleet reported treating, folded as the mission report folds it
        self.ledger = FleetLedger()
        self._spot_states: tuple[str, ...] = ()
        self._link_expiry: dict[tuple[str, str], float] = {}
        self.link_counts: Counter[str] = Counter()
        self._counted: dict[str, tuple[float, float]] = {}  # series -> (t, value) last drawn
        self.now_s = 0.0

    # -- public -------------------------------------------------------------------------------

    def initial(self) -> list[Drawing]:
        """The picture before any telemetry: every spot pending, at t = 0."""
        return [self._spots(force=True)]

    def apply(self, vid: str, record: Record) -> list[Drawing]:
        t = float(record.t_s)
        self.now_s = max(self.now_s, t)
        if isinstance(record, Truth):
            out = self._on_truth(vid, record)
        elif isinstance(record, Status):
            out = self._on_status(record)
        elif isinstance(record, Event):
            out = self._on_event(record)
        elif isinstance(record, LinkRecord):
            out = self._on_link(record)
        else:
            raise TypeError(f"not a telemetry record: {type(record).__name__}")
        out += self._expire_links(self.now_s)
        out += self._check_silence(self.now_s)
        return [d for d in out if d is not None]

    def fleet_figures(self) -> dict[str, float]:
        """Spots cleared, priority collected (each spot once) and duplicate treatments (the
        mission report's definitions, from the same `FleetLedger`)."""
        index = self.layers.spot_index
        priority = sum(float(self.layers.spot_priority[index[t]]) for t in self.ledger.cleared
                       if t in index)
        return {
            "spots_cleared": float(len(self.ledger.cleared)),
            "priority_collected": priority,
            "duplicates": float(self.ledger.duplicates()),
        }

    # -- records ------------------------------------------------------------------------------

    def _vehicle(self, vid: str) -> _Vehicle:
        if vid not in self.vehicles:
            index = len(self.vehicles)
            self.vehicles[vid] = _Vehicle(vid, palette.vehicle_color(index),
                                          self.layers.rendezvous.get(vid))
        return self.vehicles[vid]

    def _heard(self, v: _Vehicle, t: float) -> list[Drawing]:
        v.last_heard_s = max(v.last_heard_s, t)
        if not v.silent:
            return []
        v.silent = False
        return [LogLine(t, f"{v.vid} heard again", "INFO"), *self._update_mark(v, t)]

    def _on_truth(self, vid: str, truth: Truth) -> list[Drawing]:
        v = self._vehicle(vid)
        out = self._heard(v, truth.t_s)
        if truth.t_s < v.last_truth_s:
            return out  # overtaken by a newer pose already drawn
        v.last_truth_s = truth.t_s
        v.xy = (truth.pos[0], truth.pos[1])
        v.yaw_deg = truth.yaw_deg
        out += self._set_state(v, truth.state, truth.t_s)
        out.append(Pose(truth.t_s, vid, v.xy, v.yaw_deg, v.state, v.color))
        if not v.trail or math.dist(v.trail[-1], v.xy) >= self.tuning.trail_step_m:
            v.trail.append(v.xy)
            if len(v.trail) >= 2:
                out.append(Trail(truth.t_s, vid, np.array(v.trail), v.color))
        return out

    def _on_status(self, s: Status) -> list[Drawing]:
        v = self._vehicle(s.id)
        out = self._heard(v, s.t_s)
        out += [Scalar(s.t_s, f"battery_s/{s.id}", s.battery_s),
                Scalar(s.t_s, f"t_diff_s/{s.id}", s.t_diff_s)]
        self.ledger.add_treated(s.id, s.treated)  # cumulative: safe in any order
        if v.status is not None and s.t_s < v.status.t_s:
            return out + self._treated_scalars(s.id)  # route and state: the newer status rules
        v.status = s
        if v.xy is None:  # no truth yet (late join): the status position will do
            v.xy = (s.pos[0], s.pos[1])
        out += self._set_state(v, s.state, s.t_s)
        out += [self._route(v, s.t_s), self._spots()]
        return out + self._treated_scalars(s.id)

    def _treated_scalars(self, vid: str) -> list[Drawing]:
        """Counts over the whole picture (statuses and events, every vehicle), stamped with the
        picture's clock: samples of different vehicles may arrive out of order, and a row
        stamped earlier must never carry a newer picture than a row stamped later."""
        out = [self._count(f"spots_treated/{vid}",
                           float(len(self.ledger.treated_by.get(vid, ()))))]
        out += [self._count(f"fleet/{k}", val) for k, val in self.fleet_figures().items()]
        return [d for d in out if d is not None]

    def _count(self, path: str, value: float) -> Scalar | None:
        """A cumulative count, drawn when it changes (and as a heartbeat while it does not):
        statuses repeat counts every few seconds, and the viewer need not redraw them all."""
        t = self.now_s
        last = self._counted.get(path)
        if last is not None and last[1] == value and t - last[0] < \
                self.tuning.counter_heartbeat_s:
            return None
        self._counted[path] = (t, value)
        return Scalar(t, path, value)

    def _on_event(self, e: Event) -> list[Drawing]:
        v = self._vehicle(e.id)
        text = f"{e.id} {e.kind}"
        if e.tasks:
            text += " spots " + ",".join(str(t) for t in e.tasks)
        if e.peer:
            text += f" peer {e.peer}"
        if e.detail:
            text += f": {e.detail}"
        out: list[Drawing] = [LogLine(e.t_s, text, WARN_EVENTS.get(e.kind, "INFO"))]
        if e.kind == "cleared":
            self.ledger.add_treated(e.id, e.tasks)
            out.append(self._spots())
            out += self._treated_scalars(e.id)
        elif e.kind == "abort":
            out += self._set_state(v, "aborted", e.t_s)
        elif e.kind in ("lost", "revived") and e.peer:
            peer = self._vehicle(e.peer)
            if e.kind == "lost":
                peer.lost_by.add(e.id)
            else:
                peer.lost_by.discard(e.id)
            out += self._update_mark(peer, e.t_s)
        return out

    def _on_link(self, e: LinkRecord) -> list[Drawing]:
        self.link_counts["delivered" if e.delivered else "dropped"] += 1
        if e.delivered:
            self.link_counts["bytes"] += e.nbytes
        else:
            self.link_counts[f"drop:{e.reason}"] += 1
        counts = [("fleet/messages/delivered", self.link_counts["delivered"]),
                  ("fleet/messages/dropped", self.link_counts["dropped"]),
                  ("fleet/bytes/delivered", self.link_counts["bytes"])]
        if not e.delivered:
            counts.append((f"fleet/drops/{e.reason}", self.link_counts[f"drop:{e.reason}"]))
        out: list[Drawing] = [d for d in (self._count(p, float(n)) for p, n in counts)
                              if d is not None]
        src = self.vehicles.get(e.src)
        dst = self.vehicles.get(e.dst) if e.dst != BROADCAST else None
        if src is not None and dst is not None and src.xy is not None and dst.xy is not None:
            out.append(LinkLine(e.t_s, e.src, e.dst, src.xy, dst.xy, e.delivered,
                                e.reason or "", e.nbytes))
            self._link_expiry[(e.src, e.dst)] = e.t_s + self.tuning.link_ttl_s
        return out

    # -- derived ------------------------------------------------------------------------------

    def _set_state(self, v: _Vehicle, state: str, t: float) -> list[Drawing]:
        if state == v.state or (v.state in STOPPED and state not in STOPPED):
            return []  # an aborted vehicle stays aborted whatever a late sample says
        first = not v.state
        v.state = state
        out: list[Drawing] = []
        if state in LOGGED_STATES and (not first or state in STOPPED):
            level = "WARN" if state in STOPPED else "INFO"
            out.append(LogLine(t, f"{v.vid} is {state}", level))
        if state in STOPPED or state in FINISHED:
            out.append(self._route(v, t))
            out.append(self._spots())
        return out + self._update_mark(v, t)

    def _update_mark(self, v: _Vehicle, t: float) -> list[Drawing]:
        if v.state == "dead" or v.silent:
            kind = "dead" if v.state == "dead" else "silent"
        elif v.state == "aborted":
            kind = "aborted"
        elif v.lost_by:
            kind = "lost"
        else:
            kind = ""
        if kind == v.mark or v.xy is None:
            return []
        v.mark = kind
        return [Mark(t, v.vid, kind, v.xy)]

    def _check_silence(self, t: float) -> list[Drawing]:
        out: list[Drawing] = []
        for v in self.vehicles.values():
            waiting = v.state not in STOPPED and v.state not in FINISHED and not v.silent
            if waiting and v.last_heard_s > -math.inf and t - v.last_heard_s > \
                    self.tuning.silent_after_s:
                v.silent = True
                out.append(LogLine(t, f"{v.vid} silent since t={v.last_heard_s:.0f} s", "ERROR"))
                out += self._update_mark(v, t)
                out += [self._route(v, t), self._spots()]
        return out

    def _active(self, v: _Vehicle) -> bool:
        return v.state not in STOPPED and not v.silent

    def _route(self, v: _Vehicle, t: float) -> Route:
        if v.status is None or v.xy is None or not self._active(v) or v.state in FINISHED:
            return Route(t, v.vid, np.zeros((0, 2)), v.color)
        pts = [np.array([v.xy]), self.layers.spot_xy_of(v.status.route)]
        if v.rendezvous is not None:
            pts.append(np.array([v.rendezvous]))
        return Route(t, v.vid, np.concatenate(pts), v.color)

    def _spots(self, force: bool = False) -> Spots | None:
        """Every spot's state, stamped with the picture's clock (see `_treated_scalars`)."""
        planned: dict[int, str] = {}
        claimed: dict[int, str] = {}
        orphaned: set[int] = set()
        for v in self.vehicles.values():
            if v.status is None:
                continue
            if self._active(v):
                for tid in v.status.route:
                    planned.setdefault(tid, v.vid)
                for tid in v.status.claims:
                    claimed.setdefault(tid, v.vid)
            else:
                orphaned.update(v.status.route)
        states = []
        for tid in self.layers.spot_ids.tolist():
            if tid in self.ledger.cleared:
                states.append("cleared")
            elif tid in claimed:
                states.append(f"claimed:{claimed[tid]}")
            elif tid in planned:
                states.append(f"planned:{planned[tid]}")
            elif tid in orphaned:
                states.append("abandoned")
            else:
                states.append("pending")
        new = tuple(states)
        if new == self._spot_states and not force:
            return None
        self._spot_states = new
        colors = np.array([self._spot_color(s) for s in new], np.uint8).reshape(-1, 3)
        return Spots(self.now_s, new, colors)

    def _spot_color(self, state: str) -> palette.Rgb:
        kind, _, vid = state.partition(":")
        if kind == "planned":
            return self.vehicles[vid].color
        return {"cleared": palette.SPOT_CLEARED, "claimed": palette.SPOT_CLAIMED,
                "abandoned": palette.SPOT_ABANDONED}.get(kind, palette.SPOT_PENDING)

    def _expire_links(self, t: float) -> list[Drawing]:
        due = sorted((exp, pair) for pair, exp in self._link_expiry.items() if exp <= t)
        for _, pair in due:
            del self._link_expiry[pair]
        return [LinkClear(exp, src, dst) for exp, (src, dst) in due]
