"""The report's figures (matplotlib, no pyplot: no global state, no display needed).

Each function draws one PNG and returns nothing; the data comes from `timeline` and the
report, never from the figure, so tests check the data and that the files exist.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

from matplotlib.figure import Figure
from matplotlib.patches import Patch

from cotsfleet.mission.report_model import FaultRow, Messages, MissionReport, drop_reasons
from cotsfleet.reporting.timeline import ACTIVITIES, Collected, Segment

COLOURS = {"transit": "#9ecae1", "inspect": "#fdae6b", "inject": "#31a354", "idle": "#d9d9d9",
           "down": "#de2d26"}
FAULT_MARKERS = {"kill": ("x", "#000000"), "abort": ("v", "#e6550d"),
                 "restart": ("o", "#3182bd"), "partition": ("|", "#756bb1"),
                 "stall": ("s", "#636363")}
DPI = 110


def _minutes(seconds: Sequence[float]) -> list[float]:
    return [s / 60.0 for s in seconds]


def _fault_lines(ax: Any, faults: Sequence[FaultRow]) -> None:
    for f in faults:
        if f.kind in FAULT_MARKERS:
            colour = FAULT_MARKERS[f.kind][1]
            ax.axvline(f.t_s / 60.0, color=colour, lw=0.8, ls=":")
            ax.annotate(f"{f.kind} {f.vid}", (f.t_s / 60.0, 1.0),
                        xycoords=("data", "axes fraction"), rotation=90, va="top", ha="right",
                        fontsize=7, color=colour)


def priority_over_time(collected: Collected, report: MissionReport, path: Path) -> None:
    """Cumulative priority (or spots, without a scenario) of the fleet and of each vehicle:
    the report's figures (`MissionReport.collected`) step by step."""
    fig = Figure(figsize=(8, 4), dpi=DPI, layout="constrained")
    ax = fig.add_subplot()
    c = report.collected
    if collected.priority:
        what = "real priority collected" if collected.on_reef else "priority collected"
        total, total_name = c.priority_of, ("the real reef's total" if collected.on_reef
                                            else "the scenario's total")
    else:
        what, total, total_name = "spots treated", float(c.spots_of), "the scenario's spots"
    end = max(report.end_s, collected.t_s[-1], 1.0)

    def to_end(times: Sequence[float], values: Sequence[float]) -> tuple[list, list]:
        # a step series holds its last value to the end (else its last step is a spike)
        return _minutes([*times, end]), [*values, values[-1]]

    ax.step(*to_end(collected.t_s, collected.values), where="post", color="black", lw=2,
            label="fleet (each spot once)")
    for vid, (times, values) in sorted(collected.by_vehicle.items()):
        ax.step(*to_end(times, values), where="post", lw=1, label=vid)
    ax.set_xlim(0.0, end / 60.0)
    if total:
        ax.axhline(float(total), color="grey", ls="--", lw=1)
        ax.annotate(f"{total_name} {float(total):,.0f}", (0.99, float(total)), fontsize=8,
                    color="dimgrey", va="top", xycoords=("axes fraction", "data"), ha="right")
    _fault_lines(ax, report.faults)
    ax.set_xlabel("mission time (min)")
    ax.set_ylabel(what)
    ax.set_title(f"{what.capitalize()} over time")
    ax.legend(loc="upper left", fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(path)


def vehicle_timeline(segments: Mapping[str, Sequence[Segment]], report: MissionReport,
                     path: Path) -> None:
    """One row per vehicle: what it was doing when, and the faults injected into it."""
    vids = list(segments)
    fig = Figure(figsize=(8, 1.0 + 0.6 * max(1, len(vids))), dpi=DPI, layout="constrained")
    ax = fig.add_subplot()
    present = []
    for row, vid in enumerate(vids):
        for activity in ACTIVITIES:
            bars = [(s.start_s / 60.0, s.duration_s / 60.0) for s in segments[vid]
                    if s.activity == activity]
            if bars:
                # thin white edges keep back-to-back injections apart
                ax.broken_barh(bars, (row - 0.35, 0.7), facecolors=COLOURS[activity],
                               edgecolors="white", linewidth=0.4)
                present += [activity] if activity not in present else []
    for f in report.faults:
        if f.vid in vids and f.kind in FAULT_MARKERS:
            marker, colour = FAULT_MARKERS[f.kind]
            ax.plot(f.t_s / 60.0, vids.index(f.vid), marker=marker, color=colour,
                    markersize=9, markeredgewidth=2, ls="none")
    ax.set_yticks(range(len(vids)), vids)
    ax.set_ylim(len(vids) - 0.5, -0.5)
    ax.set_xlim(0.0, max(report.end_s, 1.0) / 60.0)
    ax.set_xlabel("mission time (min)")
    ax.set_title("What each vehicle did (x kill, v abort, o restart)")
    shown = [a for a in ACTIVITIES if a in present]
    ax.legend(handles=[Patch(color=COLOURS[a], label=a) for a in shown],
              loc="upper center", bbox_to_anchor=(0.5, -0.35 if len(vids) < 3 else -0.2),
              ncol=max(1, len(shown)), fontsize=8, frameon=False)
    ax.grid(axis="x", alpha=0.3)
    fig.savefig(path)


def link_deliveries(messages: Messages, path: Path) -> None:
    """Receptions per sender: delivered and dropped by reason."""
    by_sender = dict(messages.link_by_sender)
    if not by_sender and messages.link:
        by_sender = {"all": messages.link}
    fig = Figure(figsize=(8, 3.2), dpi=DPI, layout="constrained")
    ax = fig.add_subplot()
    senders = sorted(by_sender)
    reasons = sorted({r for row in by_sender.values() for r, n in drop_reasons(row).items()
                      if n})
    left = [0.0] * len(senders)
    palette = ["#31a354", "#de2d26", "#fd8d3c", "#756bb1", "#636363", "#e7298a", "#a6761d",
               "#1f78b4", "#b2df8a"]
    for i, key in enumerate(["delivered", *reasons]):
        values = [float(by_sender[s].get(key, 0)) for s in senders]
        ax.barh(senders, values, left=left, color=palette[i % len(palette)],
                label=key if key == "delivered" else f"dropped: {key}")
        left = [a + b for a, b in zip(left, values)]
    ax.set_xlabel("receptions (one per frame and receiver)")
    ax.set_title("Acoustic link: deliveries and drops by sender")
    ax.legend(fontsize=8, loc="lower right")
    ax.invert_yaxis()
    fig.savefig(path)
