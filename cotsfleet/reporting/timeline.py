"""What the event log says happened when: pure functions over a report and its events.

Events are dicts with ``t_s, id, kind, tasks, peer, detail`` (`fleet_bus.telemetry.Event`).
A ``cleared`` event is stamped when an injection ends, so the injection began ``service_s``
earlier; a ``replan`` event with detail ``home`` marks the arrival at the rendezvous; kills and
restarts come from the report's ``faults``. Spot priorities and injection times come from the
scenario when it is given; without it, injections are assumed to last `DEFAULT_SERVICE_S`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping, Sequence

ACTIVITIES = ("transit", "inspect", "inject", "idle", "down")
DEFAULT_SERVICE_S = 75.0  # the middle of the paper's U(60, 90) s (eq. 2)
DEFAULT_INSPECT_S = 20.0


@dataclass(frozen=True)
class Spots:
    """Priority and injection time per scenario task id (empty without a scenario)."""

    priority: Mapping[int, float] = field(default_factory=dict)
    service_s: Mapping[int, float] = field(default_factory=dict)
    battery_s: Mapping[str, float] = field(default_factory=dict)
    inspect_s: float = DEFAULT_INSPECT_S

    @property
    def known(self) -> bool:
        return bool(self.priority)

    @staticmethod
    def of_scenario(doc: Mapping[str, Any] | None) -> "Spots":
        if not isinstance(doc, Mapping):
            return Spots()
        tasks = [t for t in doc.get("tasks", []) if isinstance(t, Mapping) and "id" in t]
        truth = doc.get("truth") if isinstance(doc.get("truth"), Mapping) else {}
        return Spots(
            priority={t["id"]: float(t.get("priority", 0.0)) for t in tasks},
            service_s={t["id"]: float(t.get("service_s", DEFAULT_SERVICE_S)) for t in tasks},
            battery_s={v["id"]: float(v["battery_s"]) for v in doc.get("vehicles", [])
                       if isinstance(v, Mapping) and "id" in v and "battery_s" in v},
            # Without a truth section the map is exact and nothing is inspected
            # (`reef_sim.truth.exact_reef`); with one, its camera's figure.
            inspect_s=float(truth.get("inspect_s", DEFAULT_INSPECT_S)) if truth else 0.0,
        )


@dataclass(frozen=True)
class Segment:
    start_s: float
    end_s: float
    activity: str  # one of ACTIVITIES

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


def _events_of(events: Iterable[Mapping[str, Any]], vid: str, kind: str) -> list[Mapping]:
    return sorted((e for e in events if e.get("id") == vid and e.get("kind") == kind),
                  key=lambda e: float(e.get("t_s", 0.0)))


def down_intervals(report: Mapping[str, Any], vid: str, end_s: float) -> list[tuple[float, float]]:
    """When ``vid``'s agent was dead: from each kill to the next restart (or the end)."""
    faults = sorted((f for f in report.get("faults", []) if f.get("vid") == vid),
                    key=lambda f: float(f.get("t_s", 0.0)))
    out, since = [], None
    for f in faults:
        t = float(f.get("t_s", 0.0))
        if f.get("kind") == "kill" and since is None:
            since = t
        elif f.get("kind") == "restart" and since is not None and t > since:
            out.append((since, min(t, end_s)))
            since = None
    if since is not None and since < end_s:
        out.append((since, end_s))
    return out


def home_time(report: Mapping[str, Any], events: Sequence[Mapping[str, Any]],
              vehicle: Mapping[str, Any]) -> float | None:
    """When the vehicle reached its rendezvous: its ``home`` event, else (for a vehicle the
    report says is home) its battery use, which stops at recovery."""
    homes = [e for e in _events_of(events, vehicle.get("id"), "replan")
             if e.get("detail") == "home"]
    if homes:
        return float(homes[-1]["t_s"])
    if vehicle.get("home") and vehicle.get("battery_used_s") is not None:
        return float(vehicle["battery_used_s"])
    return None


def vehicle_segments(report: Mapping[str, Any], events: Sequence[Mapping[str, Any]],
                     spots: Spots) -> dict[str, list[Segment]]:
    """Per vehicle, ``[0, end_s]`` cut into transit, inspect, inject, idle and down."""
    end_s = float(report.get("end_s", 0.0) or 0.0)
    out: dict[str, list[Segment]] = {}
    for vehicle in report.get("vehicles", []):
        vid = vehicle.get("id")
        busy: list[Segment] = [Segment(a, b, "down") for a, b in down_intervals(report, vid,
                                                                                 end_s)]
        for e in _events_of(events, vid, "cleared"):
            t = float(e["t_s"])
            for task in e.get("tasks", []) or []:
                service = spots.service_s.get(task, DEFAULT_SERVICE_S)
                busy.append(Segment(max(0.0, t - service), t, "inject"))
        for e in (x for x in events if x.get("id") == vid
                  and (str(x.get("kind", "")).startswith("inspect") or x.get("kind") == "empty")):
            t = float(e["t_s"])
            busy.append(Segment(max(0.0, t - spots.inspect_s), t, "inspect"))
        home = home_time(report, events, vehicle)
        if home is not None and home < end_s:
            busy.append(Segment(home, end_s, "idle"))
        out[vid] = _fill(busy, end_s)
    return out


def _fill(busy: list[Segment], end_s: float) -> list[Segment]:
    """The segments in time order, overlaps cut (down > inject > inspect > idle), gaps filled
    with transit."""
    rank = {"down": 0, "inject": 1, "inspect": 2, "idle": 3}
    cuts = sorted({0.0, end_s, *(s.start_s for s in busy), *(s.end_s for s in busy)})
    cuts = [c for c in cuts if 0.0 <= c <= end_s]
    out: list[Segment] = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        if b <= a:
            continue
        mid = (a + b) / 2.0
        covering = [s.activity for s in busy if s.start_s <= mid < s.end_s]
        activity = min(covering, key=rank.__getitem__) if covering else "transit"
        if out and out[-1].activity == activity and out[-1].end_s == a:
            out[-1] = Segment(out[-1].start_s, b, activity)
        else:
            out.append(Segment(a, b, activity))
    return out


def time_shares(segments: Sequence[Segment]) -> dict[str, float]:
    """Seconds per activity."""
    shares = dict.fromkeys(ACTIVITIES, 0.0)
    for s in segments:
        shares[s.activity] += s.duration_s
    return shares


@dataclass(frozen=True)
class Collected:
    """The fleet's cumulative collection: at ``t_s[i]`` it had cleared ``spots[i]`` distinct
    spots worth ``priority[i]`` (None without a scenario), and ``by_vehicle`` the same per
    vehicle (first clear of a spot counts, so the sum over vehicles is the fleet's)."""

    t_s: list[float]
    spots: list[int]
    priority: list[float] | None
    by_vehicle: dict[str, tuple[list[float], list[float]]]


def collected_over_time(events: Sequence[Mapping[str, Any]], spots: Spots) -> Collected:
    cleared = sorted((e for e in events if e.get("kind") == "cleared"),
                     key=lambda e: float(e.get("t_s", 0.0)))
    seen: set[int] = set()
    t_s, count, priority = [0.0], [0], [0.0]
    by_vehicle: dict[str, tuple[list[float], list[float]]] = {}
    for e in cleared:
        for task in e.get("tasks", []) or []:
            if task in seen:
                continue  # a duplicate treatment collects nothing
            seen.add(task)
            value = spots.priority.get(task, 0.0)
            t = float(e["t_s"])
            t_s.append(t)
            count.append(count[-1] + 1)
            priority.append(priority[-1] + value)
            times, values = by_vehicle.setdefault(e.get("id", "?"), ([0.0], [0.0]))
            times.append(t)
            values.append(values[-1] + (value if spots.known else 1.0))
    return Collected(t_s, count, priority if spots.known else None, by_vehicle)
