"""The Unity package (unity_package/) verified without Unity.

* The Unity-independent C# core is compiled with Mono's ``mcs`` and checked by
  tests/csharp/ContractTest.cs against the contract test vectors (shaders/contract_vectors.json)
  and against vectors generated here from provider.sh.
* The MonoBehaviour and the sample are compiled against tests/unity_stubs/UnityEngineStandIn.cs,
  a compile-only stand-in for UnityEngine (NOT Unity).
* tests/csharp/LiveClient.cs (package code + stand-in) talks to a live ``shlight serve`` over a
  real WebSocket: messages, a stale source, a server restart.
* The package's HLSL include equals shaders/sh9_irradiance.hlsl byte for byte; the demo shader's
  program compiles with glslangValidator's HLSL front end (stand-in UnityCG.cginc).

Nothing here runs Unity. ``python3 tests/test_unity.py --write-meta`` adds missing .meta files.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import queue
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
PKG = ROOT / "unity_package"
CORE = sorted((PKG / "Runtime" / "Core").glob("*.cs"))
RUNTIME = sorted((PKG / "Runtime").glob("*.cs"))
SAMPLES = sorted((PKG / "Samples~").rglob("*.cs"))
STANDIN = ROOT / "tests" / "unity_stubs" / "UnityEngineStandIn.cs"
CSHARP = ROOT / "tests" / "csharp"
VECTORS = ROOT / "shaders" / "contract_vectors.json"
PACKAGE_NAME = "org.shlight.sh9lighting"

S3 = np.diag([1.0, 1.0, -1.0])
S4 = np.diag([1.0, 1.0, -1.0, 1.0])


# ---- building -------------------------------------------------------------------------------

def _mono_tools():
    mcs, mono = shutil.which("mcs"), shutil.which("mono")
    if not (mcs and mono):
        pytest.skip("Mono is not installed: apt-get install mono-mcs mono-runtime")
    return mcs, mono


def _compile(out: Path, sources, target="exe"):
    mcs, _ = _mono_tools()
    cmd = [mcs, "-nologo", "-warnaserror+", "-nowarn:618", f"-target:{target}", f"-out:{out}",
           *[str(s) for s in sources]]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, f"mcs failed:\n{r.stdout}\n{r.stderr}"
    return out


@pytest.fixture(scope="session")
def build_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("unity_csharp")


@pytest.fixture(scope="session")
def contract_exe(build_dir):
    return _compile(build_dir / "ContractTest.exe", [*CORE, CSHARP / "ContractTest.cs"])


@pytest.fixture(scope="session")
def live_exe(build_dir):
    return _compile(build_dir / "LiveClient.exe", [*CORE, *RUNTIME, STANDIN, CSHARP / "LiveClient.cs"])


def _run_contract(exe: Path, vectors: Path | None):
    _, mono = _mono_tools()
    args = [mono, str(exe)] + ([str(vectors)] if vectors else [])
    r = subprocess.run(args, capture_output=True, text=True, timeout=60)
    try:
        report = json.loads(r.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        pytest.fail(f"ContractTest printed no report (rc {r.returncode}):\n{r.stdout}\n{r.stderr}")
    assert r.returncode == 0 and not report["failures"], json.dumps(report, indent=1)
    return report


# ---- vectors in the contract format, from the Python reference --------------------------------

def write_vectors(path: Path) -> None:
    """Vectors in exactly the shader harness's format (shaders/contract_vectors.json)."""
    from provider import sh

    def case(name, coeffs, rot=None):
        normals = np.vstack([np.eye(3), -np.eye(3), sh.fibonacci_sphere(58)])
        M = sh.irradiance_matrices(coeffs)
        c = {"name": name,
             "coefficients": coeffs.reshape(-1).tolist(),
             "matrices": M.reshape(-1).tolist(),
             "normals": normals.reshape(-1).tolist(),
             "irradiance": sh.irradiance(coeffs, normals).reshape(-1).tolist(),
             "unity_matrices": (S4 @ M @ S4).reshape(-1).tolist(),
             "unity_normals": (normals @ S3).reshape(-1).tolist()}
        if rot is not None:
            RM = sh.rotate_matrices(M, rot)
            c.update(rotation=rot.reshape(-1).tolist(), rotated_matrices=RM.reshape(-1).tolist(),
                     unity_rotated_matrices=(S4 @ RM @ S4).reshape(-1).tolist())
        return c

    rng = np.random.default_rng(2024)
    rand = rng.normal(size=(9, 3))
    rand[0] = np.abs(rand[0]) + 3.0
    light = np.outer(sh.sh_basis(np.array([1.0, 0.0, 0.0])), [1.0, 2.0, 3.0])
    light[0] += 0.1
    furnace = np.zeros((9, 3))
    furnace[0] = 2 * math.sqrt(math.pi)
    hdr = rng.normal(size=(9, 3)) * [1e3, 1e3, 2e3]   # large scene-referred values
    hdr[0] = np.abs(hdr[0]) + 5e3
    cases = [case("random", rand), case("light_+x", light), case("furnace", furnace),
             case("hdr_scale", hdr),
             case("random_rotated", rand, sh.rotation_from_euler(30, -20, 10)),
             case("light_+x_yaw90", light, sh.rotation_from_euler(90, 0, 0)),
             case("light_+x_pitch_roll", light, sh.rotation_from_euler(0, 60, -45))]
    path.write_text(json.dumps({"version": 1, "frame": "rh-y-up",
                                "unity_frame": "unity-lh-y-up: (x, y, z) -> (x, y, -z)",
                                "cases": cases}))


# ---- the C# core against vectors ----------------------------------------------------------------

def test_core_against_contract_vectors(contract_exe):
    """shaders/contract_vectors.json (the shader harness's file) through the C# core."""
    if not VECTORS.exists():
        pytest.skip("shaders/contract_vectors.json is not there yet (written by the shader harness, "
                    "`shlight validate-shaders`); test_core_against_generated_vectors covers the same checks")
    report = _run_contract(contract_exe, VECTORS)
    assert report["cases"] >= 1
    for name in ("unity_matrices", "irradiance_unity", "ambient_shadesh9_from_matrices",
                 "one_sided_light"):
        assert report["checks"][name]["ok"], name
    if any("rotation" in c for c in json.loads(VECTORS.read_text())["cases"]):
        assert report["checks"]["rotated_matrices_unity"]["ok"]
    _print_agreement("contract_vectors.json", report)


def test_core_against_generated_vectors(contract_exe, tmp_path):
    """The same checks on vectors generated here from provider.sh (always available)."""
    path = tmp_path / "vectors.json"
    write_vectors(path)
    report = _run_contract(contract_exe, path)
    assert report["cases"] == 7
    checks = report["checks"]
    expected = {"matrices_from_coefficients", "irradiance_rh", "unity_matrices", "irradiance_unity",
                "message_roundtrip_unity_matrices", "upload_float32_irradiance",
                "ambient_shadesh9_from_coefficients", "ambient_shadesh9_from_matrices",
                "ambient_paths_agree", "ambient_float32_upload", "rotated_matrices_rh",
                "rotated_matrices_unity", "quaternion_roundtrip", "rotated_upload_float32",
                "rotated_irradiance_unity", "rotated_ambient_shadesh9", "one_sided_light",
                "intensity_multiplier", "furnace", "parser_rejects_invalid", "parser_accepts_valid",
                "parser_invariant_culture", "subscribe_message", "uri"}
    assert expected <= set(checks), expected - set(checks)
    assert all(c["ok"] for c in checks.values())
    # the matrix algebra is exact to rounding; irradiance agrees to the constants' 6 digits
    assert checks["unity_matrices"]["max_rel"] == 0.0
    assert checks["rotated_matrices_unity"]["max_rel"] < 1e-14
    assert checks["irradiance_unity"]["max_rel"] < 1e-6
    assert checks["ambient_shadesh9_from_matrices"]["max_rel"] < 1e-6
    _print_agreement("generated vectors", report)


def _print_agreement(label, report):
    rows = ", ".join(f"{k} {v['max_rel']:.1e}" for k, v in report["checks"].items() if v["tolerance"] > 0)
    print(f"\n{label}: {report['cases']} cases; max relative error: {rows}")


def test_csharp_ambient_factors_match_the_python_constants():
    """The k factors in Sh9Math.cs are basis constant × Â_l/π of provider.sh (DESIGN.md §7)."""
    from provider import sh
    text = (PKG / "Runtime" / "Core" / "Sh9Math.cs").read_text()
    block = re.search(r"UnityAmbientFactors =\s*\{(.*?)\};", text, re.S).group(1)
    k = [float(v) for v in re.findall(r"^\s*([0-9.]+),", block, re.M)]
    basis = np.array([sh.C0, sh.C1, sh.C1, sh.C1, sh.C2, sh.C2, sh.C20, sh.C2, sh.C22])
    assert len(k) == 9
    assert np.allclose(k, basis * sh.A_HAT_PER_COEFF / math.pi, rtol=2e-6)
    # and the magnitudes of DESIGN.md §7's signed table
    design = [0.282095, -0.325735, 0.325735, -0.325735, 0.273137, -0.273137, 0.078848, -0.273137, 0.136569]
    assert np.allclose(k, np.abs(design), atol=1e-6)


# ---- Unity-facing code against the stand-in --------------------------------------------------

def test_monobehaviours_compile_against_standin(build_dir):
    """SH9LightingClient and the sample script type-check against the UnityEngine stand-in."""
    assert RUNTIME and SAMPLES
    _compile(build_dir / "Runtime.dll", [*CORE, *RUNTIME, *SAMPLES, STANDIN], target="library")


def test_core_has_no_unity_dependency(build_dir):
    """The core compiles alone (no UnityEngine), as its asmdef's noEngineReferences promises."""
    for f in CORE:
        assert "UnityEngine" not in re.sub(r"//.*", "", f.read_text()), f.name
    _compile(build_dir / "Core.dll", CORE, target="library")
    asmdef = json.loads((PKG / "Runtime" / "Core" / "Shlight.SH9Lighting.Core.asmdef").read_text())
    assert asmdef["noEngineReferences"] is True


# ---- shaders ---------------------------------------------------------------------------------------

def test_hlsl_include_identical_to_shaders_dir():
    """The package's include must never drift from shaders/sh9_irradiance.hlsl."""
    a = (ROOT / "shaders" / "sh9_irradiance.hlsl").read_bytes()
    b = (PKG / "Shaders" / "sh9_irradiance.hlsl").read_bytes()
    assert a == b, ("unity_package/Shaders/sh9_irradiance.hlsl differs from shaders/sh9_irradiance.hlsl: "
                    "copy shaders/sh9_irradiance.hlsl over it")


def test_demo_shader_declares_stereo_instancing():
    src = (PKG / "Shaders" / "SH9Diffuse.shader").read_text()
    for token in ("UNITY_VERTEX_INPUT_INSTANCE_ID", "UNITY_VERTEX_OUTPUT_STEREO", "UNITY_SETUP_INSTANCE_ID",
                  "UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO", "#pragma multi_compile_instancing",
                  '#include "sh9_irradiance.hlsl"', "SHIrradiance(", "UNITY_PI"):
        assert token in src, token
    assert 'Shader "Shlight/SH9 Diffuse"' in src
    assert "LightMode" not in re.sub(r"//.*", "", src)  # no LightMode tag: built-in and URP both draw it


@pytest.mark.parametrize("gamma", [False, True], ids=["linear", "gamma"])
def test_demo_shader_compiles_with_glslang_hlsl(tmp_path, gamma):
    """The CGPROGRAM of SH9Diffuse.shader through glslangValidator's HLSL front end, with a
    stand-in UnityCG.cginc (tests/unity_stubs): checks the shader's own code, not Unity's macros."""
    glslang = shutil.which("glslangValidator")
    if not glslang:
        pytest.skip("glslangValidator not installed (apt-get install glslang-tools)")
    src = (PKG / "Shaders" / "SH9Diffuse.shader").read_text()
    prog = re.search(r"CGPROGRAM(.*?)ENDCG", src, re.S).group(1)
    prog = "\n".join(l for l in prog.splitlines() if not l.strip().startswith("#pragma"))
    f = tmp_path / "sh9diffuse.hlsl"
    f.write_text(prog)
    for stage, entry in (("vert", "vert"), ("frag", "frag")):
        cmd = [glslang, "-D", "-V", f"-I{ROOT / 'tests' / 'unity_stubs'}", f"-I{PKG / 'Shaders'}",
               "-S", stage, "-e", entry, "-o", str(tmp_path / f"{entry}.spv"), str(f)]
        if gamma:
            cmd.insert(1, "-DUNITY_COLORSPACE_GAMMA")
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
        assert r.returncode == 0, r.stdout + r.stderr


# ---- package layout ----------------------------------------------------------------------------

def _package_assets():
    """Every file and folder Unity imports (Samples~ included: its metas travel with the sample)."""
    for p in sorted(PKG.rglob("*")):
        if p.name.endswith(".meta") or any(part.startswith(".") for part in p.relative_to(PKG).parts):
            continue
        if p == PKG / "Samples~":  # Unity skips "~" folders; only their contents get imported (with metas)
            continue
        yield p


def _importer(p: Path) -> str:
    if p.is_dir():
        return "DefaultImporter"
    if p.name == "package.json":
        return "PackageManifestImporter"
    return {".cs": "MonoImporter", ".asmdef": "AssemblyDefinitionImporter", ".shader": "ShaderImporter",
            ".hlsl": "ShaderIncludeImporter", ".cginc": "ShaderIncludeImporter",
            ".md": "TextScriptImporter", ".json": "TextScriptImporter", ".txt": "TextScriptImporter",
            ".mat": "NativeFormatImporter"}.get(p.suffix, "DefaultImporter")


def _guid(p: Path) -> str:
    return hashlib.md5(f"{PACKAGE_NAME}:{p.relative_to(PKG).as_posix()}".encode()).hexdigest()


def _meta_text(p: Path) -> str:
    importer = _importer(p)
    lines = ["fileFormatVersion: 2", f"guid: {_guid(p)}"]
    if p.is_dir():
        lines.append("folderAsset: yes")
    lines.append(f"{importer}:")
    lines.append("  externalObjects: {}")
    if importer == "MonoImporter":
        lines += ["  serializedVersion: 2", "  defaultReferences: []", "  executionOrder: 0",
                  "  icon: {instanceID: 0}"]
    elif importer == "ShaderImporter":
        lines += ["  defaultTextures: []", "  nonModifiableTextures: []"]
    elif importer == "NativeFormatImporter":
        lines += ["  mainObjectFileID: 2100000"]
    lines += ["  userData: ", "  assetBundleName: ", "  assetBundleVariant: "]
    return "\n".join(lines) + "\n"


def write_missing_meta() -> list[Path]:
    written = []
    for p in _package_assets():
        meta = p.with_name(p.name + ".meta")
        if not meta.exists():
            meta.write_text(_meta_text(p))
            written.append(meta)
    return written


def test_package_manifest_and_layout():
    manifest = json.loads((PKG / "package.json").read_text())
    assert manifest["name"] == PACKAGE_NAME and re.fullmatch(r"[a-z0-9.\-]+", manifest["name"])
    assert re.fullmatch(r"\d+\.\d+\.\d+", manifest["version"])
    assert re.fullmatch(r"\d{4}\.\d", manifest["unity"])
    for key in ("displayName", "description"):
        assert manifest[key]
    for sample in manifest["samples"]:
        assert (PKG / sample["path"]).is_dir() and sample["path"].startswith("Samples~/")
    for asmdef in PKG.rglob("*.asmdef"):
        json.loads(asmdef.read_text())
    readme = (PKG / "README.md").read_text()
    for needle in ("Add package from disk", "?path=unity_package", "--host 0.0.0.0", "--token",
                   "InternetClient", "PrivateNetworkClientServer", "nothing lights up",
                   "UnityCG.cginc", "UndoCosineRescaling", "PackCoefficients", "URP"):
        assert needle in readme, needle


def test_meta_files_present_and_guids_unique():
    """Immutable (git URL) packages ignore assets without .meta; GUIDs must be unique."""
    guids = {}
    for p in _package_assets():
        meta = p.with_name(p.name + ".meta")
        assert meta.exists(), f"{meta.relative_to(ROOT)} missing: run python3 tests/test_unity.py --write-meta"
        text = meta.read_text()
        m = re.search(r"^guid: ([0-9a-f]{32})$", text, re.M)
        assert m, meta
        assert m.group(1) not in guids, f"duplicate GUID in {meta} and {guids.get(m.group(1))}"
        guids[m.group(1)] = meta
        assert f"\n{_importer(p)}:" in text, f"{meta.name}: expected {_importer(p)}"
    for meta in PKG.rglob("*.meta"):
        assert meta.with_name(meta.name[:-5]).exists(), f"orphan {meta}"
    # the sample material points at the package shader's GUID
    shader_guid = re.search(r"guid: (\w+)", (PKG / "Shaders" / "SH9Diffuse.shader.meta").read_text()).group(1)
    mat = next((PKG / "Samples~").rglob("*.mat")).read_text()
    assert f"guid: {shader_guid}, type: 3" in mat


if __name__ == "__main__":
    if "--write-meta" in sys.argv:
        for m in write_missing_meta():
            print("wrote", m.relative_to(ROOT))
