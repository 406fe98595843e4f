"""Reports a person reads: a mission's Markdown with matplotlib figures, named after its JSON
(``r.json``: ``r.md``, ``r-*.png``), and a Markdown summary (medians, quartiles, per-seed rows)
for a sweep of missions (``X.json``: ``X.md``, ``X.csv``).

``write_report_bundle(report, out_dir, events=None, scenario=None, stem="report")`` and
``write_sweep_summary(runs, out_dir, stem="sweep")``; reports are the typed tree of
`cotsfleet.mission.report_model`. See docs/reports.md.
"""

from cotsfleet.reporting.bundle import read_events, write_report_bundle
from cotsfleet.reporting.sweep import write_sweep_summary

__all__ = ["read_events", "write_report_bundle", "write_sweep_summary"]
