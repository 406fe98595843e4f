"""The mission report: one format for `cotsfleet sim` and `cotsfleet run`.

Built from what an operator gets after recovery: the fleet's telemetry (`FleetLedger`: each
vehicle's last `Status`, the `Event` log, what each reported treating), the relay's link
counters, and the faults that were applied (with the times they were). The process backend
adds ``security``: what the operator, the relay and each agent refused, by reason
(`fleet_bus.auth`). What the fleet collected is `FleetLedger.collected`'s one definition:
on the real reef in a dynamic mission (`values_of`), on the map's spots otherwise.

`build_report` returns the typed tree of `cotsfleet.mission.report_model`; its ``to_dict``
is ``report.json``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import msgspec

from comms_sim.stats import LinkCounts, totals, totals_by_sender
from cotsfleet.mission.faults import Fault
from cotsfleet.mission.report_model import (
    DynamicSection,
    FaultRow,
    FleetSection,
    Messages,
    MissionReport,
    ReportError,
    Security,
    TreatedRow,
    VehicleRow,
)
from fleet_bus.ledger import FleetLedger, RealReef, SpotValues
from fleet_bus.states import EventKind, FaultKind, VehicleState
from hfc_core.model.problem import Problem
from reef_sim.truth import Reef

# What each of a backend's sections must be: the report's own field types.
EXTRA_SECTIONS = {f.name: f.type for f in msgspec.structs.fields(MissionReport)
                  if f.name != "other"}


def values_of(problem: Problem, reef: Reef | None) -> SpotValues:
    """What a treatment is worth in this mission: the map's priorities, and the real reef
    when there is one (the simulated world's bookkeeping)."""
    predicted = {t.id: float(t.priority) for t in problem.tasks}
    if reef is None:
        return SpotValues(predicted)
    of_task = {}
    for i, t in enumerate(problem.tasks):
        s = reef.of_task(i)
        if s is not None:
            of_task[t.id] = s
    return SpotValues(predicted, RealReef(
        priority=tuple(float(s.priority) for s in reef.spots),
        positions=tuple(tuple(float(c) for c in s.pos) for s in reef.spots),
        of_task=of_task, unmapped=frozenset(reef.unmapped())))


def dynamic_section(ledger: FleetLedger, values: SpotValues) -> DynamicSection:
    """What the fleet did on the real reef: every treatment of a real spot (in time order),
    the real spots its finds are, the predicted spots found empty, and the reef's figures."""
    reef = values.reef
    assert reef is not None
    treated = [TreatedRow(spot=t.spot, vehicle=t.vid, t_s=round(t.t_s, 1))
               for t in ledger.treatments_of(values) if t.spot is not None]
    c = ledger.collected(values)
    spots = {t.spot for t in treated}
    found = ledger.found_spots(values)
    return DynamicSection(
        treated=treated, spots_discovered=len(found), empty_inspected=len(ledger.empty),
        truth_priority=round(reef.total, 2), truth_spots=len(reef.priority),
        unmapped=len(reef.unmapped), unmapped_treated=len(spots & reef.unmapped),
        priority_treated=round(c.priority, 2), duplicate_treatments=c.duplicates,
        unmapped_found=len(found & reef.unmapped))


def _extra(extra: Mapping[str, Any]) -> dict[str, Any]:
    """A backend's additions as the report's typed sections (unknown ones kept as they are:
    `MissionReport.other`)."""
    known = set(MissionReport.__struct_fields__) - {"other"}
    out: dict[str, Any] = {"other": {k: v for k, v in extra.items() if k not in known}}
    for k, v in extra.items():
        if k not in known:
            continue
        try:
            out[k] = msgspec.convert(v, EXTRA_SECTIONS[k])
        except msgspec.ValidationError as exc:  # our own backends' contract
            raise ReportError(f"the backend's {k!r} section: {exc}") from None
    return out


def build_report(problem: Problem, ledger: FleetLedger, link: LinkCounts | None,
                 faults: Sequence[Fault], *, mode: str, seed: int, end_s: float,
                 extra: Mapping[str, Any] | None = None,
                 reef: Reef | None = None) -> MissionReport:
    """The report; with ``reef`` (a dynamic mission) priorities and duplicates are the real
    reef's, not the map's (`FleetLedger.collected`). ``link`` None: the relay's counters
    never came (the report says unknown, not zero)."""
    values = values_of(problem, reef)
    collected = ledger.collected(values)
    statuses, events = ledger.statuses, ledger.events
    killed = {f.vid: f.t_s for f in faults if f.kind == FaultKind.KILL}
    aborted = {f.vid: f.t_s for f in faults if f.kind == FaultKind.ABORT}
    restarted = {f.vid for f in faults if f.kind == FaultKind.RESTART}
    stalled = {f.vid for f in faults if f.kind == FaultKind.STALL}
    helms = ((extra or {}).get("helm") or {}).get("vehicles", {})
    vehicles = []
    for v in problem.vehicles:
        s = statuses.get(v.id)
        vehicles.append(VehicleRow(
            id=v.id,
            state="dead" if v.id in killed and v.id not in restarted else
                  (s.state if s else "unknown"),
            tasks_treated=len(ledger.treated_by.get(v.id, ())),
            priority=round(collected.by_vehicle.get(v.id, (0, 0.0))[1], 2),
            distance_m=round(s.distance_m, 1) if s else 0.0,
            battery_used_s=round(v.battery_s - s.battery_s, 1) if s else 0.0,
            t_diff_s=round(s.battery_s, 1) if s and s.state == VehicleState.HOME else None,
            home=bool(s and s.state == VehicleState.HOME),
            aborted=v.id in aborted, killed=v.id in killed, restarted=v.id in restarted,
            stalled=v.id in stalled,
            helm=helms.get(v.id, "sim"),  # what drove it (`cotsfleet run --helm`)
            nav_fixes=int(s.counters.get("nav_fixes", 0)) if s else 0,
            counters=dict(s.counters) if s else {}))

    detection: dict[str, dict[str, float | None]] = {}
    for gone, t0 in sorted({**aborted, **killed}.items()):
        row: dict[str, float | None] = {}
        for v in problem.vehicles:
            out_before = [t for t in (killed.get(v.id), aborted.get(v.id)) if t is not None]
            if v.id == gone or any(t <= t0 for t in out_before):
                continue  # only vehicles still in the mission can detect anything
            seen = [e.t_s for e in events
                    if e.id == v.id and e.kind == EventKind.LOST and e.peer == gone and e.t_s >= t0]
            row[v.id] = round(min(seen) - t0, 1) if seen else None
        detection[gone] = row
    # A 'lost' is true from the vehicle's first kill or abort on: a vehicle killed, restarted
    # and killed again keeps its first kill here (``killed`` holds its last, for detection),
    # else its first kill's detections counted as false alarms (a fault fuzz: preset seed 59).
    out_from: dict[str, float] = {}
    for f in faults:
        if f.kind in (FaultKind.KILL, FaultKind.ABORT):
            out_from[f.vid] = min(f.t_s, out_from.get(f.vid, f.t_s))
    false_alarms = sum(
        1 for e in events if e.kind == EventKind.LOST and e.detail == "silent"
        and not (e.peer in out_from and e.t_s >= out_from[e.peer]))
    taken_over = {t for e in events if e.kind == EventKind.TAKEOVER for t in e.tasks}

    agent_totals: dict[str, int] = {}
    largest = 0
    for s in statuses.values():
        for k, n in s.counters.items():
            if k == "largest_frame":
                largest = max(largest, int(n))
            else:
                agent_totals[k] = agent_totals.get(k, 0) + int(n)
    bytes_sent = agent_totals.get("tx_bytes", 0)
    minutes = max(end_s, 1.0) / 60.0
    treatments, duplicates = ledger.treatments, collected.duplicates
    fleet = FleetSection(
        spots_total=problem.n_tasks, spots_cleared=len(ledger.cleared),
        priority=round(collected.priority, 2), priority_total=round(collected.priority_of, 2),
        treatments=treatments, duplicate_treatments=duplicates,
        duplicate_share=round(duplicates / treatments, 4) if treatments else 0.0,
        vehicles_home=sum(1 for v in vehicles if v.home), detection_delay_s=detection,
        false_alarms=false_alarms, spots_taken_over=len(taken_over),
        claims=sum(1 for e in events if e.kind == EventKind.CLAIM),
        claims_lost=sum(1 for e in events if e.kind == EventKind.CLAIM_LOST),
        replans=agent_totals.get("replans", 0))
    messages = Messages(
        frames_sent=sum(n for k, n in agent_totals.items()
                        if k.startswith("tx_") and k != "tx_bytes"),
        bytes_sent=bytes_sent,
        bytes_per_vehicle_minute=round(bytes_sent / problem.n_vehicles / minutes, 1),
        largest_frame_bytes=largest,
        by_kind={k[3:]: n for k, n in sorted(agent_totals.items())
                 if k.startswith("tx_") and k != "tx_bytes"},
        dropped_by_agents={k[5:]: n for k, n in sorted(agent_totals.items())
                           if k.startswith("drop_")},
        link=totals(link) if link is not None else None,
        link_by_sender=totals_by_sender(link) if link is not None else {})
    suspects: dict[str, dict[str, int]] = {}
    for s in statuses.values():
        for accused, n in s.suspects.items():
            suspects.setdefault(accused, {})[s.id] = int(n)
    sections = _extra(extra or {})
    if link is None and isinstance(sections.get("security"), Security):
        # the relay's refusals come with its link counters: neither came
        sections["security"] = msgspec.structs.replace(sections["security"], relay=None)
    return MissionReport(
        mode=mode, scenario=problem.name, seed=seed, end_s=round(end_s, 1),
        faults=[FaultRow(kind=f.kind, vid=f.vid, t_s=f.t_s, value=f.value,
                         order=" ".join(f.words)) for f in faults],
        vehicles=vehicles, fleet=fleet, messages=messages,
        dynamic=dynamic_section(ledger, values) if reef is not None else None,
        suspects={k: dict(sorted(v.items())) for k, v in sorted(suspects.items())} or None,
        **sections)
