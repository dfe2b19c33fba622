"""Headless OpenGL for the shader harness and the examples (moderngl + EGL).

:func:`create_context` gives a standalone OpenGL 3.3+ core context without a display:
Mesa's llvmpipe on machines without a GPU, the real GPU where there is one.
"""
from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

SHADER_DIR = Path(__file__).resolve().parent.parent / "shaders"

INSTALL_HINT = ("headless OpenGL needs EGL and a Mesa driver: on Debian/Ubuntu "
                "`sudo apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri`")


class NoOpenGL(RuntimeError):
    """No OpenGL context could be made; the message names what to install."""


def create_context(require: int = 330):
    """A standalone moderngl context (EGL backend), or :class:`NoOpenGL` with a hint."""
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - declared dependency
        raise NoOpenGL(f"moderngl is not installed ({exc}): pip install moderngl") from None
    errors = []
    for kwargs in ({"backend": "egl"}, {}):
        try:
            return moderngl.create_context(standalone=True, require=require, **kwargs)
        except Exception as exc:  # moderngl raises plain Exceptions for missing libraries
            errors.append(f"{kwargs or 'default'}: {exc}")
    raise NoOpenGL(f"cannot create an OpenGL {require // 100}.{require % 100 // 10} context "
                   f"({'; '.join(errors)}). {INSTALL_HINT}")


def shader_source(name: str) -> str:
    """Text of a file in shaders/ (e.g. "sh9_irradiance.glsl")."""
    path = SHADER_DIR / name
    if not path.exists():
        raise FileNotFoundError(f"shader {name} not found in {SHADER_DIR}")
    return path.read_text()


def uv_sphere(segments: int = 64, rings: int = 32):
    """Unit sphere mesh: (positions (N, 3) float32, normals (N, 3), indices (M, 3) uint32)."""
    theta = np.linspace(0, math.pi, rings + 1)
    phi = np.linspace(0, 2 * math.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    pos = np.stack([np.sin(t) * np.sin(p), np.cos(t), -np.sin(t) * np.cos(p)], -1).reshape(-1, 3)
    idx = []
    for r in range(rings):
        for s in range(segments):
            a = r * (segments + 1) + s
            b = a + segments + 1
            idx += [(a, b, a + 1), (a + 1, b, b + 1)]
    pos = pos.astype(np.float32)
    return pos, pos.copy(), np.asarray(idx, np.uint32)
