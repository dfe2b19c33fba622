"""The shipped GLSL and HLSL against the CPU, on a real headless OpenGL context (llvmpipe here).

Every comparison renders E(n) through the shader (one fragment per normal, float32 targets)
and checks it against float64 ñᵀMñ from provider.core.geometry.sh: see provider/verify/harness.py for the error
measure and its tolerance. No OpenGL is mocked. Without EGL the tests skip with the install
hint (set SHLIGHT_REQUIRE_GL=1 to make that a failure); without glslangValidator/spirv-cross
the HLSL tests skip likewise (SHLIGHT_REQUIRE_HLSL=1).
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from provider.core.geometry import sh
from provider.verify import contract, harness
from provider import compute_sh9

import reference as ref
from conftest import HDRI_DIR, load_hdri
from shadertools import evaluator_or_skip

ROOT = Path(__file__).resolve().parents[2]
PANORAMAS = sorted(HDRI_DIR.glob("*.exr"))
TOL = harness.FLOAT32_TOLERANCE
#: Fewer dense normals than the CLI's 65 536 keep the file fast: 16 390, about one per
#: 2.5 square degrees, plus ±X, ±Y, ±Z.
NORMALS = harness.dense_normals(16384)


@pytest.fixture(scope="module")
def glsl(ctx):
    return harness.IrradianceEvaluator(ctx, "glsl")


@pytest.fixture(scope="module")
def hlsl(ctx):
    return evaluator_or_skip(harness.IrradianceEvaluator, ctx, "hlsl")


@pytest.fixture(params=["glsl", "hlsl"])
def evaluator(request):
    return request.getfixturevalue(request.param)


@pytest.fixture(scope="module")
def all_cases():
    cases = harness.synthetic_cases(NORMALS) + harness.panorama_cases(PANORAMAS, NORMALS)
    cases += harness.vector_cases(contract.load_contract_vectors())
    return cases


# -- the shaders against the CPU -------------------------------------------------------------------

def test_every_case_matches_the_cpu_to_float32_rounding(evaluator, all_cases):
    """Furnace, +X light, random, the nine real panoramas, the rotated probe, the vectors."""
    results = harness.run_cases(evaluator, all_cases, NORMALS)
    names = {r.case for r in results}
    assert {"furnace", "one_sided_+x", "random", "panorama:lab", "panorama:sky"} <= names
    assert any(n.startswith("rotated_yaw90:") for n in names)
    assert sum(n.startswith("panorama:") for n in names) == len(PANORAMAS) == 9
    failed = [r.line() for r in results if not r.passed]
    assert not failed, "\n".join(failed)
    worst = max(r.max_rel for r in results)
    print(f"\n{evaluator.path}: {len(results)} cases, worst max relative error {worst:.2e}, "
          f"worst relative RMS {max(r.rms_rel for r in results):.2e} (tolerance {TOL:.2e})")
    # the measure is not vacuous: float32 leaves a visible, small error
    assert 0 < worst < TOL


def test_ringing_scene_is_clamped_to_zero(evaluator):
    """lab.exr: order-2 SH irradiance goes negative (blue); the shader must show 0 there."""
    M = compute_sh9(load_hdri("lab"), error_estimate=False).matrices
    clamped, unclamped = evaluator.evaluate(M, NORMALS)
    exact = sh.irradiance_from_matrices(M, NORMALS.astype(np.float32))
    scale = sh.irradiance_from_matrices(np.abs(M), np.abs(NORMALS))
    negative = exact < -TOL * scale
    assert negative.sum() > 10                       # the scene really rings
    assert np.all(unclamped[negative] < 0)           # the unclamped function shows it
    assert np.all(clamped[negative] == 0.0)          # the shipped function clamps it exactly
    assert np.all(clamped >= 0)
    positive = exact > TOL * scale
    assert np.allclose(clamped[positive], unclamped[positive], rtol=0, atol=0)


def test_one_sided_light_lands_on_the_right_side(evaluator):
    """Radiance (1, 0.5, 0.25) from x > 0 only: E(+X) = π·colour, E(-X) = 0 (sign slips show)."""
    M = sh.irradiance_matrices(contract.one_sided_coefficients())
    axes = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, 0, 1]])
    clamped, _ = evaluator.evaluate(M, axes)
    colour = contract.ONE_SIDED_COLOUR
    assert np.allclose(clamped[0], math.pi * colour, rtol=1e-5)
    assert np.allclose(clamped[1], 0.0, atol=1e-5)
    assert np.allclose(clamped[2:], math.pi / 2 * colour, rtol=1e-5)


def test_unity_frame_light_from_minus_z_lands_on_plus_z(evaluator):
    """The +X light yawed 90° shines from -Z (right-handed), i.e. +Z in Unity's frame."""
    case = next(c for c in contract.load_contract_vectors()["cases"]
                if c["name"] == "one_sided_+x_yaw90")
    colour = contract.ONE_SIDED_COLOUR
    rh, _ = evaluator.evaluate(case["rotated_matrices"], [[0, 0, -1.0], [0, 0, 1.0]])
    unity, _ = evaluator.evaluate(case["unity_rotated_matrices"], [[0, 0, 1.0], [0, 0, -1.0]])
    for got in (rh, unity):
        assert np.allclose(got[0], math.pi * colour, rtol=1e-5)
        assert np.allclose(got[1], 0.0, atol=1e-5)


def test_furnace_gives_pi_and_the_demo_shader_shows_white_as_1(ctx, glsl):
    clamped, _ = glsl.evaluate(sh.irradiance_matrices(contract.furnace_coefficients()), NORMALS)
    assert np.allclose(clamped, math.pi, rtol=2e-6)
    checks = {c.name: c for c in harness.lit_diffuse_checks(ctx)}
    assert checks["furnace_white_shows_1"].pixels > 1000
    failed = [c.line() for c in checks.values() if not c.passed]
    assert not failed, "\n".join(failed)


def test_the_harness_catches_slips(glsl):
    """Negative controls: a frame slip, and one matrix entry off by one part in 10⁴, fail."""
    case = next(c for c in harness.synthetic_cases(NORMALS) if c.name == "random")
    S4 = np.diag([1.0, 1.0, -1.0, 1.0])
    flipped = S4 @ case.matrices @ S4               # Unity matrices with right-handed normals
    clamped, unclamped = glsl.evaluate(flipped, NORMALS)
    assert not harness.compare(case, "glsl", clamped, unclamped, NORMALS).passed
    nudged = case.matrices.copy()
    nudged[1, 0, 3] *= 1 + 1e-4
    nudged[1, 3, 0] *= 1 + 1e-4
    clamped, unclamped = glsl.evaluate(nudged, NORMALS)
    assert not harness.compare(case, "glsl", clamped, unclamped, NORMALS).passed


def test_uniform_upload_gives_the_shader_m_itself(evaluator):
    """Beyond the symmetric contract: the shader's M·v is the uploaded M times v (no silent
    transpose in either path's upload, the HLSL cbuffer packing included)."""
    glsl_body = harness.GLSL_EVALUATOR.replace("clampedOut = vec4(shIrradiance(n), 1.0);",
                                               "clampedOut = shIrradianceR * vec4(n, 0.0);")
    hlsl_src = harness.HLSL_EVALUATOR.replace("t.clamped = float4(SHIrradiance(n), 1.0);",
                                              "t.clamped = mul(_SHIrradianceR, float4(n, 0.0));")
    probe = harness.IrradianceEvaluator(evaluator.ctx, evaluator.path,
                                        glsl_body if evaluator.path == "glsl" else hlsl_src)
    M = np.arange(16.0).reshape(4, 4)
    columns, _ = probe.evaluate(np.stack([M, np.eye(4), np.eye(4)]), np.eye(3))
    assert np.array_equal(columns, M[:3, :3].T)       # row i: M @ e_i = column i of M


# -- rotation: R̃MR̃ᵀ against re-projecting a rotated panorama --------------------------------------

def rotate_equirect(image, R, supersample=2):
    """The equirect of the environment rotated by R, L'(ω) = L(Rᵀω), by resampling
    (bilinear at 2× resolution, then a 2×2 box average). Test-only: the product rotates
    coefficients, never images."""
    h, w = image.shape[:2]
    d = ref.equirect_directions(w * supersample, h * supersample)
    src = d @ R                                                  # each row: Rᵀ ω
    theta = np.arccos(np.clip(src[..., 1], -1, 1))
    phi = np.arctan2(src[..., 0], -src[..., 2])
    mx = ((phi / (2 * np.pi) + 0.5) * w - 0.5).astype(np.float32)
    my = (theta / np.pi * h - 0.5).astype(np.float32)
    img = np.maximum(np.nan_to_num(image), 0).astype(np.float32)
    big = cv2.remap(img, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
    return big.reshape(h, supersample, w, supersample, 3).mean(axis=(1, 3))


@pytest.mark.parametrize("name", ["venice", "lab", "forest"])
def test_rotated_matrices_match_a_reprojected_rotated_panorama(evaluator, name):
    """GPU E with R̃MR̃ᵀ uploaded = CPU E of the panorama resampled into the rotated frame.

    Bilinear resampling costs ~1e-4 of the scale on these (sunless) scenes; the wrong
    rotation (Rᵀ) is off by 0.5 to 1.
    """
    image = load_hdri(name)
    R = sh.rotation_from_euler(30, -20, 10)
    M = compute_sh9(image, error_estimate=False).matrices
    reprojected = compute_sh9(rotate_equirect(image, R), error_estimate=False).matrices
    want = sh.irradiance_from_matrices(reprojected, NORMALS)
    for rotation, ok in ((R, True), (R.T, False)):
        uploaded = sh.rotate_matrices(M, rotation)
        _, unclamped = evaluator.evaluate(uploaded, NORMALS)
        scale = sh.irradiance_from_matrices(np.abs(uploaded), np.abs(NORMALS))
        err = np.max(np.abs(unclamped - want) / scale)
        assert (err < 1e-3) == ok, (rotation.tolist(), err)


def test_yaw90_is_an_exact_column_roll():
    """The harness's exact rotation case: a +90° yaw moves the +X light to -Z."""
    img = np.zeros((32, 64, 3), np.float32)
    img[:, 48] = 1.0                                # column u = 0.76: near +X
    rolled = harness.yaw90_rolled(img)
    d = ref.equirect_directions(64, 32)
    lit = d[rolled[..., 0] > 0]
    assert np.all(lit[:, 2] < -0.99 * np.hypot(lit[:, 0], lit[:, 2]))
    R = sh.rotation_from_euler(90, 0, 0)
    assert np.allclose(R @ [1.0, 0, 0], [0, 0, -1.0])


# -- the contract vectors file ----------------------------------------------------------------------

EXPECTED_CASE_KEYS = ["name", "coefficients", "matrices", "normals", "irradiance",
                      "unity_matrices", "unity_normals"]
ROTATION_KEYS = ["rotation", "rotated_matrices", "unity_rotated_matrices"]
#: Lights cases (docs/contract.md §10; checked in tests/core/lights/test_lights.py).
LIGHT_KEYS = ["lights", "light_directions", "light_irradiance", "ambient_coefficients",
              "ambient_matrices", "irradiance_with_lights", "unity_ambient_matrices",
              "unity_light_directions"]


def test_vectors_file_is_what_the_generator_writes():
    """shaders/contract_vectors.json is current: same structure, same numbers, within the
    tolerances tests/shadertools.py states (the engine's float32 sums move in their last
    digits from one CPU to another; everything else to 1e-12)."""
    from shadertools import vectors_mismatches
    committed = json.loads(contract.VECTORS_PATH.read_text())
    fresh = json.loads(contract.dumps(contract.contract_vectors()))
    for k in ("version", "frame", "unity_frame", "description"):
        assert committed[k] == fresh[k], k
    assert vectors_mismatches(fresh["cases"], committed["cases"], "cases") == []


def test_vectors_file_format_and_internal_consistency():
    """Exactly the agreed format; every derived array follows from the coefficients."""
    doc = json.loads(contract.VECTORS_PATH.read_text())
    assert doc["version"] == 1 and doc["frame"] == "rh-y-up"
    assert doc["unity_frame"] == "unity-lh-y-up: (x, y, z) -> (x, y, -z)"
    assert set(doc) == {"version", "frame", "unity_frame", "description", "cases",
                        "exports_description", "exports"}   # exports: tests/core/conventions/test_export.py
    names = [c["name"] for c in doc["cases"]]
    for required in ("furnace", "one_sided_+x", "random", "panorama_sky", "panorama_lab_ringing"):
        assert required in names
    S3, S4 = np.diag([1.0, 1.0, -1.0]), np.diag([1.0, 1.0, -1.0, 1.0])
    rotations = 0
    for c in doc["cases"]:
        keys = (EXPECTED_CASE_KEYS + (ROTATION_KEYS if "rotation" in c else [])
                + (LIGHT_KEYS if "lights" in c else []))
        assert list(c) == keys, c["name"]
        assert all(isinstance(v, float) and math.isfinite(v)
                   for k in keys[1:] if k != "lights" for v in c[k]), c["name"]
        L = np.reshape(c["coefficients"], (9, 3))
        M = np.reshape(c["matrices"], (3, 4, 4))
        n = np.reshape(c["normals"], (-1, 3))
        assert len(c["coefficients"]) == 27 and len(c["matrices"]) == 48
        assert np.allclose(M, sh.irradiance_matrices(L), rtol=0, atol=1e-12 * np.abs(M).max())
        assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-12)
        E = np.reshape(c["irradiance"], (-1, 3))
        assert E.shape == n.shape
        assert np.allclose(E, sh.irradiance_from_matrices(M, n), atol=1e-12 * np.abs(E).max())
        # and ñᵀMñ agrees with Σ Â_l L_lm Y_lm(n) written independently (6-digit constants)
        assert np.abs(E - ref.sh_irradiance(L, n)).max() <= 2e-6 * np.abs(E).max()
        assert np.array_equal(np.reshape(c["unity_matrices"], (3, 4, 4)), S4 @ M @ S4)
        assert np.array_equal(np.reshape(c["unity_normals"], (-1, 3)), n @ S3)
        if "rotation" in c:
            rotations += 1
            R = np.reshape(c["rotation"], (3, 3))
            assert np.allclose(R @ R.T, np.eye(3), atol=1e-12) and np.linalg.det(R) > 0
            RM = np.reshape(c["rotated_matrices"], (3, 4, 4))
            assert np.allclose(RM, sh.rotate_matrices(M, R), atol=1e-12 * np.abs(M).max())
            assert np.allclose(np.reshape(c["unity_rotated_matrices"], (3, 4, 4)), S4 @ RM @ S4,
                               rtol=0, atol=0)
    assert rotations >= 1
    lab = next(c for c in doc["cases"] if c["name"] == "panorama_lab_ringing")
    assert min(lab["irradiance"]) < 0                 # the ringing case really rings
    furnace = next(c for c in doc["cases"] if c["name"] == "furnace")
    assert np.allclose(furnace["irradiance"], math.pi, rtol=1e-6)
    light = next(c for c in doc["cases"] if c["name"] == "one_sided_+x")
    n = np.reshape(light["normals"], (-1, 3))
    assert np.allclose(np.reshape(light["irradiance"], (-1, 3)), contract.one_sided_irradiance(n),
                       atol=5e-6 * math.pi)


# -- pictures ---------------------------------------------------------------------------------------

def test_brute_force_reference_matches_full_resolution():
    """The pictures' 64×32-block reference against the full-resolution sum (sun included)."""
    from provider.verify.pictures import brute_force_irradiance, panorama_flux
    normals = ref.NORMALS[::4]
    for name in ("sky", "lab"):
        image = load_hdri(name)
        dirs, flux = panorama_flux(image)
        got = brute_force_irradiance(dirs, flux, normals)
        assert ref.rel_rms(got, ref.brute_irradiance(image, normals)) < 2e-3, name


def test_pictures_are_written_and_measure_sh9(ctx, tmp_path):
    from provider.verify.pictures import write_validation_pictures
    pics = write_validation_pictures(ctx, [HDRI_DIR / "venice.exr"], tmp_path, size=128)
    assert len(pics) == 1
    png = cv2.imread(pics[0]["file"])
    assert png is not None and png.shape[1] == 3 * 128 and png.shape[0] > 3 * 128
    assert png.std() > 20                                    # not a blank image
    # over the whole sphere, SH9 vs brute force is the engine's truncation error (~0.9 %)
    image = load_hdri("venice")
    truth = ref.brute_irradiance(image)
    sh9 = sh.irradiance(compute_sh9(image, error_estimate=False).coefficients, ref.NORMALS)
    assert abs(pics[0]["all_normals_rms_rel"] - ref.rel_rms(sh9, truth)) < 2e-3
    assert 0.001 < pics[0]["sphere_rms_rel"] < 0.1


# -- the command line -------------------------------------------------------------------------------

def _cli(args, env=None, cwd=None):
    return subprocess.run([sys.executable, "-m", "provider.cli", "validate-shaders", *args],
                          capture_output=True, text=True, timeout=120, env=env, cwd=cwd or ROOT)


def test_cli_passes_and_reports_both_paths(ctx, tmp_path):
    r = _cli([str(HDRI_DIR / "lab.exr"), "--normals", "4096", "--out", str(tmp_path)])
    assert r.returncode == 0, r.stdout + r.stderr
    assert "PASS  glsl  panorama:lab" in r.stdout and "PASS  hlsl  panorama:lab" in r.stdout
    assert "PASS  demo  furnace_white_shows_1" in r.stdout
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["failed"] == 0 and not report["skipped"]
    assert (tmp_path / "lab.png").is_file()


def test_cli_without_opengl_says_what_to_install(tmp_path):
    env = dict(os.environ, __EGL_VENDOR_LIBRARY_FILENAMES=str(tmp_path / "none.json"),
               LIBGL_DRIVERS_PATH=str(tmp_path), EGL_PLATFORM="surfaceless")
    env.pop("DISPLAY", None)
    env.pop("WAYLAND_DISPLAY", None)
    r = _cli([str(HDRI_DIR / "lab.exr"), "--no-pictures", "--out", str(tmp_path)], env=env)
    assert r.returncode == 2, r.stdout + r.stderr
    assert "libegl1 libegl-mesa0 libgl1-mesa-dri" in r.stderr
    assert "Traceback" not in r.stderr and "Traceback" not in r.stdout


def test_cli_without_hlsl_tools_skips_rather_than_passes(ctx, tmp_path):
    """No glslangValidator/spirv-cross on PATH: HLSL is reported as skipped, never passed."""
    env = dict(os.environ, PATH=str(tmp_path))
    args = [str(HDRI_DIR / "venice.exr"), "--no-pictures", "--normals", "1024",
            "--out", str(tmp_path)]
    r = _cli(args, env=env)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "SKIP  hlsl" in r.stdout and "glslang-tools spirv-cross" in r.stdout
    assert "PASS  hlsl" not in r.stdout
    assert "HLSL skipped" in r.stdout
    assert _cli(args + ["--require-hlsl"], env=env).returncode == 1


# -- render helpers -----------------------------------------------------------------------------------

def test_meshes_are_counter_clockwise_with_unit_normals():
    from provider.verify.render import torus, uv_sphere
    for mesh in (uv_sphere(), torus()):
        pos, nrm, idx = mesh
        assert np.allclose(np.linalg.norm(nrm, axis=1), 1, atol=1e-6)
        a, b, c = pos[idx[:, 0]], pos[idx[:, 1]], pos[idx[:, 2]]
        face = np.cross(b - a, c - a)
        outward = np.einsum("ij,ij->i", face, nrm[idx].sum(axis=1))
        area = np.linalg.norm(face, axis=1)
        assert np.all(outward[area > 1e-9] > 0)          # pole triangles of the sphere are degenerate


def test_camera_helpers():
    from provider.verify.render import look_at, perspective
    eye = np.array([0.0, 1.2, 3.0])
    V = look_at(eye)
    assert np.allclose(V @ [*eye, 1], [0, 0, 0, 1])
    target = V @ [0, 0, 0, 1.0]
    assert np.allclose(target[:2], 0) and target[2] < 0          # looking down -Z in eye space
    assert np.allclose(V[:3, :3] @ V[:3, :3].T, np.eye(3))
    P = perspective(40.0, 1.0, 0.1, 20.0)
    near, far = P @ [0, 0, -0.1, 1], P @ [0, 0, -20, 1]
    assert np.isclose(near[2] / near[3], -1) and np.isclose(far[2] / far[3], 1)


def test_rendered_sphere_faces_the_camera(ctx):
    """With back-face culling on, the visible normals point to the camera (winding is right)."""
    from provider.verify.pictures import ObjectRenderer
    r = ObjectRenderer(ctx, 64)
    r.set_lighting(sh.irradiance_matrices(contract.furnace_coefficients()))
    shown, normals, mask = r.render("sphere")
    assert mask.sum() > 0.4 * 64 * 64
    to_eye = r.eye / np.linalg.norm(r.eye)
    assert np.mean(normals[mask] @ to_eye) > 0.5
    assert np.allclose(shown[mask], 1.0, atol=2e-6)               # furnace: white shows 1
