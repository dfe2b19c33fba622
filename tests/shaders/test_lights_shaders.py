"""The shipped ambient + lights shader functions (shaders/sh9_lights.glsl and .hlsl, docs/contract.md
§10) against the CPU, on a real headless OpenGL context, the HLSL through SPIR-V
(provider/verify/lights.py); the lights cases of the contract vectors; the picture.

Like tests/shaders/test_shaders.py: without EGL these skip with the install hint
(SHLIGHT_REQUIRE_GL=1 makes that a failure), without glslangValidator/spirv-cross the HLSL
ones skip (SHLIGHT_REQUIRE_HLSL=1).
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
from provider.verify import contract, harness, lights

import reference as ref
from conftest import HDRI_DIR, load_hdri
from shadertools import evaluator_or_skip

ROOT = Path(__file__).resolve().parents[2]
PANORAMAS = sorted(HDRI_DIR.glob("*.exr"))
TOL = harness.FLOAT32_TOLERANCE
NORMALS = harness.dense_normals(16384)


@pytest.fixture(scope="module", params=["glsl", "hlsl"])
def evaluator(request, ctx):
    return evaluator_or_skip(lights.LightsEvaluator, ctx, request.param)


def test_every_lights_case_matches_the_cpu_to_float32_rounding(evaluator):
    """One-sided light, no light, every slot, unused slots, the engine's lights on the nine
    panoramas, and the contract vectors' lights cases in both frames."""
    cases = (lights.synthetic_light_cases(NORMALS) + lights.panorama_light_cases(PANORAMAS)
             + lights.vector_light_cases(contract.load_contract_vectors()))
    results = lights.run_light_cases(evaluator, cases, NORMALS)
    names = {r.case for r in results}
    assert {"lights:one_sided", "lights:none", "lights:count_2_of_4",
            "lights:panorama:sky", "lights-vectors-unity:lights_one_sided"} <= names
    failed = [r.line() for r in results if not r.passed]
    assert not failed, "\n".join(failed)
    worst = max(r.max_rel for r in results)
    assert 0 < worst < TOL


def test_the_light_lands_on_its_side_in_both_frames(evaluator):
    """The vectors' one-sided case: E = 0.1π + I toward (2, 1, -2)/3, 0.1π away from it; in
    Unity's frame the same at (2, 1, 2)/3 (a z slip shows)."""
    case = next(c for c in contract.load_contract_vectors()["cases"]
                if c["name"] == "lights_one_sided")
    d, irr = contract.ONE_SIDED_LIGHT
    for frame, toward in (("", d), ("unity_", d * [1, 1, -1])):
        clamped, _ = evaluator.evaluate_lights(case[f"{frame}ambient_matrices"],
                                               case[f"{frame}light_directions"],
                                               case["light_irradiance"], [toward, -toward])
        assert np.allclose(clamped[0], 0.1 * math.pi + irr, rtol=1e-5), frame
        assert np.allclose(clamped[1], 0.1 * math.pi, rtol=1e-5), frame


def test_the_harness_catches_light_slips(ctx):
    """Negative controls: a light direction with z flipped (a frame slip), or the count
    ignored, fails the comparison."""
    glsl = lights.LightsEvaluator(ctx, "glsl")
    case = next(c for c in lights.synthetic_light_cases(NORMALS) if c.name == "lights:4_random")
    flipped = case.directions * [1, 1, -1]
    clamped, unclamped = glsl.evaluate_lights(case.matrices, flipped, case.irradiance, NORMALS)
    assert not lights.compare_lights(case, "glsl", clamped, unclamped, NORMALS).passed
    partial = next(c for c in lights.synthetic_light_cases(NORMALS)
                   if c.name == "lights:count_2_of_4")
    clamped, unclamped = glsl.evaluate_lights(partial.matrices, partial.directions,
                                              partial.irradiance, NORMALS)   # all 4 lit
    assert not lights.compare_lights(partial, "glsl", clamped, unclamped, NORMALS).passed


def test_vectors_lights_cases_are_consistent():
    """Each lights case: the full SH9 is ambient + Σ I Y(d); E with lights follows from the
    wire fields; Unity's fields are the z-flips; the one-sided case matches its analytic E."""
    doc = json.loads(contract.VECTORS_PATH.read_text())
    cases = [c for c in doc["cases"] if "lights" in c]
    assert [c["name"] for c in cases] == ["lights_one_sided", "lights_panorama_sky",
                                          "lights_panorama_lab", "lights_none_city"]
    assert [c["lights"] for c in cases] == [1, 1, 2, 0]
    S3, S4 = np.diag([1.0, 1.0, -1.0]), np.diag([1.0, 1.0, -1.0, 1.0])
    for c in cases:
        k = c["lights"]
        A = np.reshape(c["ambient_coefficients"], (9, 3))
        d = np.reshape(c["light_directions"], (k, 3))
        irr = np.reshape(c["light_irradiance"], (k, 3))
        n = np.reshape(c["normals"], (-1, 3))
        full = A + sum((np.outer(ref.basis(dk), Ik) for dk, Ik in zip(d, irr)), np.zeros((9, 3)))
        L = np.reshape(c["coefficients"], (9, 3))
        assert np.abs(full - L).max() <= 1e-9 * np.abs(L).max(), c["name"]
        MA = np.reshape(c["ambient_matrices"], (3, 4, 4))
        assert np.allclose(MA, sh.irradiance_matrices(A), atol=1e-12 * np.abs(MA).max())
        E = np.reshape(c["irradiance_with_lights"], (-1, 3))
        want = ref.sh_irradiance(A, n) + np.maximum(n @ d.T, 0) @ irr
        assert np.abs(E - want).max() <= 2e-6 * np.abs(E).max(), c["name"]
        assert np.array_equal(np.reshape(c["unity_ambient_matrices"], (3, 4, 4)), S4 @ MA @ S4)
        assert np.array_equal(np.reshape(c["unity_light_directions"], (k, 3)), d @ S3)
    one = cases[0]
    n = np.reshape(one["normals"], (-1, 3))
    d, irr = contract.ONE_SIDED_LIGHT
    analytic = 0.1 * math.pi + np.maximum(n @ d, 0)[:, None] * irr
    assert np.allclose(np.reshape(one["irradiance_with_lights"], (-1, 3)), analytic,
                       atol=5e-6 * math.pi)


def test_the_lights_picture_shows_what_lights_change(ctx, tmp_path):
    """sky: SH9 vs ambient + lights vs brute force; lights cut the error several fold."""
    picture, stats = lights.lights_picture(ctx, load_hdri("sky"), "sky", size=96)
    assert picture.shape[1] == 3 * 96 and picture.std() > 20
    assert stats["lights"] == 1
    assert stats["all_normals_lights_rms_rel"] < 0.25 * stats["all_normals_sh9_rms_rel"]
    assert stats["sphere_lights_rms_rel"] < 0.25 * stats["sphere_sh9_rms_rel"]
    pic = lights.write_lights_picture(ctx, [HDRI_DIR / "venice.exr", HDRI_DIR / "sky.exr"],
                                      tmp_path, size=64)
    assert Path(pic["file"]).name == "lights_sky.png" and Path(pic["file"]).is_file()


def test_the_demo_program_with_lights_matches_its_twin(ctx):
    check = lights.lit_diffuse_lights_check(ctx)
    assert check.passed and check.pixels > 1000, check.line()


def test_cli_validates_the_lights_functions_on_both_paths(ctx, tmp_path):
    r = subprocess.run([sys.executable, "-m", "provider.cli", "validate-shaders",
                        str(HDRI_DIR / "sky.exr"), "--normals", "1024", "--no-pictures",
                        "--out", str(tmp_path)], capture_output=True, text=True, timeout=180,
                       cwd=ROOT)
    assert r.returncode == 0, r.stdout + r.stderr
    for path in ("glsl", "hlsl"):
        for case in ("lights:one_sided", "lights:panorama:sky",
                     "lights-vectors-unity:lights_panorama_lab"):
            assert f"PASS  {path}  {case}" in r.stdout, (path, case)
    assert "PASS  demo  lights_one_sided_reinhard" in r.stdout
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["failed"] == 0
