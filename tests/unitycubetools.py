"""The Unity package's reflection cube as its C# core bakes it (tests/csharp/CubeTest.cs under
Mono), read back for the cube and IBL tests; the `cube_exe` fixture in tests/conftest.py
builds CubeTest.exe once a session."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

from unitytools import CORE, CSHARP, _compile, _mono_tools

ROOT = Path(__file__).resolve().parent.parent
S3 = np.diag([1.0, 1.0, -1.0])     # our wire frame is Unity's with z negated
LEVELS = 7                          # the Unity cube's mips: UNITY_SPECCUBE_LOD_STEPS + 1


def _environment(image: Path, out: Path, size=32, *extra) -> Path:
    """`shlight environment IMAGE -o OUT --size N`: the provider's own file."""
    r = subprocess.run([sys.executable, "-m", "provider.cli", "environment", str(image), "-o", str(out),
                        "--size", str(size), *extra], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    return out


def _run(exe: Path, *args) -> tuple[int, list[dict]]:
    _, mono = _mono_tools()
    r = subprocess.run([mono, str(exe), *map(str, args)], capture_output=True, text=True, timeout=300)
    lines = [json.loads(line) for line in r.stdout.splitlines() if line.startswith("{")]
    assert lines or r.returncode != 0 or args[0] == "halves", r.stderr
    return r.returncode, lines


def bake(exe: Path, ktx: Path, out: Path, rotation=None) -> tuple[dict, list[np.ndarray]]:
    """The Unity cube the package bakes: meta, and levels (6, n, n, 4) float64 (RGBA halves)."""
    args = ["bake", ktx, out] + ([] if rotation is None else list(np.asarray(rotation, float).reshape(9)))
    rc, lines = _run(exe, *args)
    assert rc == 0, lines
    return lines[0], read_unity_cube(out, lines[0]["size"])


def read_unity_cube(path: Path, size: int) -> list[np.ndarray]:
    data = np.fromfile(path, "<f2").astype(np.float64)
    levels, at = [], 0
    for m in range(LEVELS):
        n = max(1, size >> m)
        levels.append(data[at:at + 6 * n * n * 4].reshape(6, n, n, 4))
        at += 6 * n * n * 4
    assert at == len(data)
    return levels


def unity_level_roughness(m: float) -> float:
    """The root of ρ(1.7 − 0.7ρ)·6 = m (Unity's MipmapLevelToPerceptualRoughness)."""
    return (1.7 - math.sqrt(2.89 - 2.8 * m / 6)) / 1.4


def compile_cube_test(out: Path) -> Path:
    """tests/csharp/CubeTest.cs with the package's C# core, built at ``out``."""
    return _compile(out, [*CORE, CSHARP / "CubeTest.cs"])
