"""Reports a person reads: a mission's Markdown with matplotlib figures, named after its JSON
(``r.json``: ``r.md``, ``r-*.png``), and a Markdown summary (medians, quartiles, per-seed rows)
for a sweep of missions (``X.json``: ``X.md``, ``X.csv``).

``write_report_bundle(report, out_dir, events=None, scenario=None, stem="report")`` and
``write_sweep_summary(runs, out_dir, stem="sweep")``; reports are the typed tree of
`cotsfleet.mission.report_model`. See docs/reports.md.
"""

from __future__ import annotations

import importlib
from typing import Any

# Loaded on first use: the bundle draws with matplotlib (some 30 MB), which a sweep worker or a
# process reading only `reporting.sweep`'s tables must not carry.
_HOMES = {"read_events": "bundle", "write_report_bundle": "bundle",
          "write_sweep_summary": "sweep"}

__all__ = ["read_events", "write_report_bundle", "write_sweep_summary"]


def __getattr__(name: str) -> Any:
    if name not in _HOMES:
        raise AttributeError(f"module 'cotsfleet.reporting' has no attribute {name!r}")
    return getattr(importlib.import_module(f"cotsfleet.reporting.{_HOMES[name]}"), name)
