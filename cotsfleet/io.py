"""Reading the files a user hands the CLI (the only file I/O in front of the pure `hfc_core`).

Every reader fails with one line naming the file and, for a document that breaks its schema
(`cotsfleet.schemas`), the path of the offending field: a scenario raises `ScenarioError`,
everything else `UsageError`; both end as exit code 2 without a traceback.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cotsfleet.errors import UsageError
from cotsfleet.schemas import SchemaViolation, validate
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.formats.top import parse_top
from hfc_core.model.errors import ScenarioError
from hfc_core.model.problem import Problem
from reef_sim.navigation import navigation_from_doc
from reef_sim.truth import reef_from_doc

if TYPE_CHECKING:
    from comms_sim.config import ChannelConfig
    from fleet_agent.config import AgentConfig


def read_text(path: str | Path, error: type[Exception] = UsageError) -> str:
    """The file's text, or ``error`` saying in one line why not."""
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise error(f"{path}: no such file") from None
    except IsADirectoryError:
        raise error(f"{path}: is a directory, not a file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{path}: cannot read: {exc}") from None


def read_json(path: str | Path, error: type[Exception] = UsageError) -> Any:
    try:
        return json.loads(read_text(path, error))
    except json.JSONDecodeError as exc:
        raise error(f"{path}: not valid JSON: {exc}") from None


def read_toml(path: str | Path) -> dict[str, Any]:
    try:
        return tomllib.loads(read_text(path))
    except tomllib.TOMLDecodeError as exc:
        raise UsageError(f"{path}: not valid TOML: {exc}") from None


def check_schema(doc: Any, name: str, path: str | Path,
                 error: type[Exception] = UsageError) -> None:
    """`cotsfleet.schemas.validate` with the file's name in front of the message."""
    try:
        validate(doc, name)
    except SchemaViolation as exc:
        raise error(f"{path}: {exc}") from None


def read_scenario(path: str | Path) -> tuple[Problem, dict | None]:
    """A scenario JSON or a TOP instance (Chao's text format, recognised by its header): the
    problem and, for JSON, its document (which may carry extra fields such as the
    ``cots_map`` the dashboard draws); a TOP instance has no document."""
    path = Path(path)
    text = read_text(path, ScenarioError)
    if text.lstrip().startswith("n "):
        return parse_top(text, name=path.stem), None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ScenarioError(f"{path}: not valid JSON: {exc}") from None
    check_schema(doc, "scenario", path, ScenarioError)
    try:
        problem = problem_from_dict(doc)
        reef_from_doc(doc, problem)  # the hidden reef (simulation only): refuse a bad one here
        navigation_from_doc(doc)  # and the simulated vehicles' navigation error
        return problem, doc
    except ScenarioError as exc:
        raise ScenarioError(f"{path}: {exc}") from None


def read_agent_config(path: str | Path) -> "AgentConfig":
    """An agent config TOML (a flat table or an ``[agent]`` table), checked."""
    from fleet_agent.config import config_from_dict

    doc = read_toml(path)
    table = doc.get("agent", doc)
    check_schema(table, "agent", path)
    try:
        return config_from_dict(table)
    except (TypeError, ValueError) as exc:
        raise UsageError(f"{path}: {exc}") from None


def read_channel_config(path: str | Path) -> "ChannelConfig":
    """An acoustic channel config, ``.toml`` or ``.json``, checked."""
    from comms_sim.config import config_from_dict

    path = Path(path)
    if path.suffix not in (".toml", ".json"):
        raise UsageError(f"{path}: a channel config must be .toml or .json")
    doc = read_toml(path) if path.suffix == ".toml" else read_json(path)
    check_schema(doc, "channel", path)
    try:
        return config_from_dict(doc)
    except (TypeError, ValueError) as exc:
        raise UsageError(f"{path}: {exc}") from None
