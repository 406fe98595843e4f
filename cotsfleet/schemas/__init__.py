"""JSON Schemas of the files a user writes, and one-line messages when a file breaks them.

``scenario`` (scenario JSON), ``agent`` (agent config TOML) and ``channel`` (acoustic channel
TOML/JSON). The schemas give structure and name the offending field by its path
(``tasks[3].pos``); the packages that read the documents keep the semantic checks.
"""

from __future__ import annotations

import json
from functools import lru_cache
from importlib import resources
from typing import Any

from jsonschema import Draft202012Validator
from jsonschema.exceptions import ValidationError, best_match

SCHEMAS = ("scenario", "agent", "channel")


class SchemaViolation(ValueError):
    """A document that does not fit its schema; ``path`` names the field (``""``: the root)."""

    def __init__(self, path: str, message: str) -> None:
        super().__init__(f"{path}: {message}" if path else message)
        self.path = path


@lru_cache(maxsize=None)
def schema(name: str) -> dict[str, Any]:
    """The JSON Schema ``name`` (one of `SCHEMAS`)."""
    if name not in SCHEMAS:
        raise KeyError(f"no schema {name!r}; known: {', '.join(SCHEMAS)}")
    text = resources.files(__package__).joinpath(f"{name}.schema.json").read_text("utf-8")
    return json.loads(text)


@lru_cache(maxsize=None)
def _validator(name: str) -> Draft202012Validator:
    return Draft202012Validator(schema(name))


def validate(doc: Any, name: str) -> None:
    """Raise `SchemaViolation` for the most relevant error of ``doc`` against schema ``name``."""
    error = best_match(_validator(name).iter_errors(doc))
    if error is not None:
        raise SchemaViolation(field_path(error), describe(error))


def field_path(error: ValidationError) -> str:
    """``tasks[3].pos`` style path of the offending value."""
    out = ""
    for key in error.absolute_path:
        out += f"[{key}]" if isinstance(key, int) else (f".{key}" if out else str(key))
    return out


def _json_type(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, (int, float)):
        return "number"
    names: dict[type, str] = {dict: "object", list: "array", str: "string"}
    return names.get(type(value), type(value).__name__)


def _short(value: Any, limit: int = 40) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def describe(error: ValidationError) -> str:
    """A short message: what was expected and what was found (never the whole document)."""
    # Any: parts of a JSON document and of its schema
    kind = error.validator
    want: Any = error.validator_value
    got: Any = error.instance
    schema: Any = error.schema
    if kind == "required":
        missing = [k for k in want if isinstance(got, dict) and k not in got]
        return f"missing field {missing[0]!r}" if missing else error.message
    if kind == "type":
        wanted = " or ".join(want) if isinstance(want, list) else want
        return f"expected {wanted}, got {_json_type(got)} {_short(got)}"
    if kind == "additionalProperties":
        allowed = schema.get("properties", {})
        extra = sorted(k for k in got if k not in allowed)
        return f"unknown field(s) {', '.join(map(repr, extra))}; known: {', '.join(allowed)}"
    if kind in ("minimum", "exclusiveMinimum", "maximum", "exclusiveMaximum"):
        op = {"minimum": ">=", "exclusiveMinimum": ">", "maximum": "<=",
              "exclusiveMaximum": "<"}[kind]
        return f"must be {op} {want}, got {_short(got)}"
    if kind in ("minItems", "maxItems"):
        bound = "at least" if kind == "minItems" else "at most"
        return f"needs {bound} {want} item(s), got {len(got)}"
    if kind == "minLength":
        return f"must not be empty, got {_short(got)}"
    if kind == "enum":
        return f"must be one of {', '.join(map(repr, want))}, got {_short(got)}"
    if kind == "pattern":
        return f"{_short(got)} does not have the expected form ({want})"
    return _short(error.message, 160)
