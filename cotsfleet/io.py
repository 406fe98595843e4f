"""Loading scenario files (the only file I/O in front of the pure `hfc_core`)."""

from __future__ import annotations

import json
from pathlib import Path

from hfc_core.problem import Problem, ScenarioError
from hfc_core.scenario import problem_from_dict
from hfc_core.top import parse_top


def read_scenario(path: str | Path) -> tuple[Problem, dict | None]:
    """A scenario JSON or a TOP instance (Chao's text format, recognised by its header): the
    problem and, for JSON, its document (which may carry extra fields such as the
    ``cots_map`` the dashboard draws); a TOP instance has no document."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ScenarioError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{path}: cannot read: {exc}") from None
    if text.lstrip().startswith("n "):
        return parse_top(text, name=path.stem), None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ScenarioError(f"{path}: not valid JSON: {exc}") from None
    try:
        return problem_from_dict(doc), doc
    except ScenarioError as exc:
        raise ScenarioError(f"{path}: {exc}") from None
