"""What the event log says happened when: pure functions over a report and its events.

Events are `fleet_bus.telemetry.Event` records (``events.jsonl`` holds one per line). A
``cleared`` event is stamped when an injection ends and its detail says how long it lasted
(`fleet_bus.telemetry.cleared_detail`: after a look, what the camera measured; a log from
before it said so is read with the scenario's ``service_s``). A ``claim_lost`` or
``judged_treated`` event whose detail says the vehicle stopped injecting, for a spot a peer
held by an earlier claim or was heard to have treated, says for how long; a ``replan`` event
with detail ``home`` marks the arrival at the rendezvous; kills and restarts come from the
report's ``faults``. Spot priorities come from the scenario when it is given; without it,
injections with no time in their detail are assumed to last `DEFAULT_SERVICE_S`. What the
fleet collected over time is `fleet_bus.ledger.cumulative`: the figures of the report, step by
step.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

from cotsfleet.mission.report_model import FaultRow, MissionReport, VehicleRow
from fleet_bus.ledger import FleetLedger, SpotValues, cumulative
from fleet_bus.states import EventKind, FaultKind
from fleet_bus.telemetry import Event, detail_injected_s, detail_stopped_s

ACTIVITIES = ("transit", "inspect", "inject", "idle", "down")
DEFAULT_SERVICE_S = 75.0  # the middle of the paper's U(60, 90) s (eq. 2)
DEFAULT_INSPECT_S = 20.0


@dataclass(frozen=True)
class Spots:
    """Per scenario task id its injection time, each vehicle's battery, the inspection time
    and what each treatment is worth (`values`; None without a scenario)."""

    service_s: Mapping[int, float] = field(default_factory=dict)
    battery_s: Mapping[str, float] = field(default_factory=dict)
    inspect_s: float = DEFAULT_INSPECT_S
    values: SpotValues | None = None

    @property
    def known(self) -> bool:
        return self.values is not None

    @staticmethod
    def of_scenario(doc: Mapping[str, Any] | None) -> "Spots":
        """The figures of a scenario document (raises `ScenarioError` for a bad one)."""
        if not isinstance(doc, Mapping):
            return Spots()
        from cotsfleet.mission.report import values_of
        from hfc_core.formats.scenario import problem_from_dict
        from reef_sim.truth import reef_from_doc

        problem = problem_from_dict(doc)
        reef = reef_from_doc(doc, problem)
        return Spots(
            service_s={t.id: float(t.service_s) for t in problem.tasks},
            battery_s={v.id: float(v.battery_s) for v in problem.vehicles},
            # Without a truth section the map is exact and nothing is inspected
            # (`reef_sim.truth.exact_reef`); with one, its camera's figure.
            inspect_s=float(reef.inspect_s) if reef is not None else 0.0,
            values=values_of(problem, reef),
        )


@dataclass(frozen=True)
class Segment:
    start_s: float
    end_s: float
    activity: str  # one of ACTIVITIES

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


def _events_of(events: Sequence[Event], vid: str, *kinds: str) -> list[Event]:
    return sorted((e for e in events if e.id == vid and e.kind in kinds), key=lambda e: e.t_s)


def down_intervals(faults: Sequence[FaultRow], vid: str, end_s: float
                   ) -> list[tuple[float, float]]:
    """When ``vid``'s agent was dead: from each kill to the next restart (or the end)."""
    out, since = [], None
    for f in sorted((f for f in faults if f.vid == vid), key=lambda f: f.t_s):
        if f.kind == FaultKind.KILL and since is None:
            since = f.t_s
        elif f.kind == FaultKind.RESTART and since is not None and f.t_s > since:
            out.append((since, min(f.t_s, end_s)))
            since = None
    if since is not None and since < end_s:
        out.append((since, end_s))
    return out


def home_time(events: Sequence[Event], vehicle: VehicleRow) -> float | None:
    """When the vehicle reached its rendezvous: its ``home`` event, else (for a vehicle the
    report says is home) its battery use, which stops at recovery."""
    homes = [e for e in _events_of(events, vehicle.id, EventKind.REPLAN) if e.detail == "home"]
    if homes:
        return homes[-1].t_s
    if vehicle.home:
        return vehicle.battery_used_s
    return None


def vehicle_segments(report: MissionReport, events: Sequence[Event],
                     spots: Spots) -> dict[str, list[Segment]]:
    """Per vehicle, ``[0, end_s]`` cut into transit, inspect, inject, idle and down."""
    end_s = report.end_s
    out: dict[str, list[Segment]] = {}
    for vehicle in report.vehicles:
        vid = vehicle.id
        busy: list[Segment] = [Segment(a, b, "down")
                               for a, b in down_intervals(report.faults, vid, end_s)]
        for e in _events_of(events, vid, EventKind.CLEARED):
            told = detail_injected_s(e.detail)
            for task in e.tasks:
                service = told if told is not None else \
                    spots.service_s.get(task, DEFAULT_SERVICE_S)
                busy.append(Segment(max(0.0, e.t_s - service), e.t_s, "inject"))
        for e in _events_of(events, vid, EventKind.CLAIM_LOST, EventKind.JUDGED_TREATED):
            # an injection left to an earlier claim, or to a peer's clear of the spot
            stopped_s = detail_stopped_s(e.detail)
            if stopped_s is not None:
                busy.append(Segment(max(0.0, e.t_s - stopped_s), e.t_s, "inject"))
        for e in (x for x in events if x.id == vid
                  and (x.kind.startswith("inspect") or x.kind == EventKind.EMPTY)):
            busy.append(Segment(max(0.0, e.t_s - spots.inspect_s), e.t_s, "inspect"))
        home = home_time(events, vehicle)
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
    """The fleet's cumulative collection, step by step: at ``t_s[i]`` it had collected
    ``values[i]`` (priority with a scenario, else distinct spots treated), and ``by_vehicle``
    the same per vehicle. The last values are the report's (`FleetLedger.collected`)."""

    t_s: list[float]
    values: list[float]
    by_vehicle: dict[str, tuple[list[float], list[float]]]
    priority: bool  # values are priorities (else spot counts)
    on_reef: bool  # on the real reef (else the map's)


def collected_over_time(events: Sequence[Event], spots: Spots) -> Collected:
    """The treatments of the event log, folded as the report folds them."""
    ledger = FleetLedger()
    for e in events:
        ledger.add_event(e)
    if spots.values is not None:
        t_s, total, per = cumulative(ledger.treatments_of(spots.values), spots.values)
        return Collected(t_s, total, per, True, spots.values.reef is not None)
    counting = SpotValues(dict.fromkeys(ledger.cleared, 1.0))  # no scenario: spots count
    t_s, total, per = cumulative(ledger.treatments_of(counting), counting)
    return Collected(t_s, total, per, False, False)
