"""Shared by the shader tests: build an evaluator, or skip the test where the HLSL tools are
missing."""
from __future__ import annotations

import os

import pytest


def evaluator_or_skip(make, *args):
    """``make(*args)``; where it needs glslangValidator/spirv-cross and they are missing
    (:class:`~provider.verify.hlsl.HlslToolsMissing`) the test skips, saying what to install
    (SHLIGHT_REQUIRE_HLSL=1: it fails instead)."""
    from provider.verify.hlsl import HlslToolsMissing
    try:
        return make(*args)
    except HlslToolsMissing as exc:
        if os.environ.get("SHLIGHT_REQUIRE_HLSL"):
            raise
        pytest.skip(str(exc))


# ---- the contract vectors: committed against fresh -------------------------------------------------
#
# The cases named below carry the engine's float32 sums over a 512×256 panorama: BLAS and numpy
# pick their summation kernels by CPU (AVX-512, AVX2, SSE, NEON), so these numbers move in their
# last float32 digits from one machine to another (1.5e-7 of an array's largest value measured
# across OpenBLAS's Haswell, SkylakeX and Prescott kernels; a pairwise float32 sum's bound is
# ~log2(N)·2⁻²⁴ ≈ 1e-6 of the sum of magnitudes). Every other case is float64 arithmetic on a few
# numbers (1e-16 measured): they must agree to 1e-12 of their array's scale.
ENGINE_CASES = ("panorama", "lights_panorama", "lights_none")
ENGINE_RTOL = 1e-6
FLOAT64_RTOL = 1e-12


def vectors_mismatches(fresh, committed, where: str = "", rtol: float | None = None) -> list[str]:
    """Where two contract-vector documents (or parts of one) differ: structure and strings
    exactly, each numeric array within ``rtol`` of its largest magnitude (by default, per case:
    ENGINE_RTOL for the engine's cases, FLOAT64_RTOL for the rest)."""
    import numpy as np
    out: list[str] = []
    if isinstance(committed, dict):
        if list(fresh) != list(committed):
            return [f"{where}: keys {list(fresh)} != {list(committed)}"]
        if rtol is None and isinstance(committed.get("name"), str):
            rtol = ENGINE_RTOL if committed["name"].startswith(ENGINE_CASES) else FLOAT64_RTOL
        for k in committed:
            out += vectors_mismatches(fresh[k], committed[k], f"{where}.{k}", rtol)
    elif isinstance(committed, list) and committed and isinstance(committed[0], (dict, str)):
        if len(fresh) != len(committed):
            return [f"{where}: {len(fresh)} items != {len(committed)}"]
        for i, (a, b) in enumerate(zip(fresh, committed)):
            out += vectors_mismatches(a, b, f"{where}[{i}]", rtol)
    elif isinstance(committed, (str, bool)) or committed is None:
        if fresh != committed:
            out.append(f"{where}: {fresh!r} != {committed!r}")
    else:
        a, b = np.asarray(fresh, float), np.asarray(committed, float)
        if a.shape != b.shape:
            return [f"{where}: shape {a.shape} != {b.shape}"]
        tol = (FLOAT64_RTOL if rtol is None else rtol) * max(np.max(np.abs(b), initial=0), 1e-300)
        worst = np.max(np.abs(a - b), initial=0)
        if not worst <= tol:
            out.append(f"{where}: differs by {worst:.3g} (allowed {tol:.3g})")
    return out
