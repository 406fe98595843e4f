"""An engine's keyword parameters, checked against its parameter dataclass."""

from __future__ import annotations

from dataclasses import fields
from typing import Any, ClassVar, Protocol, TypeVar


class _Dataclass(Protocol):
    """Any dataclass (what `dataclasses.fields` takes)."""

    __dataclass_fields__: ClassVar[dict[str, Any]]


P = TypeVar("P", bound=_Dataclass)


def engine_params(cls: type[P], params: dict[str, Any]) -> P:
    """``cls(**params)`` for an engine's parameter dataclass, refusing unknown names with
    the list of known ones (a typo must not silently fall back to a default)."""
    known = {f.name for f in fields(cls)}
    unknown = set(params) - known
    if unknown:
        raise ValueError(
            f"unknown {cls.__name__} field(s) {sorted(unknown)}; known: {sorted(known)}")
    return cls(**params)
