"""What the terminal says about a mission: the progress line while it runs and the summary
after it, in the words ``report.md`` uses (`collected_line`, `fleet_bus.event_text`)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

from cotsfleet.mission.report_model import MissionReport
from fleet_bus.event_text import NOTABLE, sentence
from fleet_bus.ledger import Collected
from fleet_bus.telemetry import Event

EVENTS_ON_TERMINAL = 12  # notable events printed after a mission; report.md has them all
DROP_ORDER = ("partition", "range", "sinr", "half_duplex", "collision", "random", "superseded",
              "oversize", "queue_full")


def percent(part: float, whole: float) -> str:
    """`` (75 %)``, or "" when there is no whole to be a share of."""
    return f" ({100.0 * part / whole:.0f} %)" if whole > 0 else ""


def collected_line(c: Collected) -> str:
    """``45 of 79 real spots treated, priority 3058 of 4080 (75 %)``: the one wording of what
    the fleet collected (real spots and priorities on a reef, the map's otherwise)."""
    return (f"{c.spots} of {c.spots_of} {c.spot_word} treated, priority {c.priority:.0f} of "
            f"{c.priority_of:.0f}{percent(c.priority, c.priority_of)}")


def progress_line(t_s: float, c: Collected, vehicles: Sequence[str]) -> str:
    """A running mission's line: mission time, what was collected, each vehicle's word."""
    return f"t={t_s:6.0f} s  {collected_line(c)}  | " + " | ".join(vehicles)


def notable(events: Iterable[Event]) -> list[Event]:
    """The events an operator reads after a mission, in time order."""
    return sorted((e for e in events if e.kind in NOTABLE), key=lambda e: e.t_s)


def format_report(report: MissionReport, events: Sequence[Event] = ()) -> str:
    """A terminal summary of a report (and of its notable events, when given)."""
    f, m, c = report.fleet, report.messages, report.collected
    lines = [f"{report.mode} {report.scenario} seed {report.seed}: {collected_line(c)}, "
             f"{c.duplicates} duplicate treatment(s), {f.vehicles_home} of "
             f"{len(report.vehicles)} vehicle(s) home, end t={report.end_s:.0f} s"]
    lines.append(f"{'vehicle':<8} {'state':<9} {'spots':>5} {'priority':>9} {'dist m':>8} "
                 f"{'batt used':>9} {'T_diff':>7}  faults")
    for v in report.vehicles:
        spots, _ = c.by_vehicle.get(v.id, (0, 0.0))
        tdiff = f"{v.t_diff_s:.0f}" if v.t_diff_s is not None else "-"
        lines.append(f"{v.id:<8} {v.state:<9} {spots:>5} {v.priority:>9.1f} "
                     f"{v.distance_m:>8.0f} {v.battery_used_s:>9.0f} {tdiff:>7}  "
                     f"{','.join(v.flags)}")
    d = report.dynamic
    if d is not None:
        lines.append(f"map: {f.spots_total} predicted spots, {d.empty_inspected} found empty; "
                     f"finds: {d.spots_discovered} real spot(s), "
                     + (f"{d.unmapped_found} of the {d.unmapped} the map missed "
                        f"({d.unmapped_treated} treated)"
                        if isinstance(d.unmapped_found, int) else
                        f"{d.unmapped_treated} of the {d.unmapped} the map missed treated"))
    for gone, row in f.detection_delay_s.items():
        delays = ", ".join(f"{vid} {'-' if x is None else f'{x:.0f} s'}"
                           for vid, x in row.items())
        lines.append(f"detection of {gone}: {delays}")
    link = m.link
    if link is None:
        water = "the relay's counters never came (receptions unknown)"
    else:
        drops = {k: link[k] for k in DROP_ORDER if link.get(k)}
        water = (f"receptions {link.get('sent', 0)}, delivered {link.get('delivered', 0)}, "
                 f"dropped {', '.join(f'{k} {n}' for k, n in drops.items()) or 'none'}")
    refused = ", ".join(f"{k} {n}" for k, n in m.dropped_by_agents.items()) or "nothing"
    lines.append(f"radio: {m.frames_sent} frames, {m.bytes_sent} bytes "
                 f"({m.bytes_per_vehicle_minute:.0f} B/vehicle/min), largest "
                 f"{m.largest_frame_bytes} B; {water}; agents refused {refused}; takeovers "
                 f"{f.spots_taken_over} spot(s), false alarms {f.false_alarms}")
    sec = report.security
    if sec is not None:
        parts = [f"operator {sec.operator}"] if sec.operator else []
        if sec.relay is None:
            parts.append("relay unknown (its counters never came)")
        elif sec.relay:
            parts.append(f"relay {sec.relay}")
        parts += [f"{vid} {row}" for vid, row in sec.agents.items()]
        if sec.orders:
            parts.append(f"order requests {sec.orders}")
        lines.append(f"security: {sec.refused_total} message(s) refused"
                     + (f" ({'; '.join(parts)})" if parts else ""))
    if report.suspects:
        lines.append("suspects: " + suspects_line(report.suspects))
    shown = notable(events)
    for e in shown[:EVENTS_ON_TERMINAL]:
        lines.append(f"t={e.t_s:6.0f} s  {sentence(e)}")
    if len(shown) > EVENTS_ON_TERMINAL:
        lines.append(f"... and {len(shown) - EVENTS_ON_TERMINAL} more notable event(s) in the "
                     "report's Markdown")
    return "\n".join(lines)


def suspects_line(suspects: Mapping[str, Mapping[str, int]]) -> str:
    """Who said what could not be, by whom it was refused: "auv3 (14 refused: auv1 9, auv2 5)"."""
    return "; ".join(f"{accused} ({sum(by.values())} refused: "
                     + ", ".join(f"{v} {n}" for v, n in by.items()) + ")"
                     for accused, by in suspects.items())
