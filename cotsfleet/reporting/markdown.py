"""A mission's report as Markdown a person reads, from the typed report (pure: text only).

Every figure of what was collected is `MissionReport.collected` (the real reef's in a dynamic
mission, named so; the map's otherwise), in the words of `terminal.collected_line`; events
are sentences (`fleet_bus.event_text`); every share says what it is a share of; sections with
nothing to say are left out, and top-level fields this version does not know are listed in a
table at the end rather than dropped.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from typing import Any

from cotsfleet.mission.faults import INSIDER_ATTACKS, OUTSIDER_ATTACKS
from cotsfleet.mission.report_model import (Commands, FaultRow, MissionReport, Security,
                                            TreatedRow, drop_reasons)
from cotsfleet.reporting.terminal import notable, suspects_line
from cotsfleet.reporting.timeline import ACTIVITIES, Segment, Spots, time_shares
from fleet_bus.event_text import sentence
from fleet_bus.states import FaultKind, VehicleState
from fleet_bus.telemetry import Event

MODES = {"sim": "in-process simulation (deterministic, seeded)",
         "run": "emulated mission, one OS process per vehicle over Zenoh"}
EVENTS_IN_REPORT = 60  # notable events listed; events.jsonl has them all
OTHER_VALUE_CHARS = 100


def share(part: Any, whole: Any, of: str) -> str:
    """``" (52 % of the scenario's spots)"``, or "" when the share cannot be computed."""
    try:
        part, whole = float(part), float(whole)
    except (TypeError, ValueError):
        return ""
    return f" ({100.0 * part / whole:.0f} % of {of})" if whole > 0 else ""


def _num(value: Any, digits: int = 0) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return str(value)
    return f"{value:,.{digits}f}"


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c).replace("|", "/") for c in row) + " |" for row in rows]
    return out + [""]


def warnings(report: MissionReport) -> list[str]:
    """What a reader must not miss: a failure, an interruption, false alarms, duplicates,
    vehicles not back."""
    f, c, out = report.fleet, report.collected, []
    if report.failure:
        out.append(f"the mission ended early: {report.failure}")
    if report.interrupted:
        out.append("the mission was interrupted: figures cover it only up to the end time")
    if f.false_alarms:
        out.append(f"{f.false_alarms} false alarm(s): a vehicle declared a live peer lost "
                   "(loss, a partition or a slow machine) and took over its spots")
    if c.duplicates:
        out.append(f"{c.duplicates} duplicate treatment(s): {c.spot_word} injected more than "
                   f"once{share(c.duplicates, c.treatments, 'all treatments')}")
    for v in report.vehicles:
        if v.state != VehicleState.HOME and not v.home:
            out.append(f"{v.id} ended {v.state}, not at its rendezvous")
    return out


def render(report: MissionReport, segments: Mapping[str, Sequence[Segment]] | None,
           spots: Spots, figures: Mapping[str, str], notes: Sequence[str] = (),
           events: Sequence[Event] = ()) -> str:
    """The Markdown text; ``figures`` maps a figure's role (``priority``, ``timeline``,
    ``link``) to its file name, ``notes`` says what could not be derived and why."""
    lines = [f"# Mission report: {report.scenario}", ""]
    lines += _mission(report)
    for w in warnings(report):
        lines += [f"> **Warning:** {w}", ""]
    lines += _collected(report, figures)
    lines += _reef(report)
    lines += _vehicles(report, segments, spots, figures)
    lines += _faults(report)
    if report.commands is not None:
        lines += _commands(report.commands)
    lines += _events(events)
    lines += _radio(report, figures)
    lines += _clock(report)
    if report.security is not None:
        lines += _security(report.security)
    if report.suspects:
        lines += ["## Suspects", "",
                  "Vehicles whose words could not be true (a claim beyond their battery, a "
                  "find off their track, another's spot said cleared by one peer alone; "
                  "docs/security.md), refused and counted by the peers that heard them:",
                  "", suspects_line(report.suspects), ""]
    lines += _processes(report)
    lines += _other(report.other)
    if notes:
        lines += ["## Notes", "", *[f"- {n}" for n in notes], ""]
    return "\n".join(lines).rstrip() + "\n"


def _mission(report: MissionReport) -> list[str]:
    f, c, d = report.fleet, report.collected, report.dynamic
    facts = [f"- **How:** {MODES.get(report.mode, report.mode)}, seed {report.seed}"
             + (f", warp {report.warp:g}" if report.warp is not None else "")
             + (f", extra link loss {report.loss:g}" if report.loss else "")]
    wall = report.wall_s
    facts.append(f"- **Duration:** {_num(report.end_s)} s of mission time "
                 f"({report.end_s / 60:.1f} min)"
                 + (f", {wall:g} s of wall time" if wall is not None else ""))
    fleet = f"- **Fleet:** {len(report.vehicles)} vehicle(s); "
    if d is None:
        fleet += f"{_num(f.spots_total)} COTS spots worth {_num(f.priority_total)} priority"
    else:
        fleet += (f"a map of {_num(f.spots_total)} predicted COTS spots; the real reef holds "
                  f"{_num(c.spots_of)} spots worth {_num(c.priority_of)} priority "
                  f"({d.unmapped} of them missed by the map)")
    facts.append(fleet)
    if report.run_dir:
        facts.append(f"- **Run directory:** `{report.run_dir}`")
    lines = ["## The mission", "", *facts, ""]
    if report.faults:
        lines += ["Faults injected:", ""]
        lines += _table(["fault", "vehicle", "at (s)", "value"],
                        [[x.kind, x.vid or "-", _num(x.t_s), _num(x.value, 2) if x.value else "-"]
                         for x in report.faults])
    else:
        lines += ["No fault was injected.", ""]
    return lines


def _collected(report: MissionReport, figures: Mapping[str, str]) -> list[str]:
    f, c = report.fleet, report.collected
    whose = "the real reef's" if c.on_reef else "the scenario's"
    lines = ["## What was collected", "",
             f"- **Spots treated:** {_num(c.spots)} of {_num(c.spots_of)} {c.spot_word}"
             f"{share(c.spots, c.spots_of, f'{whose} spots')}",
             f"- **Priority collected:** {_num(c.priority, 1)} of {_num(c.priority_of, 1)}"
             + (" real priority" if c.on_reef else "")
             + share(c.priority, c.priority_of, f"{whose} total"),
             f"- **Treatments:** {_num(c.treatments)}, of which {_num(c.duplicates)} "
             f"duplicate(s){share(c.duplicates, c.treatments, 'all treatments')}",
             f"- **Vehicles home:** {_num(f.vehicles_home)} of {len(report.vehicles)}",
             f"- **Replans:** {_num(f.replans)} route change(s) across the fleet"]
    b = report.baseline
    if b is not None:
        kind = "predicted priority (the map's)" if c.on_reef else "priority"
        lines.append(f"- **Without a link:** flying the initial plan alone, the fleet would "
                     f"treat {_num(b.spots)} spot(s) worth {_num(b.priority, 1)} {kind}")
    lines.append("")
    if "priority" in figures:
        lines += [f"![Priority collected over time]({figures['priority']})", ""]
    return lines


def _reef(report: MissionReport) -> list[str]:
    """A dynamic mission: the real reef against the map, in sentences and one table."""
    d, c, f = report.dynamic, report.collected, report.fleet
    if d is None:
        return []
    found = (f"{_num(d.spots_discovered)} aggregation(s)"
             + (f", {_num(d.unmapped_found)} of them among the {_num(d.unmapped)} the map "
                f"missed" if isinstance(d.unmapped_found, int) else ""))
    lines = ["## The real reef against the map", "",
             f"The map predicted {_num(f.spots_total)} spots; the vehicles found "
             f"{_num(d.empty_inspected)} of them empty. The fleet treated {_num(c.spots)} of "
             f"the reef's {_num(c.spots_of)} real spots, worth {_num(c.priority, 1)} of "
             f"{_num(c.priority_of, 1)} real priority"
             f"{share(c.priority, c.priority_of, 'the real total')}. The vehicles' cameras "
             f"reported {found}; {_num(d.unmapped_treated)} of the {_num(d.unmapped)} missed "
             "ones were treated.", ""]
    rows = []
    for v in report.vehicles:
        mine = [t for t in d.treated if t.vehicle == v.id]
        rows.append([v.id, _num(len(mine)), _num(len({t.spot for t in mine})),
                     _num(v.priority, 1)])
    lines += _table(["vehicle", "treatments", "real spots", "real priority"], rows)
    if d.treated:
        first: dict[int, TreatedRow] = {}
        for t in d.treated:
            first.setdefault(t.spot, t)
        again = [t for t in d.treated if first[t.spot] is not t]
        if again:
            lines += ["Real spots treated again (duplicates):", ""]
            lines += _table(["real spot", "first by", "at (s)", "again by", "at (s)"],
                            [[t.spot, first[t.spot].vehicle, _num(first[t.spot].t_s),
                              t.vehicle, _num(t.t_s)] for t in again])
    return lines


def _vehicles(report: MissionReport, segments: Mapping[str, Sequence[Segment]] | None,
              spots: Spots, figures: Mapping[str, str]) -> list[str]:
    if not report.vehicles:
        return []
    c = report.collected
    rows = []
    for v in report.vehicles:
        n, priority = c.by_vehicle.get(v.id, (0, 0.0))
        battery = spots.battery_s.get(v.id)
        used = _num(v.battery_used_s) + (f" of {battery:,.0f}" if battery else "")
        rows.append([v.id, v.state, _num(n), _num(priority, 1)
                     + share(priority, c.priority, "the fleet's"),
                     _num(v.distance_m), used, _num(v.t_diff_s), ", ".join(v.flags) or "-"])
    lines = ["## Per vehicle", ""]
    lines += _table(["vehicle", "state", c.spot_word, "priority", "distance (m)",
                     "battery used (s)", "left at rendezvous (s)", "faults"], rows)
    if sum(p for _, p in c.by_vehicle.values()) > c.priority + 0.01:
        lines += ["A spot treated by two vehicles counts for both, so the vehicles' shares "
                  "add up to more than the fleet's.", ""]
    if segments:
        end = report.end_s
        lines += [f"Time spent (seconds; share of the mission's {_num(end)} s), derived from "
                  "the event log:", ""]
        spent = {vid: time_shares(segs) for vid, segs in segments.items()}
        shown = [a for a in ACTIVITIES if a in ("transit", "inject")
                 or any(t[a] > 0 for t in spent.values())]
        trows = [[vid, *[f"{t[a]:,.0f} ({100.0 * t[a] / end:.0f} %)" if end else
                         f"{t[a]:,.0f}" for a in shown]] for vid, t in spent.items()]
        lines += _table(["vehicle", *shown], trows)
    if "timeline" in figures:
        lines += [f"![What each vehicle did]({figures['timeline']})", ""]
    return lines


def false_alarm_text(false_alarms: int, duplicates: int) -> str:
    """The false alarms and what they cost, as this report can tell."""
    what = f"{_num(false_alarms)} (a live vehicle declared lost)"
    if not false_alarms:
        return what
    if duplicates:
        return (f"{what}; the report counts {_num(duplicates)} duplicate treatment(s), which "
                "a false alarm can cause (two vehicles treating the spots of one)")
    return f"{what}; they cost detours here, no duplicate treatment"


def _faults(report: MissionReport) -> list[str]:
    f = report.fleet
    when = {(x.vid, x.kind): x.t_s for x in report.faults}
    lines = ["## Faults and detection", ""]
    if report.faults:
        lines.append("- **Injected:** " + "; ".join(_fault_text(x) for x in report.faults) + ".")
    for gone, row in f.detection_delay_s.items():
        how = "killed" if (gone, "kill") in when else "aborted" if (gone, "abort") in when \
            else "lost"
        t0 = when.get((gone, "kill"), when.get((gone, "abort")))
        heard = ", ".join(f"{vid} after {d:g} s" if d is not None else f"{vid} never"
                          for vid, d in row.items()) or "no vehicle was left to notice"
        lines.append(f"- **{gone}** ({how}{f' at {_num(t0)} s' if t0 is not None else ''}) "
                     f"was declared lost by {heard}.")
    lines += [f"- **False alarms:** "
              f"{false_alarm_text(f.false_alarms, report.collected.duplicates)}",
              f"- **Spots taken over** from lost vehicles: {_num(f.spots_taken_over)};"
              f" claims made {_num(f.claims)}, lost to a conflicting claim "
              f"{_num(f.claims_lost)}"]
    o = report.oracle
    if o is not None:
        lines.append(
            f"- **Against a perfect-information replan:** after {o.vid} died at "
            f"{_num(o.t_s)} s the survivors collected {_num(o.collected, 1)} priority, "
            f"{o.ratio:.3f} times the {_num(o.priority, 1)} of a centralized replan of the "
            "survivors made at that moment with perfect information (true positions, "
            "batteries, cleared spots). That replan is the heuristic planner with a fixed "
            "budget, not an optimum, so the fleet can beat it: a ratio above 1 is possible.")
    return lines + [""]


def _fault_text(x: FaultRow) -> str:
    """One injected fault in words (`cotsfleet.mission.faults`)."""
    if x.kind == FaultKind.CTL:
        return f"the operator's order {x.order} at {_num(x.t_s)} s"
    if x.kind in INSIDER_ATTACKS:
        return f"{x.kind} by insider {x.vid} x{_num(x.value)} at {_num(x.t_s)} s"
    if x.kind in OUTSIDER_ATTACKS:
        return f"{x.kind} by an intruder's modem x{_num(x.value)} at {_num(x.t_s)} s"
    what = {"partition": f" for {_num(x.value)} s", "stall": f" for {_num(x.value)} s",
            "loss": f" {x.value:g}"}.get(x.kind, "")
    who = f" {x.vid}" if x.vid else ""
    return f"{x.kind}{who}{what} at {_num(x.t_s)} s"


def _commands(c: Commands) -> list[str]:
    """The operator's live orders (docs/operator.md): sent, acknowledged, refused."""
    rows = [[f"#{o.seq}", o.order, o.by or "scheduled", _num(o.issued_s), o.transmissions,
             ", ".join(f"{v} at {_num(t)} s" for v, t in sorted(o.acked.items())) or "-",
             ", ".join(f"{v}: {why}" for v, why in sorted(o.refused.items())) or "-"]
            for o in c.sent]
    lines = ["## The operator's orders", "",
             f"From the topside modem at ({', '.join(_num(v) for v in c.topside)}) m; proven "
             "by its own key chain (docs/security.md).", ""]
    if rows:
        lines += _table(["order", "words", "from", "issued s", "transmissions",
                         "acknowledged", "refused"], rows)
    refused = {**{f"by the vehicles: {k}": n for k, n in c.refused.items()},
               **{f"by the operator's side: {k}": n for k, n in c.operator_refused.items()}}
    lines.append("Refused: " + (", ".join(f"{k} {n}" for k, n in sorted(refused.items()))
                                or "none") + f"; repeats heard (not acted on twice): "
                 f"{c.repeats}.")
    return lines + [""]


def _events(events: Sequence[Event]) -> list[str]:
    shown = notable(events)
    if not shown:
        return []
    lines = ["## What happened", "",
             "Aborts, silences, losses, takeovers, finds and refusals, in time order (claims, "
             "treatments and replans are counted above; every event is in the event log).", ""]
    lines += _table(["at (s)", "what happened"],
                    [[_num(e.t_s), sentence(e)] for e in shown[:EVENTS_IN_REPORT]])
    if len(shown) > EVENTS_IN_REPORT:
        lines += [f"... and {len(shown) - EVENTS_IN_REPORT} more.", ""]
    return lines


def _radio(report: MissionReport, figures: Mapping[str, str]) -> list[str]:
    m = report.messages
    kinds = ", ".join(f"{k} {n:,}" for k, n in m.by_kind.items())
    lines = ["## Radio", "",
             f"- **Sent by the agents:** {_num(m.frames_sent)} frames"
             + (f" ({kinds})" if kinds else "")
             + f", {_num(m.bytes_sent)} bytes: {_num(m.bytes_per_vehicle_minute)}"
             f" bytes per vehicle per minute of mission; largest frame "
             f"{_num(m.largest_frame_bytes)} bytes"]
    link = m.link
    if link is None:
        lines.append("- **Through the water:** unknown: the relay's counters never came (it "
                     "was gone or did not answer at the end)")
    else:
        drops = {k: n for k, n in drop_reasons(link).items() if n}
        dropped = ", ".join(f"{k} {n:,}" for k, n in drops.items()) or "none"
        lines.append(f"- **Through the water:** {_num(link.get('sent'))} receptions (one per "
                     f"frame and receiver), {_num(link.get('delivered'))} delivered"
                     f"{share(link.get('delivered'), link.get('sent'), 'receptions')}; "
                     f"dropped: {dropped}")
    lines.append("- **Refused by the agents** (malformed, forged, replayed): "
                 + (", ".join(f"{k} {n:,}" for k, n in m.dropped_by_agents.items()) or "none"))
    lines.append("")
    if m.link_by_sender:
        reasons = sorted({r for row in m.link_by_sender.values()
                          for r, n in drop_reasons(row).items() if n})
        rows = [[s, _num(row.get("sent")), _num(row.get("delivered"))
                 + share(row.get("delivered"), row.get("sent"), "its receptions"),
                 *[_num(row.get(r, 0)) for r in reasons]]
                for s, row in sorted(m.link_by_sender.items())]
        header = ["sender", "receptions", "delivered", *[f"dropped: {r}" for r in reasons]]
        lines += _table(header, rows)
    if "link" in figures:
        lines += [f"![Acoustic link deliveries and drops]({figures['link']})", ""]
    return lines


def _clock(report: MissionReport) -> list[str]:
    """The shared mission clock of a run: the warp asked for, what it really was, its holds
    and slowdowns (`cotsfleet.mission.clock_control`)."""
    k = report.clock
    if k is None:
        return []

    def have(x: Any) -> bool:
        return isinstance(x, (int, float)) and not isinstance(x, bool)

    text = f"Warp {k.warp:g} was asked for"
    if have(k.effective_warp):
        text += f"; the mission ran at {k.effective_warp:g} on average"
    if have(k.final_warp) and k.final_warp != k.warp:
        text += f" and ended at {k.final_warp:g}"
    said = [text + "."]
    if isinstance(k.slowdowns, list) and k.slowdowns:
        slowest = min(s.warp for s in k.slowdowns)
        said.append(f"The machine could not keep up {len(k.slowdowns)} time(s): the clock "
                    f"slowed down to warp {slowest:g} at worst"
                    + (f" and sped up again {len(k.speedups)} time(s)"
                       if isinstance(k.speedups, list) and k.speedups else "") + ".")
    if have(k.holds) and k.holds:
        held = f" ({k.held_wall_s:g} wall s in all)" if have(k.held_wall_s) else ""
        said.append(f"It was held at a slow warp {k.holds} time(s) while an agent planned"
                    f"{held}.")
    if have(k.max_lag_s):
        said.append(f"The slowest vehicle's process ran at most {k.max_lag_s:g} mission s "
                    "behind the clock.")
    if have(k.slots_late) and k.slots_late:
        said.append(f"{k.slots_late} frame(s) left a host after their TDMA slot and were "
                    "dated at the slot.")
    return ["## Clock", "", " ".join(said), ""]


def _security(sec: Security) -> list[str]:
    """What the fleet refused on the bus (not signed by the key expression's rightful
    sender, replayed, malformed, invalid values), by who refused it and why."""
    def reasons(row: Mapping[str, int] | None) -> str:
        if row is None:
            return "unknown (the relay's counters never came)"
        return ", ".join(f"{k} {n:,}" for k, n in row.items() if n) or "none"

    lines = ["## Security", "",
             f"- **Refused on the bus:** {_num(sec.refused_total)} message(s)"
             + (" (not counting the relay's, which never came)" if sec.relay is None else ""),
             f"- **By the operator:** {reasons(sec.operator)}",
             f"- **By the relay:** {reasons(sec.relay)}"]
    for vid, row in sec.agents.items():
        lines.append(f"- **By {vid}:** {reasons(row)}")
    if sec.orders:
        lines.append(f"- **Order requests refused by the launcher:** {reasons(sec.orders)}")
    if sec.orders_taken:
        lines.append(f"- **Order requests taken, by signer:** {reasons(sec.orders_taken)}")
    return lines + [""]


def _processes(report: MissionReport) -> list[str]:
    """How a run's processes ended, when one ended on its own or badly."""
    codes, exited = report.exit_codes or {}, report.exited or {}
    bad = {n: c for n, c in codes.items() if c not in (0, None)}
    if not exited and not bad:
        return []
    killed = {x.vid for x in report.faults if x.kind == FaultKind.KILL}
    rows = [[name, _exit(code) + (" (the kill fault)" if name in killed else ""),
             exited.get(name, "") or "-"] for name, code in codes.items()
            if name in exited or name in bad]
    return ["## Processes", "", "Processes that ended on their own or with an error:", "",
            *_table(["process", "how it ended", "its last output"], rows)]


def _exit(code: int | None) -> str:
    if code is None:
        return "still running"
    if code < 0:
        return f"killed by signal {-code}"
    return f"exit code {code}"


def _other(other: Mapping[str, Any]) -> list[str]:
    """Top-level fields this version does not know, one row each."""
    if not other:
        return []
    rows = []
    for key, value in other.items():
        text = json.dumps(value, default=str)
        if len(text) > OTHER_VALUE_CHARS:
            text = text[:OTHER_VALUE_CHARS - 3] + "..."
        rows.append([f"`{key}`", f"`{text}`"])
    return ["## Other fields", "",
            "Fields this version of cotsfleet does not know (the report came from a newer "
            "one, or from another tool):", "", *_table(["field", "value"], rows)]
