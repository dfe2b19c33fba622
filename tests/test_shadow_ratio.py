"""The shadow a receiver sees (docs/contract.md §10, provider/core/lights/shadows.py): the CPU
ratio's definition, and the shipped ``shShadowRatio`` (GLSL) / ``SHShadowRatio`` (HLSL, through
SPIR-V) against it on a real headless OpenGL context (provider/verify/lights.py).

Without EGL the shader tests skip with the install hint (SHLIGHT_REQUIRE_GL=1 makes that a
failure), without glslangValidator/spirv-cross the HLSL ones skip (SHLIGHT_REQUIRE_HLSL=1).
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from provider.core.geometry import sh
from provider.core.lights.shadows import lit_irradiance, shadow_ratio
from provider.verify import contract, harness, lights

from conftest import HDRI_DIR

ROOT = Path(__file__).resolve().parent.parent
PANORAMAS = sorted(HDRI_DIR.glob("*.exr"))
NORMALS = harness.dense_normals(8192)
TOL = harness.FLOAT32_TOLERANCE


# ---- the definition (CPU) ------------------------------------------------------------------

def test_one_light_without_ambient_gives_its_visibility_where_it_shines():
    """No ambient, one light: the ratio is V where the light falls (n·d > 0) and 1 where it
    does not (no light there to block: the denominator is 0)."""
    d, irr = contract.ONE_SIDED_LIGHT
    n = NORMALS
    r = shadow_ratio(n, np.zeros((3, 4, 4)), d[None], irr[None], [0.3])
    lit = (n @ d) > 1e-9
    assert np.allclose(r[lit], 0.3) and np.all(r[~lit] == 1.0)


def test_the_ratio_is_one_in_the_open_and_the_ambient_share_in_full_shadow():
    """Uniform ambient E_a = 0.1π and one light I: in full shadow the facing normal keeps
    E_a / (E_a + I); visible lights change nothing; ratio within [0, 1] everywhere."""
    A = sh.irradiance_matrices(contract.furnace_coefficients(0.1))
    d, irr = contract.ONE_SIDED_LIGHT
    toward = d[None]
    assert np.allclose(shadow_ratio(toward, A, d[None], irr[None], [1.0]), 1.0)
    got = shadow_ratio(toward, A, d[None], irr[None], [0.0])[0]
    assert np.allclose(got, 0.1 * math.pi / (0.1 * math.pi + irr))
    r = shadow_ratio(NORMALS, A, d[None], irr[None], np.linspace(0, 1, len(NORMALS))[:, None])
    assert r.min() >= 0 and r.max() <= 1 + 1e-12


def test_several_lights_each_count_by_their_own_visibility():
    rng = np.random.default_rng(3)
    dirs = rng.normal(size=(3, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    irr = rng.uniform(1, 5, size=(3, 3))
    A = sh.irradiance_matrices(contract.furnace_coefficients(0.2))
    n = NORMALS[:500]
    V = rng.uniform(size=(len(n), 3))
    num = (np.maximum(sh.irradiance_from_matrices(A, n), 0)
           + sum(V[:, [k]] * np.maximum(n @ dirs[k], 0)[:, None] * irr[k] for k in range(3)))
    den = (np.maximum(sh.irradiance_from_matrices(A, n), 0)
           + sum(np.maximum(n @ dirs[k], 0)[:, None] * irr[k] for k in range(3)))
    assert np.allclose(shadow_ratio(n, A, dirs, irr, V), num / den)
    assert np.allclose(lit_irradiance(n, A, dirs, irr, np.ones(3)), den)


def test_a_ringing_ambient_is_clamped_and_no_light_means_ratio_one():
    """An ambient that rings below 0 counts as no light (as the shaders clamp E): with no
    lights the ratio is exactly 1; with a shadowed light it is never negative."""
    A = -sh.irradiance_matrices(contract.furnace_coefficients(0.1))      # E_a = -0.1π
    d, irr = contract.ONE_SIDED_LIGHT
    assert np.all(shadow_ratio(NORMALS, A, np.zeros((0, 3)), np.zeros((0, 3)), []) == 1.0)
    r = shadow_ratio(NORMALS, A, d[None], irr[None], [0.0])
    assert r.min() >= 0.0


@pytest.mark.parametrize("v", [[-0.1], [1.5], [math.nan]])
def test_a_visibility_outside_zero_one_is_refused(v):
    d, irr = contract.ONE_SIDED_LIGHT
    with pytest.raises(ValueError, match="fraction"):
        shadow_ratio(NORMALS[:4], np.zeros((3, 4, 4)), d[None], irr[None], v)


# ---- the shaders ---------------------------------------------------------------------------

@pytest.fixture(scope="module", params=["glsl", "hlsl"])
def evaluator(request, ctx):
    from provider.verify.hlsl import HlslToolsMissing
    try:
        return lights.ShadowEvaluator(ctx, request.param)
    except HlslToolsMissing as exc:
        if os.environ.get("SHLIGHT_REQUIRE_HLSL"):
            raise
        pytest.skip(str(exc))


def test_every_shadow_case_matches_the_cpu_to_float32_rounding(evaluator):
    """One-sided light, four lights, two of four slots, a panorama's lights, each at every
    visibility (open, shadowed, mixed, out of range: clamped)."""
    cases = lights.shadow_cases(NORMALS, PANORAMAS)
    results = lights.run_shadow_cases(evaluator, cases, NORMALS)
    names = {r.case for r in results}
    assert {"shadow:one_sided:mixed", "shadow:4_random:clamped",
            "shadow:count_2_of_4:shadowed", "shadow:panorama:apartment:mixed"} <= names
    failed = [r.line() for r in results if not r.passed]
    assert not failed, "\n".join(failed)
    assert 0 < max(r.max_rel for r in results) < TOL


def test_the_shadow_on_the_lit_side_is_the_visibility(evaluator):
    """No ambient, the one-sided light, visibility 0.3 for light 0: the GPU gives 0.3 toward
    the light and exactly 1 away from it, on both paths."""
    d, irr = contract.ONE_SIDED_LIGHT
    evaluator.visibility = np.array([0.3, 0.0, 0.0, 0.0], np.float32)
    evaluator.set_lights(d[None], irr[None])
    ratio, _ = evaluator.evaluate(np.zeros((3, 4, 4)), [d, -d])
    assert np.allclose(ratio[0], 0.3, atol=1e-6) and np.all(ratio[1] == 1.0)


def test_the_harness_catches_a_swapped_visibility(ctx):
    """Negative control: the visibilities of lights 0 and 1 swapped fails the comparison."""
    glsl = lights.ShadowEvaluator(ctx, "glsl")
    case, _, v = next(c for c in lights.shadow_cases(NORMALS, [])
                      if c[0].name == "shadow:4_random:mixed")
    glsl.visibility = np.asarray([v[1], v[0], v[2], v[3]], np.float32)
    glsl.set_lights(case.directions, case.irradiance, case.count)
    ratio, _ = glsl.evaluate(case.matrices, NORMALS)
    assert not lights.compare_shadow(case, v, "glsl", ratio, NORMALS).passed


def test_validate_shaders_checks_the_shadow_ratio_on_both_paths(ctx, tmp_path):
    r = subprocess.run([sys.executable, "-m", "provider.cli", "validate-shaders",
                        str(HDRI_DIR / "lab.exr"), "--normals", "1024", "--no-pictures",
                        "--out", str(tmp_path)], capture_output=True, text=True, timeout=180,
                       cwd=ROOT)
    assert r.returncode == 0, r.stdout + r.stderr
    for path in ("glsl", "hlsl"):
        for case in ("shadow:one_sided:mixed", "shadow:panorama:lab:clamped"):
            assert f"PASS  {path}  {case}" in r.stdout, (path, case)
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["failed"] == 0
