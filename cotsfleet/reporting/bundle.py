"""Write a mission's report bundle: ``report.md`` and its PNG figures, next to ``report.json``."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any, Iterable, Mapping

from cotsfleet.reporting import markdown, plots
from cotsfleet.reporting.timeline import (DEFAULT_SERVICE_S, Spots, collected_over_time,
                                          vehicle_segments)

FIGURES = {"priority": "priority_over_time.png", "timeline": "vehicle_timeline.png",
           "link": "link.png"}


def event_dicts(events: Iterable[Any] | None) -> list[dict[str, Any]]:
    """Events as dicts, whether given as dicts or as `fleet_bus.telemetry.Event` objects."""
    out = []
    for e in events or ():
        if dataclasses.is_dataclass(e) and not isinstance(e, type):
            out.append(dataclasses.asdict(e))
        elif isinstance(e, Mapping):
            out.append(dict(e))
    return out


def read_events(path: str | Path) -> list[dict[str, Any]]:
    """``events.jsonl``: one event per line (raises ValueError naming the bad line)."""
    events = []
    for n, line in enumerate(Path(path).read_text(encoding="utf-8").splitlines(), start=1):
        if not line.strip():
            continue
        try:
            event = json.loads(line)
        except json.JSONDecodeError as exc:
            raise ValueError(f"{path}:{n}: not JSON: {exc.msg}") from None
        if not isinstance(event, dict):
            raise ValueError(f"{path}:{n}: an event must be an object")
        events.append(event)
    return events


def write_report_bundle(report: Mapping[str, Any], out_dir: Path,
                        events: Iterable[Any] | None = None,
                        scenario: Mapping[str, Any] | None = None) -> list[Path]:
    """Write ``report.md`` and the figures into ``out_dir``; return the paths written.

    ``events`` (dicts or `Event` objects) give the timeline and priority over time; without
    them only the link figure is drawn. ``scenario`` (the mission's scenario document) gives
    each spot's priority and injection time and each battery; without it the priority plot
    counts spots and injections are assumed to last 75 s. Figures are drawn with matplotlib's
    Agg canvas: no display needed."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    events = event_dicts(events)
    spots = Spots.of_scenario(scenario)
    notes: list[str] = []
    figures: dict[str, str] = {}
    written: list[Path] = []
    segments = None
    if events:
        collected = collected_over_time(events, spots)
        plots.priority_over_time(collected, report, out_dir / FIGURES["priority"])
        segments = vehicle_segments(report, events, spots)
        plots.vehicle_timeline(segments, report, out_dir / FIGURES["timeline"])
        figures.update(priority=FIGURES["priority"], timeline=FIGURES["timeline"])
    else:
        notes.append("no event log was given: the timeline and priority-over-time figures "
                     "need it (events.jsonl in a run directory)")
    if events and not spots.known:
        notes.append("no scenario was given: the plot counts spots instead of priority, and "
                     f"every injection is assumed to last {DEFAULT_SERVICE_S:g} s")
    messages = report.get("messages")
    if isinstance(messages, Mapping) and (messages.get("link") or
                                          messages.get("link_by_sender")):
        plots.link_deliveries(messages, report.get("link_timeline"), out_dir / FIGURES["link"])
        figures["link"] = FIGURES["link"]
    written += [out_dir / name for name in figures.values()]
    text = markdown.render(report, segments, spots, figures, notes)
    md = out_dir / "report.md"
    md.write_text(text, encoding="utf-8")
    return [md, *written]
