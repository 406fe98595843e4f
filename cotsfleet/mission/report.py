"""The mission report: one format for `cotsfleet sim` and `cotsfleet run`.

Built from what an operator gets after recovery: the fleet's telemetry (`FleetLedger`: each
vehicle's last `Status`, the `Event` log, what each reported treating), the relay's link
counters, and the faults that were applied (with the times they were). The process backend
adds ``security``: what the operator, the relay and each agent refused, by reason
(`fleet_bus.auth`); `format_report` prints it.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

from comms_sim.stats import COUNTERS, LinkCounts, totals, totals_by_sender
from cotsfleet.mission.faults import VEHICLE_FLAGS, Fault
from fleet_bus.ledger import FleetLedger
from fleet_bus.telemetry import Event
from fleet_bus.telemetry import detail_position as _fix
from hfc_core.model.problem import Problem
from reef_sim.truth import Reef

FIX_TOLERANCE_M = 1.0  # a find's logged position (decimetres) names the truth spot this close


def truth_spots_of(problem: Problem, reef: Reef, e: Event) -> list[int]:
    """The truth spots (indices in ``truth.spots``) an event's spots are: a predicted spot by
    its task (none if it was empty), a find by where it was (the world's bookkeeping)."""
    out = []
    for tid in e.tasks:
        if tid in problem.task_index:
            i = reef.of_task(problem.task_index[tid])
        else:
            fix = _fix(e.detail)
            i = None if fix is None else _nearest(reef, fix)
        if i is not None:
            out.append(i)
    return out


def _nearest(reef: Reef, pos: tuple[float, float, float]) -> int | None:
    best, best_d = None, FIX_TOLERANCE_M
    for i, s in enumerate(reef.spots):
        d = sum((a - b) ** 2 for a, b in zip(s.pos, pos)) ** 0.5
        if d <= best_d:
            best, best_d = i, d
    return best


def dynamic_section(problem: Problem, reef: Reef, events: Sequence[Event]) -> dict[str, Any]:
    """What the fleet did on the real reef: each truth spot treated (first treatment by each
    vehicle, in time order), the aggregations the map missed that were found, the predicted
    spots found empty, and the reef's whole priority."""
    treated: list[dict[str, Any]] = []
    seen: set[tuple[int, str]] = set()
    found: set[int] = set()
    empty: set[int] = set()
    for e in sorted(events, key=lambda e: e.t_s):
        if e.kind == "cleared":
            for i in truth_spots_of(problem, reef, e):
                if (i, e.id) not in seen:
                    seen.add((i, e.id))
                    treated.append({"spot": i, "vehicle": e.id, "t_s": round(e.t_s, 1)})
        elif e.kind == "found":
            fix = _fix(e.detail)
            i = None if fix is None else _nearest(reef, fix)
            if i is not None:
                found.add(i)
        elif e.kind == "empty":
            empty.update(e.tasks)
    spots = {t["spot"] for t in treated}
    unmapped = set(reef.unmapped())
    return {
        "treated": treated,
        "spots_discovered": len(found),
        "empty_inspected": len(empty),
        "truth_priority": round(reef.total_priority(), 2),
        "truth_spots": len(reef.spots),
        "unmapped": len(unmapped),
        "unmapped_treated": len(spots & unmapped),
        "priority_treated": round(sum(reef.spots[i].priority for i in spots), 2),
        "duplicate_treatments": len(treated) - len(spots),
    }


def build_report(problem: Problem, ledger: FleetLedger, link: LinkCounts | None,
                 faults: Sequence[Fault], *, mode: str, seed: int, end_s: float,
                 extra: Mapping[str, Any] | None = None,
                 reef: Reef | None = None) -> dict[str, Any]:
    """The report; with ``reef`` (a dynamic mission) priorities and duplicates are the real
    reef's (`dynamic_section`), not the map's."""
    tasks = {t.id: t for t in problem.tasks}
    dynamic = None if reef is None else dynamic_section(problem, reef, ledger.events)
    statuses, events = ledger.statuses, ledger.events
    killed = {f.vid: f.t_s for f in faults if f.kind == "kill"}
    aborted = {f.vid: f.t_s for f in faults if f.kind == "abort"}
    restarted = {f.vid for f in faults if f.kind == "restart"}
    stalled = {f.vid for f in faults if f.kind == "stall"}
    treated = ledger.treated_by
    helms = ((extra or {}).get("helm") or {}).get("vehicles", {})
    vehicles = []
    for v in problem.vehicles:
        s = statuses.get(v.id)
        mine = treated.get(v.id, set())
        vehicles.append({
            "id": v.id,
            "state": "dead" if v.id in killed and v.id not in restarted else
                     (s.state if s else "unknown"),
            "tasks_treated": len(mine),
            "priority": round(sum(tasks[t].priority for t in mine if t in tasks), 2)
            if dynamic is None else round(sum(reef.spots[d["spot"]].priority  # type: ignore
                                              for d in dynamic["treated"] if d["vehicle"] == v.id), 2),
            "distance_m": round(s.distance_m, 1) if s else 0.0,
            "battery_used_s": round(v.battery_s - s.battery_s, 1) if s else 0.0,
            "t_diff_s": round(s.battery_s, 1) if s and s.state == "home" else None,
            "home": bool(s and s.state == "home"),
            "aborted": v.id in aborted,
            "killed": v.id in killed,
            "restarted": v.id in restarted,
            "stalled": v.id in stalled,
            "helm": helms.get(v.id, "sim"),  # what drove it (`cotsfleet run --helm`)
            "nav_fixes": int(s.counters.get("nav_fixes", 0)) if s else 0,
            "counters": dict(s.counters) if s else {},
        })
    distinct, n_treatments, duplicates = ledger.cleared, ledger.treatments, ledger.duplicates()
    priority = sum(tasks[t].priority for t in distinct if t in tasks)
    priority_total = float(problem.priority.sum())
    if dynamic is not None and reef is not None:  # the real reef's figures
        priority, priority_total = dynamic["priority_treated"], dynamic["truth_priority"]
        duplicates = dynamic["duplicate_treatments"]

    detection: dict[str, dict[str, float | None]] = {}
    for gone, t0 in sorted({**aborted, **killed}.items()):
        row: dict[str, float | None] = {}
        for v in problem.vehicles:
            out_before = [t for t in (killed.get(v.id), aborted.get(v.id)) if t is not None]
            if v.id == gone or any(t <= t0 for t in out_before):
                continue  # only vehicles still in the mission can detect anything
            seen = [e.t_s for e in events
                    if e.id == v.id and e.kind == "lost" and e.peer == gone and e.t_s >= t0]
            row[v.id] = round(min(seen) - t0, 1) if seen else None
        detection[gone] = row
    false_alarms = sum(
        1 for e in events if e.kind == "lost" and e.detail == "silent"
        and not (e.peer in killed and e.t_s >= killed[e.peer])
        and not (e.peer in aborted and e.t_s >= aborted[e.peer]))
    taken_over = {t for e in events if e.kind == "takeover" for t in e.tasks}

    agent_totals: dict[str, int] = {}
    largest = 0
    for s in statuses.values():
        for k, n in s.counters.items():
            if k == "largest_frame":
                largest = max(largest, int(n))
            else:
                agent_totals[k] = agent_totals.get(k, 0) + int(n)
    frames_sent = sum(n for k, n in agent_totals.items()
                      if k.startswith("tx_") and k != "tx_bytes")
    bytes_sent = agent_totals.get("tx_bytes", 0)
    minutes = max(end_s, 1.0) / 60.0
    link_totals = totals(link) if link is not None else dict.fromkeys(COUNTERS, 0)
    return {
        "mode": mode,
        "scenario": problem.name,
        "seed": seed,
        "end_s": round(end_s, 1),
        "faults": [{"kind": f.kind, "vid": f.vid, "t_s": f.t_s, "value": f.value}
                   for f in faults],
        "vehicles": vehicles,
        "fleet": {
            "spots_total": problem.n_tasks,
            "spots_cleared": len(distinct),
            "priority": round(priority, 2),
            "priority_total": round(priority_total, 2),
            "treatments": n_treatments,
            "duplicate_treatments": duplicates,
            "duplicate_share": round(duplicates / n_treatments, 4) if n_treatments else 0.0,
            "vehicles_home": sum(1 for v in vehicles if v["home"]),
            "detection_delay_s": detection,
            "false_alarms": false_alarms,
            "spots_taken_over": len(taken_over),
            "claims": sum(1 for e in events if e.kind == "claim"),
            "claims_lost": sum(1 for e in events if e.kind == "claim_lost"),
            "replans": agent_totals.get("replans", 0),
        },
        "messages": {
            "frames_sent": frames_sent,
            "bytes_sent": bytes_sent,
            "bytes_per_vehicle_minute": round(bytes_sent / problem.n_vehicles / minutes, 1),
            "largest_frame_bytes": largest,
            "by_kind": {k[3:]: n for k, n in sorted(agent_totals.items())
                        if k.startswith("tx_") and k != "tx_bytes"},
            "dropped_by_agents": {k[5:]: n for k, n in sorted(agent_totals.items())
                                  if k.startswith("drop_")},
            "link": link_totals,
            "link_by_sender": totals_by_sender(link) if link is not None else {},
        },
        **({"dynamic": dynamic} if dynamic is not None else {}),
        **(dict(extra) if extra else {}),
    }


def format_report(report: Mapping[str, Any]) -> str:
    """A terminal summary of a report."""
    f, m = report["fleet"], report["messages"]
    lines = [f"{report['mode']} {report['scenario']} seed {report['seed']}: "
             f"{f['spots_cleared']}/{f['spots_total']} spots cleared, priority "
             f"{f['priority']:.0f}/{f['priority_total']:.0f}, "
             f"{f['duplicate_treatments']} duplicate treatment(s), "
             f"{f['vehicles_home']} vehicle(s) home, end t={report['end_s']:.0f} s"]
    lines.append(f"{'vehicle':<8} {'state':<9} {'tasks':>5} {'priority':>9} {'dist m':>8} "
                 f"{'batt used':>9} {'T_diff':>7}  faults")
    for v in report["vehicles"]:
        flags = [k for k in VEHICLE_FLAGS if v.get(k)]
        tdiff = f"{v['t_diff_s']:.0f}" if v["t_diff_s"] is not None else "-"
        lines.append(f"{v['id']:<8} {v['state']:<9} {v['tasks_treated']:>5} "
                     f"{v['priority']:>9.1f} {v['distance_m']:>8.0f} {v['battery_used_s']:>9.0f} "
                     f"{tdiff:>7}  {','.join(flags)}")
    d = report.get("dynamic")
    if d:
        share = d["priority_treated"] / d["truth_priority"] if d["truth_priority"] else 0.0
        lines.append(f"reef: {len({t['spot'] for t in d['treated']})} of {d['truth_spots']} real "
                      f"spots treated, priority {d['priority_treated']:.0f} of "
                      f"{d['truth_priority']:.0f} ({100 * share:.0f} %); "
                      f"{d['spots_discovered']} of {d['unmapped']} aggregations the map missed "
                      f"found ({d['unmapped_treated']} treated); {d['empty_inspected']} predicted "
                      f"spot(s) found empty")
    for gone, row in f["detection_delay_s"].items():
        delays = ", ".join(f"{vid} {'-' if d is None else f'{d:.0f} s'}" for vid, d in row.items())
        lines.append(f"detection of {gone}: {delays}")
    link = m["link"]
    drops = {k: link.get(k, 0) for k in ("partition", "range", "sinr", "half_duplex", "collision",
                                          "random", "superseded", "oversize") if link.get(k)}
    lines.append(f"radio: {m['frames_sent']} frames, {m['bytes_sent']} bytes "
                 f"({m['bytes_per_vehicle_minute']:.0f} B/vehicle/min), largest "
                 f"{m['largest_frame_bytes']} B; receptions {link.get('sent', 0)}, delivered "
                 f"{link.get('delivered', 0)}, dropped {drops}; agents refused "
                 f"{m['dropped_by_agents']}; takeovers {f['spots_taken_over']} spot(s), "
                 f"false alarms {f['false_alarms']}")
    sec = report.get("security")
    if sec:
        parts = [f"{who} {sec[who]}" for who in ("operator", "relay") if sec.get(who)]
        parts += [f"{vid} {row}" for vid, row in sec.get("agents", {}).items()]
        lines.append(f"security: {sec['refused_total']} message(s) refused"
                     + (f" ({'; '.join(parts)})" if parts else ""))
    return "\n".join(lines)
