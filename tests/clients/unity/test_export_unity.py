"""The `unity` export against Unity's published ShadeSH9 in C# under Mono, and against the Unity
package's own conversion (tests/csharp/ExportTest.cs on the golden vectors).

Compiled with Mono's mcs like tests/clients/unity/test_unity.py does; skipped (with the apt line) without Mono.
Nothing here runs Unity.
"""
from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from provider.verify import contract

ROOT = Path(__file__).resolve().parents[3]
CORE = sorted((ROOT / "unity_package" / "Runtime" / "Core").glob("*.cs"))
SOURCES = [ROOT / "tests" / "csharp" / "Checks.cs", ROOT / "tests" / "csharp" / "ExportTest.cs"]


@pytest.fixture(scope="module")
def export_exe(tmp_path_factory):
    mcs, mono = shutil.which("mcs"), shutil.which("mono")
    if not (mcs and mono):
        pytest.skip("Mono is not installed: apt-get install mono-mcs mono-runtime")
    exe = tmp_path_factory.mktemp("export_csharp") / "ExportTest.exe"
    r = subprocess.run([mcs, "-nologo", "-warnaserror+", "-target:exe", f"-out:{exe}",
                        *map(str, CORE), *map(str, SOURCES)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, f"mcs failed:\n{r.stdout}\n{r.stderr}"
    return mono, exe


def run_export_test(export_exe, vectors: Path) -> tuple[int, dict]:
    mono, exe = export_exe
    r = subprocess.run([mono, str(exe), str(vectors)], capture_output=True, text=True, timeout=60)
    try:
        return r.returncode, json.loads(r.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        pytest.fail(f"ExportTest printed no report (rc {r.returncode}):\n{r.stdout}\n{r.stderr}")


def test_unity_export_in_csharp(export_exe):
    """ShadeSH9 (UnityCG.cginc) of every golden `unity` vector shows E/π; the one-sided lights
    land on Unity's +X, +Y and +Z (our −Z); the package's C# conversion gives the Python
    export's numbers, from the coefficients and from the matrices."""
    rc, report = run_export_test(export_exe, contract.VECTORS_PATH)
    assert rc == 0 and not report["failures"], json.dumps(report, indent=1)
    assert report["cases"] == len(json.loads(contract.VECTORS_PATH.read_text())["exports"]) >= 5
    checks = report["checks"]
    for name in ("package_from_coefficients", "package_from_matrices", "packing",
                 "shadesh9_white", "one_sided_lit_side", "one_sided_dark_side", "self_description"):
        assert checks[name]["ok"] and checks[name]["count"] > 0, name
    assert checks["one_sided_lit_side"]["count"] == 3


def test_csharp_catches_a_sign_slip(export_exe, tmp_path):
    """The C# check is not vacuous: the vectors with Unity's z flip forgotten (L10, L2-1, L21
    of our frame copied as they are) fail, and the −Z light lands on Unity's −Z."""
    doc = json.loads(contract.VECTORS_PATH.read_text())
    for case in doc["exports"]:
        u = case["unity"]
        for key in ("sh", "sh_ambient"):
            if key in u:
                for rgb in range(3):
                    for i in (2, 5, 7):
                        u[key][rgb * 9 + i] *= -1
        from provider.core.conventions.formats import unity_shader_constants
        import numpy as np
        u["shaderConstants"] = unity_shader_constants(np.reshape(u["sh"], (3, 9)).T).reshape(-1).tolist()
        if "sh_ambient" in u:
            u["shaderConstantsAmbient"] = unity_shader_constants(
                np.reshape(u["sh_ambient"], (3, 9)).T).reshape(-1).tolist()
    path = tmp_path / "slipped.json"
    path.write_text(json.dumps(doc))
    rc, report = run_export_test(export_exe, path)
    assert rc == 1
    assert not report["checks"]["package_from_coefficients"]["ok"]
    assert not report["checks"]["shadesh9_white"]["ok"]
    assert any("one_sided_-z" in f and "brightest" in f for f in report["failures"])
