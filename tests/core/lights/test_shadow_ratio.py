"""The shadow a receiver sees (docs/contract.md §10, provider/core/lights/shadows.py): the CPU
ratio's definition, and the shipped ``shShadowRatio`` (GLSL) / ``SHShadowRatio`` (HLSL, through
SPIR-V) against it on a real headless OpenGL context (provider/verify/lights.py).

Without EGL the shader tests skip with the install hint (SHLIGHT_REQUIRE_GL=1 makes that a
failure), without glslangValidator/spirv-cross the HLSL ones skip (SHLIGHT_REQUIRE_HLSL=1).
"""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from provider.core.geometry import sh
from provider.core.lights.shadows import (ambient_radiance, cap_projected_solid_angle,
                                          lit_irradiance, occluded_ambient, shadow_ratio)
from provider.verify import contract, harness, lights

from conftest import HDRI_DIR
from shadertools import evaluator_or_skip

ROOT = Path(__file__).resolve().parents[3]
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


# ---- the occluder's ambient occlusion (CPU) ------------------------------------------------

def test_the_ambient_radiance_from_the_matrices_is_the_sh9_radiance():
    """L_a(d) recovered from the irradiance matrices alone equals Σ L_lm Y_lm(d) of the
    coefficients they were built from (to the matrices' 6-digit constants)."""
    L = np.random.default_rng(5).normal(size=(9, 3))
    d = NORMALS[:2000]
    got = ambient_radiance(sh.irradiance_matrices(L), d)
    assert np.abs(got - sh.sh_basis(d) @ L).max() < 1e-5 * np.abs(L).sum()


@pytest.mark.parametrize("sin_half", [0.2, 1 / 3, 0.7, 0.95, 1.0])
def test_the_cap_projected_solid_angle_is_the_integral_over_the_cap(sin_half):
    """∫_cap max(0, n·ω) dω by summing 2 million evenly spread directions, for the cap's axis
    above, across and below the receiver's horizon (the horizon-cut formula included)."""
    w = harness.dense_normals(2_000_000).astype(np.float64)
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    cos_a = math.sqrt(1 - sin_half ** 2)
    n = np.array([0.0, 1.0, 0.0])
    for theta in (0, 30, 60, 80, 88, 90, 95, 110, 150, 180):
        t = math.radians(theta)
        d = np.array([math.sin(t), math.cos(t), 0.0])
        brute = 4 * math.pi * np.mean(np.maximum(w @ n, 0) * ((w @ d) >= cos_a))
        got = float(cap_projected_solid_angle(math.cos(t), sin_half))
        assert got == pytest.approx(brute, abs=2e-3 * math.pi), (theta, got, brute)
    above = float(cap_projected_solid_angle(0.9, sin_half)) if sin_half < 0.9 else None
    if above is not None:
        assert above == pytest.approx(math.pi * sin_half ** 2 * 0.9, rel=1e-12)


def test_under_a_sphere_in_a_uniform_room_the_ratio_is_one_minus_sin_squared():
    """Uniform radiance 1, no lights, a sphere straight above a floor (sin α = R/|c − p|):
    the floor loses π sin²α of its π, ratio 1 − sin²α; with occluded_ambient=None, 1."""
    A = sh.irradiance_matrices(contract.furnace_coefficients())
    up = np.array([[0.0, 1.0, 0.0]])
    none = (np.zeros((0, 3)), np.zeros((0, 3)), [])
    for s in (0.1, 1 / 3, 0.6):
        o = occluded_ambient(up, A, [0.0, 1.0, 0.0], s)
        assert np.allclose(o, math.pi * s * s, rtol=1e-5)
        assert np.allclose(shadow_ratio(up, A, *none, occluded_ambient=o), 1 - s * s, rtol=1e-5)
    assert np.all(shadow_ratio(up, A, *none) == 1.0)
    # a sphere below the floor's horizon hides nothing of it
    assert np.all(occluded_ambient(up, A, [0.0, -1.0, 0.0], 0.5) == 0.0)


def test_the_occluded_ratio_stays_in_zero_one_and_keeps_the_lights():
    """An occluded ambient larger than the ambient takes it to 0, never below; the lights'
    share is untouched (a shadowed light and a fully occluded ambient give 0, a visible
    light its share)."""
    A = sh.irradiance_matrices(contract.furnace_coefficients(0.1))
    d, irr = contract.ONE_SIDED_LIGHT
    toward = d[None]
    huge = np.full((1, 3), 1e3)
    assert np.allclose(shadow_ratio(toward, A, d[None], irr[None], [0.0], huge), 0.0)
    got = shadow_ratio(toward, A, d[None], irr[None], [1.0], huge)[0]
    assert np.allclose(got, irr / (0.1 * math.pi + irr))
    o = occluded_ambient(NORMALS, A, d, 0.5)
    r = shadow_ratio(NORMALS, A, d[None], irr[None], [0.4], o)
    assert r.min() >= 0 and r.max() <= 1 + 1e-12


@pytest.mark.parametrize("bad", [{"sin_half_angle": -0.1}, {"sin_half_angle": math.nan},
                                 {"occluded": -1.0}, {"occluded": math.inf}])
def test_a_bad_occluder_is_refused(bad):
    A = sh.irradiance_matrices(contract.furnace_coefficients())
    d, irr = contract.ONE_SIDED_LIGHT
    with pytest.raises(ValueError):
        if "sin_half_angle" in bad:
            occluded_ambient(NORMALS[:4], A, d, bad["sin_half_angle"])
        else:
            shadow_ratio(NORMALS[:4], A, d[None], irr[None], [1.0],
                         np.full((4, 3), bad["occluded"]))


# ---- the shaders ---------------------------------------------------------------------------

@pytest.fixture(scope="module", params=["glsl", "hlsl"])
def evaluator(request, ctx):
    return evaluator_or_skip(lights.ShadowEvaluator, ctx, request.param)


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


@pytest.fixture(scope="module", params=["glsl", "hlsl"])
def shader_path(request, ctx):
    evaluator_or_skip(lights.OccludedEvaluator, ctx, request.param, "ambient")
    return request.param


def test_every_occluder_case_matches_the_cpu(ctx, shader_path):
    """shOccludedAmbient / SHOccludedAmbient and the occluded ratio against the CPU for
    occluders overhead, wide and tilted, and around the receiver, over a random ambient with
    four lights and a panorama's (every receiver horizon crossed by the dense normals)."""
    cases = lights.occluded_cases(NORMALS, PANORAMAS)
    results = lights.run_occluded_cases(ctx, shader_path, cases, NORMALS)
    names = {r.case for r in results}
    assert {"shadow:occluded_ambient:4_random:tilted_wide",
            "shadow:occluded_ratio:panorama:apartment:overhead",
            "shadow:occluded_ratio:4_random:inside"} <= names
    failed = [r.line() for r in results if not r.passed]
    assert not failed, "\n".join(failed)


def test_the_gpu_floor_under_a_sphere_in_a_uniform_room_keeps_one_minus_sin_squared(ctx, shader_path):
    """Independent answer: uniform radiance 1, no lights, sphere straight overhead at
    sin α = 1/3: the floor's ratio is 8/9 on the GPU too; facing away from it, 1."""
    ev = lights.OccludedEvaluator(ctx, shader_path, "ratio")
    ev.occluder = np.array([0.0, 1.0, 0.0, 1 / 3], np.float32)
    ev.set_lights(np.zeros((0, 3)), np.zeros((0, 3)))
    A = sh.irradiance_matrices(contract.furnace_coefficients())
    ratio, _ = ev.evaluate(A, [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]])
    assert np.allclose(ratio[0], 8 / 9, atol=1e-5) and np.allclose(ratio[1], 1.0, atol=1e-6)


def test_the_harness_catches_a_wrong_occluder_size(ctx):
    """Negative control: rendered with sin α = 0.3 but judged as 1/3 fails."""
    case, what, occluder, v = next(c for c in lights.occluded_cases(NORMALS, [])
                                   if c[0].name == "shadow:occluded_ambient:4_random:overhead")
    ev = lights.OccludedEvaluator(ctx, "glsl", what)
    ev.occluder = np.array([0.0, 1.0, 0.0, 0.3], np.float32)
    ev.set_lights(case.directions, case.irradiance, case.count)
    value, _ = ev.evaluate(case.matrices, NORMALS)
    assert not lights.compare_occluded(case, occluder, v, what, "glsl", value, NORMALS).passed


def test_validate_shaders_checks_the_shadow_ratio_on_both_paths(ctx, tmp_path):
    r = subprocess.run([sys.executable, "-m", "provider.cli", "validate-shaders",
                        str(HDRI_DIR / "lab.exr"), "--normals", "1024", "--no-pictures",
                        "--out", str(tmp_path)], capture_output=True, text=True, timeout=180,
                       cwd=ROOT)
    assert r.returncode == 0, r.stdout + r.stderr
    for path in ("glsl", "hlsl"):
        for case in ("shadow:one_sided:mixed", "shadow:panorama:lab:clamped",
                     "shadow:occluded_ambient:panorama:lab:tilted_wide",
                     "shadow:occluded_ratio:4_random:overhead"):
            assert f"PASS  {path}  {case}" in r.stdout, (path, case)
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["failed"] == 0
