"""The rule of the tree (docs/architecture.md): who may import whom, and no circles.

`fleet_agent`, `comms_sim` and `ground_station` are peers: each stands on `fleet_bus` (the
contract) and `hfc_core` (the planner) and never imports another peer; `cotsfleet` wires them
together; `fleet_bus` and `hfc_core` import no project package but themselves, and
`hfc_core` stays pure numpy/scipy. `reef_sim` (the simulated world) stands on `hfc_core` and
`fleet_bus`; the planner never imports it. Inside `hfc_core` the model imports no engine and no
entry point. Every import statement is read, at any depth (function-level imports and imports
for type checking count too), and so is every ``importlib.import_module`` of a string.
"""

from __future__ import annotations

import ast
import functools
import sys
from pathlib import Path
from typing import Collection, Mapping, Sequence

import pytest

REPO = Path(__file__).resolve().parents[1]
PROJECT = ("hfc_core", "fleet_bus", "fleet_agent", "comms_sim", "ground_station", "cotsfleet",
           "reef_sim")
ALLOWED = {
    "hfc_core": {"hfc_core"},
    "fleet_bus": {"fleet_bus"},
    "reef_sim": {"reef_sim", "hfc_core", "fleet_bus"},
    # Only the agent's shell (its process, its helms) binds the simulated world: the decision
    # logic never imports it (`test_the_agents_decisions_never_see_the_simulated_world`).
    "fleet_agent": {"fleet_agent", "fleet_bus", "hfc_core", "reef_sim"},
    "comms_sim": {"comms_sim", "fleet_bus", "hfc_core"},
    "ground_station": {"ground_station", "fleet_bus", "hfc_core", "reef_sim"},  # the COTS map
    "cotsfleet": set(PROJECT),
}
# Inside the planner: module prefix -> the hfc_core modules it may import. The model is the
# bottom layer; formats read documents into it; engines share only the stop and the result
# with the entry points (`hfc_core.solve`, `hfc_core.replan`), which may import anything.
HFC_LAYERS = {
    "hfc_core.model": ("hfc_core.model",),
    "hfc_core.formats": ("hfc_core.model", "hfc_core.formats"),
    "hfc_core.stop": (),
    "hfc_core.result": ("hfc_core.model",),
    "hfc_core.engines": ("hfc_core.model", "hfc_core.engines", "hfc_core.stop",
                         "hfc_core.result"),
}
# Packages whose module graph must have no circle (benchmarks: it holds the bound's package).
ACYCLIC = (*PROJECT, "benchmarks")
# Circles being removed elsewhere. Each entry fails the test once its circle is gone, so it
# cannot outlive the fix (none today).
KNOWN_CIRCLES: dict[str, list[set[str]]] = {}
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


# The agent's shell: where a vehicle (simulated or real) is chosen and bound to the agent.
AGENT_SHELL = ("fleet_agent/helms/", "fleet_agent/node.py", "fleet_agent/__main__.py",
               "fleet_agent/onboard.py", "fleet_agent/options.py")


def test_the_agents_decisions_never_see_the_simulated_world() -> None:
    """The decision logic learns its vehicle only through the vehicle port: it imports
    neither the simulated world nor a helm (issue 27: no simulated vehicle in the agent)."""
    wrong = []
    for path in sorted((REPO / "fleet_agent").rglob("*.py")):
        rel = path.relative_to(REPO).as_posix()
        if rel.startswith(AGENT_SHELL):
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=rel)
        for node in ast.walk(tree):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module] if isinstance(node, ast.ImportFrom) and node.module else []
            wrong += [f"{rel}:{node.lineno} imports {n}" for n in names
                      if n.split(".")[0] == "reef_sim" or n.startswith("fleet_agent.helms")]
    assert wrong == []


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


def test_the_planner_is_layered() -> None:
    """The model imports no engine and no entry point; engines no entry point (`solve`,
    `replan`): what they share with them is the stop and the result."""
    graph = import_graph(["hfc_core"])
    wrong = []
    for module, targets in graph.items():
        layer = next((p for p in HFC_LAYERS if module == p or module.startswith(p + ".")), None)
        if layer is None:
            continue
        allowed = HFC_LAYERS[layer]
        wrong += [f"{module} imports {t}" for t in sorted(targets)
                  if not any(t == a or t.startswith(a + ".") for a in allowed)]
    assert wrong == []


# --- circles -----------------------------------------------------------------------------------
def modules_of(packages: Sequence[str]) -> dict[str, Path]:
    """Dotted module name -> file, for every module of ``packages``."""
    out = {}
    for package in packages:
        for path in sorted((REPO / package).rglob("*.py")):
            parts = path.relative_to(REPO).with_suffix("").parts
            out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def _import_module_arg(node: ast.Call) -> ast.expr | None:
    """The first argument of an ``importlib.import_module(...)`` or ``import_module(...)``."""
    func = node.func
    name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", None)
    return node.args[0] if name == "import_module" and node.args else None


def imported_names(path: Path, module: str, modules: Collection[str]) -> set[str]:
    """Project modules ``module`` (at ``path``) imports: statements at any depth, and
    ``import_module`` of a string literal or of an f-string (every module its constant prefix
    names). ``from p import x`` imports the module ``p.x`` if there is one, else ``p``."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*up, *([base] if base else [])])
            found |= {f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base
                      for a in node.names}
        elif isinstance(node, ast.Call) and (arg := _import_module_arg(node)) is not None:
            if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                found.add(arg.value)
            elif isinstance(arg, ast.JoinedStr) and arg.values and isinstance(
                    arg.values[0], ast.Constant):
                found |= {m for m in modules if m.startswith(str(arg.values[0].value))}
    return {m for m in found if m in modules and m != module}


def import_graph(packages: Sequence[str]) -> dict[str, set[str]]:
    modules = modules_of(packages)
    return {m: imported_names(path, m, modules) for m, path in modules.items()}


def circles(graph: Mapping[str, set[str]]) -> list[set[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[set[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, targets = work[-1]
            nxt = next((t for t in targets if t not in index or t in on_stack), None)
            if nxt is not None and nxt not in index:
                index[nxt] = low[nxt] = len(index)
                stack.append(nxt)
                on_stack.add(nxt)
                work.append((nxt, iter(sorted(graph[nxt]))))
            elif nxt is not None:
                low[node] = min(low[node], index[nxt])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = set()
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.add(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        out.append(component)
    return out


@functools.cache
def _project_circles() -> list[set[str]]:
    return circles(import_graph(ACYCLIC))


@pytest.mark.parametrize("package", ACYCLIC)
def test_no_import_circles(package: str) -> None:
    """No module of any package reaches itself through imports, counting function-level and
    type-checking imports and `importlib` (a circle is a cut in the wrong place: the thing
    both sides need belongs in a module of its own)."""
    found = [c for c in _project_circles() if any(
        m == package or m.startswith(package + ".") for m in c)]
    assert sorted(map(sorted, found)) == sorted(map(sorted, KNOWN_CIRCLES.get(package, [])))


def test_the_circle_scan_sees_through_importlib(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """The scan itself works: circles planted through a function-level import, through
    ``importlib.import_module`` of a literal and of an f-string are all found."""
    pkg = tmp_path / "pkg"
    (pkg / "commands").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "cli.py").write_text("import importlib\n\nclass UsageError(Exception): ...\n\n"
                                "def load(name):\n"
                                "    return importlib.import_module(f'pkg.commands.{name}')\n")
    (pkg / "commands" / "__init__.py").write_text("")
    (pkg / "commands" / "plan.py").write_text("from pkg.cli import UsageError\n")
    (pkg / "solve.py").write_text("import importlib\nENGINE = importlib.import_module('pkg.ga')\n")
    (pkg / "ga.py").write_text("def f():\n    from pkg.solve import ENGINE\n")
    (pkg / "leaf.py").write_text("from . import ga\n")
    monkeypatch.setattr(sys.modules[__name__], "REPO", tmp_path)
    found = sorted(map(sorted, circles(import_graph(["pkg"]))))
    assert found == [["pkg.cli", "pkg.commands.plan"], ["pkg.ga", "pkg.solve"]]
    assert import_graph(["pkg"])["pkg.leaf"] == {"pkg.ga"}
