"""Write a mission's report bundle beside its JSON: ``r.json`` gives ``r.md`` and
``r-priority.png``, ``r-timeline.png``, ``r-link.png``.

Named after the JSON rather than fixed names in a folder: two reports in one directory
(``sim --report r.json`` then ``sim --report r0.json``) keep their own Markdown and figures,
and a report's files sort together in a listing.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Iterable, Mapping

from cotsfleet.mission.report_model import MissionReport
from cotsfleet.reporting import markdown, plots
from cotsfleet.reporting.timeline import (
    DEFAULT_SERVICE_S,
    Spots,
    collected_over_time,
    vehicle_segments,
)
from fleet_bus.telemetry import Event

FIGURES = ("priority", "timeline", "link")


def bundle_names(stem: str) -> tuple[str, dict[str, str]]:
    """The Markdown's file name and each figure's, for a report whose JSON is ``stem.json``."""
    return f"{stem}.md", {role: f"{stem}-{role}.png" for role in FIGURES}


def as_events(events: Iterable[Any] | None) -> list[Event]:
    """`Event` records, whether given as records or as ``events.jsonl`` dicts (raises
    ValueError for a dict that is not an event)."""
    out = []
    for e in events or ():
        if isinstance(e, Event):
            out.append(e)
        elif isinstance(e, Mapping):
            out.append(_event(e))
        else:
            raise ValueError(f"not an event: {e!r}")
    return out


def _event(doc: Mapping[str, Any]) -> Event:
    try:
        tasks = doc.get("tasks") or []
        if not isinstance(tasks, list) or not all(isinstance(t, int) for t in tasks):
            raise ValueError("tasks must be a list of spot ids")
        return Event(float(doc["t_s"]), str(doc["id"]), str(doc["kind"]), list(tasks),
                     str(doc.get("peer") or ""), str(doc.get("detail") or ""))
    except KeyError as exc:
        raise ValueError(f"an event needs {exc}") from None
    except (TypeError, ValueError) as exc:
        raise ValueError(f"not an event: {exc}") from None


def read_events(path: str | Path) -> list[Event]:
    """``events.jsonl``: one event per line (raises ValueError naming the bad line)."""
    events = []
    for n, line in enumerate(Path(path).read_text(encoding="utf-8").splitlines(), start=1):
        if not line.strip():
            continue
        try:
            doc = json.loads(line)
        except json.JSONDecodeError as exc:
            raise ValueError(f"{path}:{n}: not JSON: {exc.msg}") from None
        if not isinstance(doc, dict):
            raise ValueError(f"{path}:{n}: an event must be an object")
        try:
            events.append(_event(doc))
        except ValueError as exc:
            raise ValueError(f"{path}:{n}: {exc}") from None
    return events


def write_report_bundle(report: MissionReport, out_dir: Path,
                        events: Iterable[Any] | None = None,
                        scenario: Mapping[str, Any] | None = None,
                        stem: str = "report") -> list[Path]:
    """Write ``stem.md`` and its figures into ``out_dir``; return the paths written.

    ``events`` (`Event` records or dicts) give the timeline, priority over time and what
    happened; without them only the link figure is drawn. ``scenario`` (the mission's
    scenario document) gives each spot's priority, the real reef and injection times and
    each battery; without it the priority plot counts spots and injections are assumed to
    last 75 s. Figures are drawn with matplotlib's Agg canvas: no display needed. Raises
    `ScenarioError` for a scenario document that cannot be read."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    md_name, names = bundle_names(stem)
    events = as_events(events)
    spots = Spots.of_scenario(scenario)
    notes: list[str] = []
    figures: dict[str, str] = {}
    segments = None
    if events:
        plots.priority_over_time(collected_over_time(events, spots), report,
                                 out_dir / names["priority"])
        segments = vehicle_segments(report, events, spots)
        plots.vehicle_timeline(segments, report, out_dir / names["timeline"])
        figures.update(priority=names["priority"], timeline=names["timeline"])
    else:
        notes.append("no event log was given: the timeline, priority-over-time and what "
                     "happened need it (events.jsonl in a run directory)")
    if events and not spots.known:
        notes.append("no scenario was given: the plot counts spots instead of priority, and "
                     f"every injection is assumed to last {DEFAULT_SERVICE_S:g} s")
    if report.messages.link or report.messages.link_by_sender:
        plots.link_deliveries(report.messages, out_dir / names["link"])
        figures["link"] = names["link"]
    text = markdown.render(report, segments, spots, figures, notes, events)
    md = out_dir / md_name
    md.write_text(text, encoding="utf-8")
    return [md, *(out_dir / name for name in figures.values())]
