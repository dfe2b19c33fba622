"""The package's shape (docs/architecture.md): layers, one-way imports, small modules.

Imports are read from the source with ``ast``, including those inside functions (a lazy
import is still a dependency), so a layer cannot reach upward by hiding an import in a
function body.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "provider"
MAX_LINES = 600

#: Each layer may import only from layers of a lower or equal rank (and its own).
RANK = {"core": 0, "live": 1, "verify": 2, "bench": 3, "cli": 4}
#: Modules the maths must never use: it does no networking, threading or asyncio.
NOT_IN_CORE = {"asyncio", "socket", "threading", "websockets", "urllib", "http", "ssl",
               "subprocess", "moderngl", "glfw"}


def _modules() -> dict[str, Path]:
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _imports(name: str, path: Path) -> set[str]:
    """Absolute names of everything ``name`` imports (provider modules resolved)."""
    tree = ast.parse(path.read_text(), str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            found.add(mod)
            for alias in node.names:       # `from . import sh` imports a module
                if f"{mod}.{alias.name}" in MODULES:
                    found.add(f"{mod}.{alias.name}")
    return found


IMPORTS = {name: _imports(name, path) for name, path in MODULES.items()}


def _layer(name: str) -> str | None:
    parts = name.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in RANK else None


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_module_over_600_lines(name):
    lines = len(MODULES[name].read_text().splitlines())
    assert lines <= MAX_LINES, f"{name} has {lines} lines (limit {MAX_LINES}): split it"


def test_layers_import_only_downward():
    wrong = []
    for name, imported in IMPORTS.items():
        layer = _layer(name)
        if layer is None:
            continue
        for target in imported:
            other = _layer(target) if target.startswith("provider.") else None
            if other is not None and RANK[other] > RANK[layer]:
                wrong.append(f"{name} imports {target} ({layer} -> {other})")
    assert not wrong, "\n".join(wrong)


def test_the_maths_does_no_io_and_knows_no_service():
    wrong = []
    for name, imported in IMPORTS.items():
        if _layer(name) != "core":
            continue
        for target in imported:
            top = target.split(".")[0]
            if top in NOT_IN_CORE or (top == "provider" and _layer(target) != "core"
                                      and target != "provider"):
                wrong.append(f"{name} imports {target}")
    assert not wrong, "\n".join(wrong)


def test_no_import_cycles():
    graph = {name: {t for t in imported if t in MODULES and t != name}
             for name, imported in IMPORTS.items()}
    # A package's __init__ is imported on the way to its modules: not an edge back.
    for name in graph:
        graph[name] = {t for t in graph[name] if not name.startswith(t + ".")}
    state, stack, cycles = {}, [], []

    def visit(node):
        state[node] = "open"
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == "open":
                cycles.append(" -> ".join(stack[stack.index(nxt):] + [nxt]))
            elif nxt not in state:
                visit(nxt)
        stack.pop()
        state[node] = "done"

    for node in sorted(graph):
        if node not in state:
            visit(node)
    assert not cycles, "import cycles:\n" + "\n".join(cycles)


def test_the_checks_see_the_package():
    # Guards the checks above against passing on an empty or misread tree.
    assert {"provider.core.engine", "provider.live.server", "provider.verify.harness",
            "provider.bench", "provider.cli"} <= set(MODULES)
    assert "provider.core.sh" in IMPORTS["provider.core.engine"]
    assert "provider.core.errors" in IMPORTS["provider.live.capture"]
