"""The fleet picture: telemetry folded into what the operator sees (pure, no I/O, no clock).

`FleetPicture.apply(vid, record)` takes one validated record (`ground_station.inputs`) and
returns the drawings it changes (`ground_station.drawing`), stamped with simulation time so
a recording is the same whatever the wall clock did. Statuses carry cumulative state (route,
treated, claims), so a ground station that joins late or restarts rebuilds the whole picture
from the next status of every vehicle.

What changes often is drawn for the whole fleet at once and only when it changed: poses in one
layer, routes in one, the live links in one snapshot at most every `Tuning.link_window_s`,
series thinned by `ground_station.series`. A browser on a busy machine then keeps up with a
mission at warp 60, and an hour's recording stays small.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from fleet_bus.event_text import find_priority, level, sentence
from fleet_bus.ledger import FIND_MATCH_M, FleetLedger, RealReef, SpotValues
from fleet_bus.link import BROADCAST, LinkRecord
from fleet_bus.states import STOPPED_STATES, EventKind, VehicleState
from fleet_bus.telemetry import Event, Status, Truth, detail_position
from ground_station import palette
from ground_station.drawing import (
    Current,
    Drawing,
    Finds,
    LinkLine,
    Links,
    LogLine,
    Mark,
    Routes,
    Scalar,
    SeriesRow,
    Spots,
    Stations,
    Trails,
    Vehicles,
)
from ground_station.inputs import Record
from ground_station.labels import box_of, stack
from ground_station.mapview import MapLayers
from ground_station.series import Policy, SeriesThinner
from hfc_core.model.current import TIDE_STEP_S

STOPPED = STOPPED_STATES  # states in which a vehicle's route is abandoned
FINISHED = (VehicleState.HOME,)
# State changes written to the log: transit <-> injecting would flood it, and an arrival is
# the vehicle's own event ("auv1 reached its rendezvous")
LOGGED_STATES = (*STOPPED, VehicleState.RETURNING)

# How each series is thinned (`ground_station.series`): the battery falls steadily (drawn once a
# minute), T_diff jumps at replans (drawn at once, with the corner), counts step when they
# change, and the link counters, which move with every frame, at most every 15 s. A plot
# 300 pixels wide for an hour's mission shows 12 s per pixel: nothing is lost to the eye, and
# the browser, whose cost is in the points its plots redraw, keeps up.
HEARTBEAT_S = 60.0
LINEAR = Policy(tolerance=120.0, heartbeat_s=HEARTBEAT_S, corners=True)
COUNTER = Policy(heartbeat_s=HEARTBEAT_S, min_interval_s=15.0)
SERIES_POLICIES: dict[str, Policy] = {
    "battery_s": LINEAR,
    "t_diff_s": Policy(tolerance=5.0, heartbeat_s=HEARTBEAT_S, corners=True),
    # how far behind the mission clock each agent's process runs: the operator slows the
    # shared clock past half a slot (the effective warp is in the report); spikes matter
    "lag_s": Policy(tolerance=0.5, heartbeat_s=HEARTBEAT_S, corners=True),
    "fleet/messages": COUNTER,
    "fleet/bytes": COUNTER,
    "fleet/drops": COUNTER,
}
COUNT = Policy(heartbeat_s=HEARTBEAT_S)  # everything else: counts, drawn when they change


def series_policy(path: str) -> Policy:
    for prefix, policy in SERIES_POLICIES.items():
        if path.startswith(prefix + "/"):
            return policy
    return COUNT


PER_VEHICLE_PLOTS = ("battery_s", "t_diff_s", "spots_treated", "lag_s")
FLEET_PLOTS = {"spots_cleared": "fleet/spots", "duplicates": "fleet/spots",
               "priority_collected": "fleet/priority", "messages": "fleet/messages",
               "drops": "fleet/messages", "bytes": "fleet/bytes", "reef_share": "fleet/reef"}


def series_line(path: str) -> tuple[str, str]:
    """A series path -> (the plot entity it is a line of, the line's name)::

        battery_s/auv1            -> battery_s, auv1
        fleet/messages/delivered  -> fleet/messages, delivered
        fleet/drops/sinr          -> fleet/messages, drops/sinr
        ground_station/dropped/x  -> ground_station/dropped, x
    """
    head, _, rest = path.partition("/")
    if head in PER_VEHICLE_PLOTS:
        return head, rest
    if head == "fleet":
        kind, _, detail = rest.partition("/")
        entity = FLEET_PLOTS.get(kind, f"fleet/{kind}")
        return entity, (rest if kind == "drops" else detail or kind)
    entity, _, name = path.rpartition("/")
    return entity or path, name


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
    trail: list[tuple[float, float]] = field(default_factory=list)  # the recent stretch
    earlier: list[np.ndarray] = field(default_factory=list)  # finished stretches
    route_key: tuple = ()  # what the drawn route was made from
    route: np.ndarray | None = None
    lost_by: set[str] = field(default_factory=set)  # peers that declared it lost
    silent: bool = False
    mark: str = ""


@dataclass(frozen=True)
class Tuning:
    link_ttl_s: float = 20.0  # how long a frame's line stays on the map
    link_window_s: float = 5.0  # the live links are redrawn at most this often
    trail_step_m: float = 10.0  # trail resolution
    trail_stretch: int = 32  # trail points per stretch: only the last stretch is redrawn
    silent_after_s: float = 120.0  # no truth/status for this long while others report: dead?
    # A label's footprint as a share of the map's larger side (width, height): vehicles whose
    # labels would overlap share one label, and those at a station are named in its label.
    label_box: tuple[float, float] = (0.10, 0.035)


class FleetPicture:
    """Everything the dashboard knows about the mission, and what changed."""

    def __init__(self, layers: MapLayers, tuning: Tuning = Tuning()) -> None:
        self.layers = layers
        self.tuning = tuning
        self.vehicles: dict[str, _Vehicle] = {}
        for vid in layers.vehicle_ids:
            self._vehicle(vid)
        # what the fleet reported treating, folded and valued as the mission report does it
        self.ledger = FleetLedger()
        self.values = spot_values(layers)
        self._spot_states: tuple[str, ...] = ()
        self.link_counts: Counter[str] = Counter()
        self._links: dict[tuple[str, str], LinkLine] = {}
        self._links_changed = False
        self._links_next_s = -math.inf
        self.series = SeriesThinner(series_policy)
        # plot entity -> its lines' paths, fixed from the start: Rerun draws only the lines
        # every row of a plot has, so a line that appears later (a drop reason, a vehicle not in
        # the scenario) gets an entity of its own instead
        self._plots: dict[str, tuple[str, ...]] = {
            **{metric: tuple(f"{metric}/{vid}" for vid in layers.vehicle_ids)
               for metric in PER_VEHICLE_PLOTS},
            "fleet/spots": ("fleet/spots_cleared", "fleet/duplicates"),
            "fleet/priority": ("fleet/priority_collected",),
            "fleet/messages": ("fleet/messages/delivered", "fleet/messages/dropped"),
            "fleet/bytes": ("fleet/bytes/delivered",),
            # dynamic missions: the share of the real reef's priority treated so far
            **({"fleet/reef": ("fleet/reef_share",)} if layers.dynamic else {}),
        }
        self.empty_ids: set[int] = set()  # predicted spots found empty
        self.finds: list[tuple[float, float, float]] = []  # (x, y, priority) as reported
        self._plot_t: dict[str, float] = {}  # plot entity -> time of its last row
        self._station_labels: tuple[str, ...] = ()
        self._station_names: list[list[_Vehicle]] = [[] for _ in layers.stations]
        self._current_next_s = math.inf
        self._current_uv: np.ndarray | None = None
        self._recent_trails = False  # whether the recent trail layer shows anything
        self._dirty: set[str] = set()  # whole-fleet layers to redraw: vehicles, routes
        self.now_s = 0.0

    # -- public -------------------------------------------------------------------------------

    def initial(self) -> list[Drawing]:
        """The picture before any telemetry: every spot pending, the stations, the current
        at t = 0."""
        out = self._spots(force=True)
        out += self._stations(force=True)
        out += self._current(0.0, force=True)
        return out

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
        out += self._check_silence(self.now_s)
        out += self._fleet_layers()
        out += self._links_layer(self.now_s)
        out += self._current(self.now_s)
        out += self._rows(self.series.due(self.now_s))
        return [d for d in out if d is not None]

    def flush(self) -> list[Drawing]:
        """At the end: the newest value of every series and the last links, so the recording
        ends on what the mission ended on."""
        return [*self._rows(self.series.flush()), *self._links_layer(self.now_s, force=True)]

    def offer(self, path: str, t_s: float, value: float) -> list[Drawing]:
        """A series sample: the plot rows it is worth (`ground_station.series`)."""
        return self._rows(self.series.offer(path, t_s, value))

    def _plot_of(self, path: str) -> str:
        entity, _ = series_line(path)
        if path not in self._plots.get(entity, ()):
            entity = path  # not one of the plot's lines from the start: a plot of its own
            self._plots.setdefault(entity, (path,))
        return entity

    def _rows(self, scalars: list[Scalar]) -> list[Drawing]:
        """Drawn samples -> rows of their plots, every line at its newest value. A plot's rows
        never go back in time (samples of different vehicles arrive out of order): a row is
        stamped no earlier than the plot's last."""
        rows: dict[tuple[str, float], dict[str, float]] = {}
        for s in scalars:
            entity = self._plot_of(s.path)
            t = max(s.t_s, self._plot_t.get(entity, -math.inf))
            self._plot_t[entity] = t
            rows.setdefault((entity, t), {})[s.path] = s.value
        out: list[Drawing] = []
        for (entity, t), drawn in rows.items():
            paths = self._plots[entity]
            values = tuple(drawn[p] if p in drawn else _or_nan(self.series.last(p))
                           for p in paths)
            out.append(SeriesRow(t, entity, tuple(series_line(p)[1] for p in paths), paths,
                                 values, tuple(drawn)))
        return out

    def fleet_figures(self) -> dict[str, float]:
        """Spots treated, priority collected (each spot once) and duplicate treatments: the
        mission report's figures (`FleetLedger.collected`), on the real reef in a dynamic
        mission (with its share of the reef's priority), on the map's spots otherwise."""
        c = self.ledger.collected(self.values)
        out = {"spots_cleared": float(c.spots), "priority_collected": c.priority,
               "duplicates": float(c.duplicates)}
        if self.layers.dynamic:
            out["reef_share"] = c.priority / c.priority_of if c.priority_of > 0 else 0.0
        return out

    # -- records ------------------------------------------------------------------------------

    def _vehicle(self, vid: str) -> _Vehicle:
        if vid not in self.vehicles:
            index = len(self.vehicles)
            self.vehicles[vid] = _Vehicle(vid, palette.vehicle_color(index),
                                          self.layers.rendezvous.get(vid))
        return self.vehicles[vid]

    def _heard(self, v: _Vehicle, t: float) -> list[Drawing]:
        v.last_heard_s = max(v.last_heard_s, t)
        if not v.silent or self.now_s - v.last_heard_s > self.tuning.silent_after_s:
            return []  # a sample that is itself older than the verdict does not lift it
        v.silent = False
        self._update_route(v)
        return [LogLine(t, f"{v.vid} heard again", "INFO"), *self._update_mark(v, t)]

    def _on_truth(self, vid: str, truth: Truth) -> list[Drawing]:
        v = self._vehicle(vid)
        out = self._heard(v, truth.t_s)
        if truth.t_s < v.last_truth_s:
            return out  # overtaken by a newer pose already drawn
        v.last_truth_s = truth.t_s
        v.xy = (truth.pos[0], truth.pos[1])
        v.yaw_deg = truth.yaw_deg
        self._dirty.add("vehicles")
        out += self._set_state(v, truth.state, truth.t_s)
        return out + self._extend_trail(v)

    def _extend_trail(self, v: _Vehicle) -> list[Drawing]:
        assert v.xy is not None
        if v.trail and math.dist(v.trail[-1], v.xy) < self.tuning.trail_step_m:
            return []
        v.trail.append(v.xy)
        out: list[Drawing] = []
        if len(v.trail) >= self.tuning.trail_stretch:
            v.earlier.append(np.array(v.trail))
            v.trail = [v.xy]  # the next stretch starts where this one ends
            out.append(self._trails("earlier", [(u.color, s) for u in self.vehicles.values()
                                                for s in u.earlier]))
        recent = [(u.color, np.array(u.trail)) for u in self.vehicles.values()
                  if len(u.trail) >= 2]
        if recent or self._recent_trails:  # an empty layer is drawn once, as a clear
            out.append(self._trails("recent", recent))
        self._recent_trails = bool(recent)
        return out

    def _trails(self, part: str, strips: list[tuple[palette.Rgb, np.ndarray]]) -> Trails:
        return Trails(self.now_s, part, tuple(s for _, s in strips), tuple(c for c, _ in strips))

    def _on_status(self, s: Status) -> list[Drawing]:
        v = self._vehicle(s.id)
        out = self._heard(v, s.t_s)
        out += self.offer(f"battery_s/{s.id}", s.t_s, s.battery_s)
        out += self.offer(f"t_diff_s/{s.id}", s.t_s, s.t_diff_s)
        out += self.offer(f"lag_s/{s.id}", s.t_s, s.lag_s)
        self.ledger.add_treated(s.id, s.treated, s.t_s)  # cumulative: safe in any order
        if v.status is not None and s.t_s < v.status.t_s:
            return out + self._treated_scalars(s.id)  # route and state: the newer status rules
        v.status = s
        if v.xy is None:  # no truth yet (late join): the status position will do
            v.xy = (s.pos[0], s.pos[1])
            self._dirty.add("vehicles")
        out += self._set_state(v, s.state, s.t_s)
        self._update_route(v)
        out += self._spots()
        return out + self._treated_scalars(s.id)

    def _treated_scalars(self, vid: str) -> list[Drawing]:
        """Counts over the whole picture (statuses and events, every vehicle), stamped with the
        picture's clock: samples of different vehicles may arrive out of order, and a row
        stamped earlier must never carry a newer picture than a row stamped later."""
        scalars = self.series.offer(f"spots_treated/{vid}", self.now_s,
                                    float(len(self.ledger.treated_by.get(vid, ()))))
        for k, val in self.fleet_figures().items():
            scalars += self.series.offer(f"fleet/{k}", self.now_s, val)
        return self._rows(scalars)

    def _on_event(self, e: Event) -> list[Drawing]:
        v = self._vehicle(e.id)
        out: list[Drawing] = [LogLine(e.t_s, sentence(e), level(e))]
        self.ledger.add_event(e)  # treatments, find positions, empty spots
        if e.kind == EventKind.CLEARED:
            out += self._spots()
            out += self._treated_scalars(e.id)
        elif e.kind == EventKind.EMPTY:
            self.empty_ids.update(e.tasks)
            out += self._spots()
        elif e.kind == EventKind.FOUND:
            out += self._found(e)
        elif e.kind == EventKind.ABORT:
            out += self._set_state(v, VehicleState.ABORTED, e.t_s, log=False)  # the event said it
        elif e.kind in (EventKind.LOST, EventKind.REVIVED) and e.peer:
            peer = self._vehicle(e.peer)
            if e.kind == EventKind.LOST:
                peer.lost_by.add(e.id)
            else:
                peer.lost_by.discard(e.id)
            out += self._update_mark(peer, e.t_s)
        return out

    def _found(self, e: Event) -> list[Drawing]:
        """A reported find joins the layer (the same aggregation reported twice: once)."""
        xy = _fix(e.detail)
        if xy is None or any(math.dist(xy, f[:2]) <= FIND_MATCH_M for f in self.finds):
            return []
        rho = find_priority(e.detail)
        self.finds.append((xy[0], xy[1], 0.0 if rho is None else rho))
        arr = np.array(self.finds, float).reshape(-1, 3)
        return [Finds(self.now_s, arr[:, :2], arr[:, 2],
                      tuple(f"find (priority {p:.0f})" for p in arr[:, 2].tolist()))]

    def _on_link(self, e: LinkRecord) -> list[Drawing]:
        self.link_counts["delivered" if e.delivered else "dropped"] += 1
        if e.delivered:
            self.link_counts["bytes"] += e.nbytes
        else:
            self.link_counts[f"drop:{e.reason}"] += 1
        t = self.now_s
        scalars: list[Scalar] = []
        for path, key in (("fleet/messages/delivered", "delivered"),
                          ("fleet/messages/dropped", "dropped"),
                          ("fleet/bytes/delivered", "bytes")):
            scalars += self.series.offer(path, t, float(self.link_counts[key]))
        for key in sorted(k for k in self.link_counts if k.startswith("drop:")):
            scalars += self.series.offer(f"fleet/drops/{key[5:]}", t,
                                         float(self.link_counts[key]))
        out: list[Drawing] = self._rows(scalars)
        src = self.vehicles.get(e.src)
        dst = self.vehicles.get(e.dst) if e.dst != BROADCAST else None
        if src is not None and dst is not None and src.xy is not None and dst.xy is not None:
            self._links[(e.src, e.dst)] = LinkLine(
                e.t_s, e.src, e.dst, src.xy, dst.xy, e.delivered, e.reason or "", e.nbytes,
                e.snr_db, getattr(e, "sinr_db", None))  # sinr_db: when the bus carries it
            self._links_changed = True
        return out

    # -- derived ------------------------------------------------------------------------------

    def _set_state(self, v: _Vehicle, state: str, t: float, log: bool = True) -> list[Drawing]:
        if state == v.state or (v.state in STOPPED and state not in STOPPED):
            return []  # an aborted vehicle stays aborted whatever a late sample says
        first = not v.state
        v.state = state
        self._dirty.add("vehicles")  # the state is in its label
        out: list[Drawing] = []
        if log and state in LOGGED_STATES and (not first or state in STOPPED):
            level = "WARN" if state in STOPPED else "INFO"
            out.append(LogLine(t, f"{v.vid} is {state}", level))
        if state in STOPPED or state in FINISHED:
            self._update_route(v)
            out += self._spots()
        return out + self._update_mark(v, t)

    def _update_mark(self, v: _Vehicle, t: float) -> list[Drawing]:
        # what is known outranks what is guessed: an announced abort explains the silence
        # that follows it, even when the announcement arrives after the station's verdict
        if v.state == VehicleState.DEAD:
            kind = "dead"
        elif v.state == VehicleState.ABORTED:
            kind = "aborted"
        elif v.silent:
            kind = "silent"
        elif v.lost_by:
            kind = "lost"
        else:
            kind = ""
        if kind == v.mark or v.xy is None:
            return []
        v.mark = kind
        self._dirty.add("vehicles")  # a marked vehicle is named by its mark, not a label
        # a verdict on the whole picture: stamped with its clock, so a mark decided later is
        # never drawn under one decided earlier (an abort announced late, after a silence)
        return [Mark(self.now_s, v.vid, kind, v.xy)]

    def _check_silence(self, t: float) -> list[Drawing]:
        out: list[Drawing] = []
        for v in self.vehicles.values():
            waiting = v.state not in STOPPED and v.state not in FINISHED and not v.silent
            if waiting and v.last_heard_s > -math.inf and t - v.last_heard_s > \
                    self.tuning.silent_after_s:
                v.silent = True
                out.append(LogLine(t, f"{v.vid} silent since t={v.last_heard_s:.0f} s", "ERROR"))
                out += self._update_mark(v, t)
                self._update_route(v)
                out += self._spots()
        return out

    def _active(self, v: _Vehicle) -> bool:
        return v.state not in STOPPED and not v.silent

    def _update_route(self, v: _Vehicle) -> None:
        """Redraw the route when what it is made of changed (its spots, or the vehicle
        stopping or finishing), not on every status: from where the vehicle is now, through
        its spots, to its rendezvous."""
        live = v.status is not None and v.xy is not None and self._active(v) \
            and v.state not in FINISHED
        key = (live, tuple(v.status.route) if live and v.status is not None else ())
        if key == v.route_key:
            return
        v.route_key = key
        v.route = None
        if live and v.status is not None and v.xy is not None:
            pts = [np.array([v.xy]), self.layers.spot_xy_of(v.status.route)]
            if v.rendezvous is not None:
                pts.append(np.array([v.rendezvous]))
            v.route = np.concatenate(pts)
        self._dirty.add("routes")

    def _fleet_layers(self) -> list[Drawing]:
        out: list[Drawing] = []
        if "vehicles" in self._dirty:
            out.append(self._vehicles())
            out += self._stations()
        if "routes" in self._dirty:
            drawn = [v for v in self.vehicles.values() if v.route is not None and len(v.route) > 1]
            out.append(Routes(self.now_s, tuple(v.vid for v in drawn),
                              tuple(v.route for v in drawn if v.route is not None),
                              tuple(v.color for v in drawn)))
        self._dirty.clear()
        return out

    def _vehicles(self) -> Vehicles:
        located = [v for v in self.vehicles.values() if v.xy is not None]
        labels, self._station_names = self._labels(located)
        xy = np.array([v.xy for v in located], float).reshape(-1, 2)
        shown = [i for i, text in enumerate(labels) if text]
        label_xy = xy.copy()
        label_xy[shown] = stack(xy[shown], self._label_box())
        return Vehicles(
            self.now_s, tuple(v.vid for v in located), xy,
            np.array([v.yaw_deg for v in located], float), labels,
            np.array([v.color for v in located], np.uint8).reshape(-1, 3), label_xy)

    def _label_box(self) -> tuple[float, float]:
        return box_of(self.layers.bounds, self.tuning.label_box)

    def _labels(self, located: list[_Vehicle]) -> tuple[tuple[str, ...], list[list[_Vehicle]]]:
        """One label per group of vehicles whose labels would overlap, on the group's first
        vehicle; vehicles at a station are named in the station's label instead (several
        vehicles share the start: their labels and the station's would pile up there), and a
        vehicle with a mark by the mark's label (``auv2 ABORTED``)."""
        xmin, xmax, ymin, ymax = self.layers.bounds
        extent = max(xmax - xmin, ymax - ymin)
        w, h = self.tuning.label_box[0] * extent, self.tuning.label_box[1] * extent

        def near(p: tuple[float, float], q: tuple[float, float]) -> bool:
            return abs(p[0] - q[0]) < w and abs(p[1] - q[1]) < h

        at_station: list[list[_Vehicle]] = [[] for _ in self.layers.stations]
        groups: list[tuple[tuple[float, float], list[_Vehicle]]] = []  # first one's place, all
        for v in located:
            assert v.xy is not None
            xy = v.xy
            stations = [i for i, s in enumerate(self.layers.stations) if near(s.xy, xy)]
            if stations:
                at_station[min(stations, key=lambda i: math.dist(self.layers.stations[i].xy,
                                                                 xy))].append(v)
                continue
            if v.mark:
                continue
            for anchor, group in groups:
                if near(anchor, xy):
                    group.append(v)
                    break
            else:
                groups.append((xy, [v]))
        text = {g[0].vid: _names(g) for _, g in groups}
        return tuple(text.get(v.vid, "") for v in located), at_station

    def _stations(self, force: bool = False) -> list[Drawing]:
        labels = tuple(s.label + (f": {_names(vs)}" if vs else "")
                       for s, vs in zip(self.layers.stations, self._station_names))
        if labels == self._station_labels and not force:
            return []
        self._station_labels = labels
        return [Stations(self.now_s, labels)]

    def _spots(self, force: bool = False) -> list[Drawing]:
        """Every spot's state, stamped with the picture's clock (see `_treated_scalars`); none
        if unchanged and not ``force``."""
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
            elif tid in self.empty_ids:
                states.append("empty")
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
            return []
        self._spot_states = new
        colors = np.array([self._spot_color(s) for s in new], np.uint8).reshape(-1, 3)
        return [Spots(self.now_s, new, colors)]

    def _spot_color(self, state: str) -> palette.Rgb:
        kind, _, vid = state.partition(":")
        if kind == "planned":
            return self.vehicles[vid].color
        pending = palette.SPOT_HOLLOW if self.layers.dynamic else palette.SPOT_PENDING
        return {"cleared": palette.SPOT_CLEARED, "claimed": palette.SPOT_CLAIMED,
                "abandoned": palette.SPOT_ABANDONED,
                "empty": palette.SPOT_EMPTY}.get(kind, pending)

    def _links_layer(self, now: float, force: bool = False) -> list[Drawing]:
        """The latest frame of each link within its time to live, redrawn at most every
        `Tuning.link_window_s`: one row for all links instead of a row (and a clear) per
        frame."""
        if now < self._links_next_s and not force:
            return []
        expired = [k for k, line in self._links.items()
                   if line.t_s + self.tuning.link_ttl_s <= now]
        for k in expired:
            del self._links[k]
        if not (self._links_changed or expired):
            return []
        self._links_changed = False
        self._links_next_s = now + self.tuning.link_window_s
        lines = tuple(self._links[k] for k in sorted(self._links))
        middles = np.array([[(a + b) / 2.0 for a, b in zip(line.a, line.b)] for line in lines],
                           float).reshape(-1, 2)
        shown = [i for i, line in enumerate(lines) if line.label()]
        middles[shown] = stack(middles[shown], self._label_box())
        return [Links(now, lines, middles)]

    def _current(self, now: float, force: bool = False) -> list[Drawing]:
        """The water current: once when steady; a tidal one at the picture's time, redrawn
        when the tide has turned by more than 2 % of its peak (checked once per tide step)."""
        layer = self.layers.current
        if layer is None or not (force or now >= self._current_next_s):
            return []
        steady = bool(layer.field.steady)
        self._current_next_s = math.inf if steady else \
            (math.floor(now / TIDE_STEP_S) + 1) * TIDE_STEP_S
        xy, uv = layer.sample(now)
        if not force and self._current_uv is not None and \
                np.abs(uv - self._current_uv).max(initial=0.0) <= 0.02 * layer.peak_mps:
            return []
        self._current_uv = uv
        return [Current(now, xy, uv, layer.scale_s, steady)]


def spot_values(layers: MapLayers) -> SpotValues:
    """What a treatment is worth on this map (`fleet_bus.ledger`): the map's priorities and,
    in a dynamic mission, the real reef, so the dashboard's figures are the report's."""
    predicted = {int(t): float(p) for t, p in zip(layers.spot_ids.tolist(),
                                                  layers.spot_priority.tolist())}
    if not layers.dynamic:
        return SpotValues(predicted)
    return SpotValues(predicted, RealReef(
        priority=tuple(float(p) for p in layers.truth_priority.tolist()),
        positions=tuple(tuple(float(c) for c in p) for p in layers.truth_pos.tolist()),
        of_task=dict(layers.truth_of_spot), unmapped=frozenset(layers.truth_unmapped)))


def _fix(detail: str) -> tuple[float, float] | None:
    """The x, y of a find's event detail (`fleet_bus.telemetry.position_detail`)."""
    xyz = detail_position(detail)
    return None if xyz is None else xyz[:2]


def _or_nan(value: float | None) -> float:
    return math.nan if value is None else value


def _names(vehicles: list[_Vehicle]) -> str:
    """``auv1 auv2 transit, auv3 home``: ids grouped by state, in order."""
    by_state: dict[str, list[str]] = {}
    for v in vehicles:
        by_state.setdefault(v.state, []).append(v.vid)
    return ", ".join(" ".join(ids) + (f" {state}" if state else "")
                     for state, ids in by_state.items())
