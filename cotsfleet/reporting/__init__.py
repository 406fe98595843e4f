"""Reports a person reads: ``report.md`` with matplotlib figures for one mission, and a
Markdown summary (medians, quartiles, per-seed rows) for a sweep of missions.

``write_report_bundle(report, out_dir, events=None, scenario=None)`` and
``write_sweep_summary(reports, out_dir)``; the report format is
`cotsfleet.mission.report.build_report`'s. See docs/reports.md.
"""

from cotsfleet.reporting.bundle import read_events, write_report_bundle
from cotsfleet.reporting.sweep import write_sweep_summary

__all__ = ["read_events", "write_report_bundle", "write_sweep_summary"]
