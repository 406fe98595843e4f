"""The rule of the tree (docs/architecture.md): who may import whom.

`fleet_agent`, `comms_sim` and `ground_station` are peers: each stands on `fleet_bus` (the
contract) and `hfc_core` (the planner) and never imports another peer; `cotsfleet` wires them
together; `fleet_bus` and `hfc_core` import no project package but themselves, and
`hfc_core` stays pure numpy/scipy. Every import statement is read, at any depth (function-level
imports count too).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PROJECT = ("hfc_core", "fleet_bus", "fleet_agent", "comms_sim", "ground_station", "cotsfleet")
ALLOWED = {
    "hfc_core": {"hfc_core"},
    "fleet_bus": {"fleet_bus"},
    "fleet_agent": {"fleet_agent", "fleet_bus", "hfc_core"},
    "comms_sim": {"comms_sim", "fleet_bus", "hfc_core"},
    "ground_station": {"ground_station", "fleet_bus", "hfc_core"},
    "cotsfleet": set(PROJECT),
}
# The planner is pure computation: no I/O frameworks, no clock, no transport, no viewer.
HFC_CORE_THIRD_PARTY = {"numpy", "scipy"}


def imports_of(package: str) -> list[tuple[Path, int, str]]:
    """(file, line, top-level module) of every import in ``package``."""
    out = []
    for path in sorted((REPO / package).rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                out += [(path, node.lineno, a.name.split(".")[0]) for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                out.append((path, node.lineno, node.module.split(".")[0]))
    return out


@pytest.mark.parametrize("package", PROJECT)
def test_packages_import_only_what_the_rule_allows(package: str) -> None:
    wrong = [f"{p.relative_to(REPO)}:{line} imports {mod}"
             for p, line, mod in imports_of(package)
             if mod in PROJECT and mod not in ALLOWED[package]]
    assert wrong == []


def test_the_planner_stays_pure() -> None:
    stdlib = set(sys.stdlib_module_names)
    wrong = [f"{p.relative_to(REPO)}:{line} imports {mod}"
             for p, line, mod in imports_of("hfc_core")
             if mod not in stdlib and mod not in HFC_CORE_THIRD_PARTY and mod != "hfc_core"]
    assert wrong == []
    io = {"socket", "subprocess", "threading", "asyncio"}  # time: the default of an injected timer
    assert [m for _, _, m in imports_of("hfc_core") if m in io] == []


def test_the_rule_catches_a_peer_import(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The scan itself works: a peer import planted in a copy of a package is found."""
    fake = tmp_path / "ground_station"
    fake.mkdir()
    (fake / "x.py").write_text("def f():\n    from fleet_agent.agent import Agent\n")
    monkeypatch.setattr(sys.modules[__name__], "REPO", tmp_path)
    found = [mod for _, _, mod in imports_of("ground_station")]
    assert found == ["fleet_agent"] and "fleet_agent" not in ALLOWED["ground_station"]


def test_no_class_in_the_agent_is_a_god_object() -> None:
    """The agent is a short step loop over parts with one idea each (issue 10): no class in
    `fleet_agent` spans more than 350 lines."""
    long = []
    for path in sorted((REPO / "fleet_agent").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef) and node.end_lineno - node.lineno + 1 > 350:
                long.append(f"{path.name}:{node.name} {node.end_lineno - node.lineno + 1} lines")
    assert long == []
