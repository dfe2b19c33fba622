"""The package's shape (docs/architecture.md): one room per concern, one-way imports, small
modules.

The import rules are import-linter contracts in pyproject.toml (``[tool.importlinter]``):
the layers, the maths without I/O, the concerns that know nothing of each other, no cycles.
Here they are run as the test command runs them, and shown to catch a violation planted in
a copy of the package. What import-linter cannot say, the size of a module and of a room,
is checked by hand.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
PACKAGE = REPO / "provider"
MAX_LINES = 600
#: Most modules a package may hold directly: a room one can take in at a glance. The command
#: line and the bench are lists of parallel commands and sections, exempt.
MAX_MODULES = 12
LISTS = {"provider.cli", "provider.bench"}


def _modules() -> dict[str, Path]:
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(REPO).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _lint_imports(cwd: Path, env: dict | None = None) -> subprocess.CompletedProcess:
    exe = Path(sys.executable).with_name("lint-imports")
    if not exe.exists():
        pytest.fail(f"{exe} missing: install the test extra (bash scripts/setup.sh test)")
    return subprocess.run([str(exe), "--no-cache"], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300)


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_module_over_600_lines(name):
    lines = len(MODULES[name].read_text().splitlines())
    assert lines <= MAX_LINES, f"{name} has {lines} lines (limit {MAX_LINES}): split it"


def test_no_room_holds_more_than_12_modules():
    rooms = {}
    for path in PACKAGE.rglob("*.py"):
        if path.name != "__init__.py":
            room = ".".join(path.parent.relative_to(REPO).parts)
            rooms.setdefault(room, []).append(path.stem)
    crowded = {room: len(mods) for room, mods in rooms.items()
               if room not in LISTS and len(mods) > MAX_MODULES}
    assert not crowded, f"more than {MAX_MODULES} modules in one room: {crowded}; group them"
    assert len(rooms["provider.core.geometry"]) >= 5      # the walk sees the tree


def test_every_room_says_what_it_owns():
    # Each package's docstring names its modules and what it may import.
    for path in PACKAGE.rglob("__init__.py"):
        room = ".".join(path.parent.relative_to(REPO).parts)
        text = path.read_text()
        assert text.lstrip().startswith('"""'), f"{room} has no docstring"
        if room.startswith(("provider.core.", "provider.live.")):
            assert "import" in text, f"{room}'s docstring does not say what it may import"


def test_the_import_contracts_hold():
    result = _lint_imports(REPO)
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-2000:]
    kept = [line for line in result.stdout.splitlines() if line.endswith(" KEPT")]
    assert len(kept) >= 5, result.stdout


def test_the_contracts_catch_what_they_forbid(tmp_path):
    # A copy of the package with three planted violations: the maths opening a socket, a
    # product importing another, the maths importing the server.
    shutil.copytree(PACKAGE, tmp_path / "provider", symlinks=True,
                    ignore=shutil.ignore_patterns("__pycache__", "data", "shaders"))
    shutil.copy(REPO / "pyproject.toml", tmp_path / "pyproject.toml")
    plants = {
        "provider/core/geometry/sh.py": "import socket  # planted\n",
        "provider/core/lights/analysis.py": "from ..reflections import prefilter  # planted\n",
        "provider/core/radiometry/images.py": "from ...live.server import service  # planted\n",
    }
    for rel, line in plants.items():
        with open(tmp_path / rel, "a") as f:
            f.write(line)
    env = dict(os.environ, PYTHONPATH=str(tmp_path))
    result = _lint_imports(tmp_path, env)
    assert result.returncode != 0, result.stdout
    out = result.stdout
    assert "provider.core.geometry.sh -> socket" in out, out
    assert "provider.core.lights.analysis -> provider.core.reflections.prefilter" in out, out
    assert "provider.core.radiometry.images -> provider.live.server.service" in out, out
