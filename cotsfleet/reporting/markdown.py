"""``report.md``: a mission report a person reads, from the report dict (pure: text only).

The report format is `cotsfleet.mission.report.build_report`'s; it grows, so every field is read
with a default, sections with nothing to say are left out, and fields this module does not
know are listed at the end rather than dropped. Every share says what it is a share of.
"""

from __future__ import annotations

import json
from typing import Any, Mapping, Sequence

from cotsfleet.mission.faults import VEHICLE_FLAGS
from cotsfleet.reporting.plots import drop_reasons
from cotsfleet.reporting.timeline import ACTIVITIES, Segment, Spots, time_shares

KNOWN = {"mode", "scenario", "seed", "end_s", "faults", "vehicles", "fleet", "messages",
         "oracle", "run_id", "run_dir", "warp", "loss", "wall_s", "interrupted", "exit_codes",
         "link_timeline", "dynamic", "security"}
KNOWN_FLEET = {"spots_total", "spots_cleared", "priority", "priority_total", "treatments",
               "duplicate_treatments", "duplicate_share", "vehicles_home", "detection_delay_s",
               "false_alarms", "spots_taken_over", "claims", "claims_lost"}
KNOWN_MESSAGES = {"frames_sent", "bytes_sent", "bytes_per_vehicle_minute", "largest_frame_bytes",
                  "by_kind", "dropped_by_agents", "link", "link_by_sender"}
SCENARIO_SPOTS = "the scenario's spots"
SCENARIO_TOTAL = "the scenario's total"
MODES = {"sim": "in-process simulation (deterministic, seeded)",
         "run": "emulated mission, one OS process per vehicle over Zenoh"}


def share(part: Any, whole: Any, of: str) -> str:
    """``"52 % of the scenario's spots"``, or "" when the share cannot be computed."""
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
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return out + [""]


def warnings(report: Mapping[str, Any]) -> list[str]:
    """What a reader must not miss: interruptions, false alarms, duplicates, lost vehicles."""
    fleet, out = report.get("fleet", {}), []
    if report.get("interrupted"):
        out.append("the mission was interrupted: figures cover it only up to the end time")
    if fleet.get("false_alarms"):
        out.append(f"{fleet['false_alarms']} false alarm(s): a vehicle declared a live peer "
                   "lost (loss, a partition or a slow machine) and took over its spots")
    if fleet.get("duplicate_treatments"):
        dups = fleet["duplicate_treatments"]
        out.append(f"{dups} duplicate treatment(s): spots injected more than once"
                   f"{share(dups, fleet.get('treatments'), 'all treatments')}")
    for v in report.get("vehicles", []):
        if v.get("state") not in ("home", None) and not v.get("home"):
            out.append(f"{v.get('id')} ended {v.get('state')}, not at its rendezvous")
    return out


def render(report: Mapping[str, Any], segments: Mapping[str, Sequence[Segment]] | None,
           spots: Spots, figures: Mapping[str, str], notes: Sequence[str] = ()) -> str:
    """The Markdown text; ``figures`` maps a figure's role (``priority``, ``timeline``,
    ``link``) to its file name, ``notes`` says what could not be derived and why."""
    lines = [f"# Mission report: {report.get('scenario', '?')}", ""]
    lines += _mission(report, spots)
    for w in warnings(report):
        lines += [f"> **Warning:** {w}", ""]
    lines += _collected(report, figures)
    lines += _vehicles(report, segments, spots, figures)
    lines += _faults(report)
    lines += _radio(report, figures)
    if isinstance(report.get("dynamic"), Mapping):
        lines += ["## Dynamic mission", "", *_generic(report["dynamic"]), ""]
    if isinstance(report.get("security"), Mapping):
        lines += _security(report["security"])
    extra = {k: v for k, v in report.items() if k not in KNOWN}
    if extra:
        lines += ["## Other fields", "", *_generic(extra), ""]
    if notes:
        lines += ["## Notes", "", *[f"- {n}" for n in notes], ""]
    return "\n".join(lines).rstrip() + "\n"


def _mission(report: Mapping[str, Any], spots: Spots) -> list[str]:
    fleet = report.get("fleet", {})
    mode = report.get("mode", "?")
    end = report.get("end_s")
    facts = [f"- **How:** {MODES.get(mode, mode)}, seed {report.get('seed', '-')}"
             + (f", warp {report['warp']:g}" if isinstance(report.get("warp"), (int, float))
                else "")
             + (f", extra link loss {report['loss']:g}" if report.get("loss") else "")]
    if end is not None:
        wall = report.get("wall_s")
        facts.append(f"- **Duration:** {_num(end)} s of mission time ({float(end) / 60:.1f} min)"
                     + (f", {wall:g} s of wall time" if isinstance(wall, (int, float)) else ""))
    facts.append(f"- **Fleet:** {len(report.get('vehicles', []))} vehicle(s); "
                 f"{_num(fleet.get('spots_total'))} COTS spots worth "
                 f"{_num(fleet.get('priority_total'))} priority in all")
    if report.get("run_dir"):
        facts.append(f"- **Run directory:** `{report['run_dir']}`")
    faults = report.get("faults", [])
    lines = ["## The mission", "", *facts, ""]
    if faults:
        lines += ["Faults injected:", ""]
        lines += _table(["fault", "vehicle", "at (s)", "value"],
                        [[f.get("kind"), f.get("vid") or "-", _num(f.get("t_s")),
                          _num(f.get("value"), 2) if f.get("value") else "-"] for f in faults])
    else:
        lines += ["No fault was injected.", ""]
    return lines


def _collected(report: Mapping[str, Any], figures: Mapping[str, str]) -> list[str]:
    f = report.get("fleet")
    if not isinstance(f, Mapping):
        return ["## What was collected", "", "The report has no fleet figures.", ""]
    k = len(report.get("vehicles", []))
    lines = ["## What was collected", "",
             f"- **Spots cleared:** {_num(f.get('spots_cleared'))} of "
             f"{_num(f.get('spots_total'))}"
             f"{share(f.get('spots_cleared'), f.get('spots_total'), SCENARIO_SPOTS)}",
             f"- **Priority collected:** {_num(f.get('priority'), 1)} of "
             f"{_num(f.get('priority_total'), 1)}"
             f"{share(f.get('priority'), f.get('priority_total'), SCENARIO_TOTAL)}",
             f"- **Treatments:** {_num(f.get('treatments'))}, of which "
             f"{_num(f.get('duplicate_treatments'))} duplicate(s)"
             f"{share(f.get('duplicate_treatments'), f.get('treatments'), 'all treatments')}",
             f"- **Vehicles home:** {_num(f.get('vehicles_home'))} of {k}"]
    extra = {key: v for key, v in f.items() if key not in KNOWN_FLEET}
    if extra:
        lines += _generic(extra)
    lines.append("")
    if "priority" in figures:
        lines += [f"![Priority collected over time]({figures['priority']})", ""]
    return lines


def _vehicles(report: Mapping[str, Any], segments: Mapping[str, Sequence[Segment]] | None,
              spots: Spots, figures: Mapping[str, str]) -> list[str]:
    vehicles = report.get("vehicles", [])
    if not vehicles:
        return []
    fleet_priority = report.get("fleet", {}).get("priority")
    rows = []
    for v in vehicles:
        flags = [k for k in VEHICLE_FLAGS if v.get(k)]
        battery = spots.battery_s.get(v.get("id"))
        used = _num(v.get("battery_used_s")) + (f" of {battery:,.0f}" if battery else "")
        rows.append([v.get("id"), v.get("state", "-"), _num(v.get("tasks_treated")),
                     _num(v.get("priority"), 1)
                     + share(v.get("priority"), fleet_priority, "the fleet's"),
                     _num(v.get("distance_m")), used, _num(v.get("t_diff_s")),
                     ", ".join(flags) or "-"])
    lines = ["## Per vehicle", ""]
    lines += _table(["vehicle", "state", "spots", "priority", "distance (m)",
                     "battery used (s)", "left at rendezvous (s)", "faults"], rows)
    if segments:
        lines += ["Time spent (seconds; share of the mission's "
                  f"{_num(report.get('end_s'))} s), derived from the event log:", ""]
        end = float(report.get("end_s", 0.0) or 0.0)
        spent = {vid: time_shares(segs) for vid, segs in segments.items()}
        shown = [a for a in ACTIVITIES if a in ("transit", "inject")
                 or any(t[a] > 0 for t in spent.values())]
        trows = [[vid, *[f"{t[a]:,.0f} ({100.0 * t[a] / end:.0f} %)" if end else
                         f"{t[a]:,.0f}" for a in shown]] for vid, t in spent.items()]
        lines += _table(["vehicle", *shown], trows)
    if "timeline" in figures:
        lines += [f"![What each vehicle did]({figures['timeline']})", ""]
    return lines


def _faults(report: Mapping[str, Any]) -> list[str]:
    fleet = report.get("fleet", {})
    delays = fleet.get("detection_delay_s") or {}
    when = {(f.get("vid"), f.get("kind")): f.get("t_s") for f in report.get("faults", [])}
    lines = ["## Faults and detection", ""]
    for gone, row in delays.items():
        how = "killed" if (gone, "kill") in when else "aborted" if (gone, "abort") in when \
            else "lost"
        t0 = when.get((gone, "kill"), when.get((gone, "abort")))
        heard = ", ".join(f"{vid} after {d:g} s" if d is not None else f"{vid} never"
                          for vid, d in row.items()) or "no vehicle was left to notice"
        lines.append(f"- **{gone}** ({how}{f' at {_num(t0)} s' if t0 is not None else ''}) "
                     f"was declared lost by {heard}.")
    lines += [f"- **False alarms:** {_num(fleet.get('false_alarms'))} (a live vehicle "
              "declared lost; they cost detours, not duplicates)",
              f"- **Spots taken over** from lost vehicles: {_num(fleet.get('spots_taken_over'))};"
              f" claims made {_num(fleet.get('claims'))}, lost to a conflicting claim "
              f"{_num(fleet.get('claims_lost'))}"]
    oracle = report.get("oracle")
    if isinstance(oracle, Mapping) and oracle.get("ratio") is not None:
        lines.append(
            f"- **Against a perfect-information replan:** after {oracle.get('vid')} died at "
            f"{_num(oracle.get('t_s'))} s the survivors collected "
            f"{_num(oracle.get('collected'), 1)} priority, {oracle['ratio']:.3f} times the "
            f"{_num(oracle.get('priority'), 1)} of a centralized replan of the survivors made "
            "at that moment with perfect information (true positions, batteries, cleared "
            "spots). That replan is the heuristic planner with a fixed budget, not an optimum, "
            "so the fleet can beat it: a ratio above 1 is possible.")
    return lines + [""]


def _radio(report: Mapping[str, Any], figures: Mapping[str, str]) -> list[str]:
    m = report.get("messages")
    if not isinstance(m, Mapping):
        return []
    link = m.get("link") or {}
    kinds = ", ".join(f"{k} {n:,}" for k, n in (m.get("by_kind") or {}).items())
    lines = ["## Radio", "",
             f"- **Sent by the agents:** {_num(m.get('frames_sent'))} frames"
             + (f" ({kinds})" if kinds else "")
             + f", {_num(m.get('bytes_sent'))} bytes: {_num(m.get('bytes_per_vehicle_minute'))}"
             f" bytes per vehicle per minute of mission; largest frame "
             f"{_num(m.get('largest_frame_bytes'))} bytes"]
    if link:
        drops = {k: n for k, n in drop_reasons(link).items() if n}
        dropped = ", ".join(f"{k} {n:,}" for k, n in drops.items()) or "none"
        lines.append(f"- **Through the water:** {_num(link.get('sent'))} receptions (one per "
                     f"frame and receiver), {_num(link.get('delivered'))} delivered"
                     f"{share(link.get('delivered'), link.get('sent'), 'receptions')}; "
                     f"dropped: {dropped}")
    refused = m.get("dropped_by_agents") or {}
    lines.append("- **Refused by the agents** (malformed, forged, replayed): "
                 + (", ".join(f"{k} {n:,}" for k, n in refused.items()) or "none"))
    extra = {k: v for k, v in m.items() if k not in KNOWN_MESSAGES}
    if extra:
        lines += _generic(extra)
    lines.append("")
    by_sender = m.get("link_by_sender") or {}
    if by_sender:
        reasons = sorted({r for row in by_sender.values() for r, n in drop_reasons(row).items()
                          if n})
        rows = [[s, _num(row.get("sent")), _num(row.get("delivered"))
                 + share(row.get("delivered"), row.get("sent"), "its receptions"),
                 *[_num(row.get(r, 0)) for r in reasons]] for s, row in sorted(by_sender.items())]
        header = ["sender", "receptions", "delivered", *[f"dropped: {r}" for r in reasons]]
        lines += _table(header, rows)
    if "link" in figures:
        lines += [f"![Acoustic link deliveries and drops]({figures['link']})", ""]
    return lines


def _security(sec: Mapping[str, Any]) -> list[str]:
    """What the fleet refused on the bus (not signed by the key expression's rightful
    sender, replayed, malformed, invalid values), by who refused it and why."""
    def reasons(row: Any) -> str:
        return ", ".join(f"{k} {n:,}" for k, n in dict(row).items() if n) or "none"

    lines = ["## Security", "",
             f"- **Refused on the bus:** {_num(sec.get('refused_total'))} message(s)",
             f"- **By the operator:** {reasons(sec.get('operator') or {})}",
             f"- **By the relay:** {reasons(sec.get('relay') or {})}"]
    for vid, row in (sec.get("agents") or {}).items():
        lines.append(f"- **By {vid}:** {reasons(row)}")
    return lines + [""]


def _generic(doc: Mapping[str, Any], prefix: str = "") -> list[str]:
    """Fields this module does not know, as bullets (nested objects flattened)."""
    out = []
    for key, value in doc.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping) and value and len(prefix.split(".")) < 3:
            out += _generic(value, f"{name}.")
        else:
            text = json.dumps(value, default=str)
            out.append(f"- {name}: {text if len(text) <= 120 else text[:117] + '...'}")
    return out
