"""The Unity package (unity_package/) verified without Unity.

* The Unity-independent C# core is compiled with Mono's ``mcs`` and checked by
  tests/csharp/ContractTest.cs against the contract test vectors (shaders/contract_vectors.json)
  and against vectors generated here from provider.core.geometry.sh.
* The MonoBehaviour and the sample are compiled against tests/unity_stubs/UnityEngineStandIn.cs,
  a compile-only stand-in for UnityEngine (NOT Unity).
* tests/csharp/LiveClient.cs (package code + stand-in, playing Unity's player loop) talks to a
  live ``shlight serve`` over a real WebSocket: messages parsed and applied (matrices and ambient
  probe against the Python conversion, a rotated transform), a stale source and its return, a
  server killed and restarted on the same port (the client reconnects by itself), a wrong token;
  suspend/resume with a connection that died unnoticed (reconnect at once on resume); zero
  managed allocations per Update in the steady state (Mono's per-thread allocation counter);
  wss:// with a private-CA certificate, trusted or not by the client's store (a TLS proxy now;
  `shlight serve --tls-cert` when the provider has it).
* The stand-in rejects what Unity's compiler rejects (properties, struct semantics, constraints).
* The package's HLSL include equals shaders/sh9_irradiance.hlsl byte for byte (the shader's
  passes and variants are compiled in tests/clients/unity/test_unity_shaders.py).

Nothing here runs Unity. ``python3 tests/clients/unity/test_unity.py --write-meta`` adds missing .meta files.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import re
import select
import shutil
import socket
import ssl
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from servertools import ServeProcess, poll, stop_process

from unitytools import (CORE, CSHARP, PKG, RUNTIME, S3, S4, SAMPLES, STANDIN,  # noqa: F401
                       VECTORS, ROOT, _compile, _LiveClient, _mono_tools, _serve_help,
                       PACKAGE_NAME)

@pytest.fixture(scope="session")
def contract_exe(build_dir):
    return _compile(build_dir / "ContractTest.exe", [*CORE, CSHARP / "Checks.cs", CSHARP / "ContractTest.cs"])


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
    from provider.core.geometry import sh

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
    """The same checks on vectors generated here from provider.core.geometry.sh (always available)."""
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
                "parser_invariant_culture", "subscribe_message", "uri",
                # lights (docs/contract.md §10): one-sided directional lights in Unity's frame, Unity's Lambert
                # with the colour/intensity mapping in each colour-space mode, ambient-only SH9
                "light_split", "light_direction_unity", "light_forward", "light_color_range",
                "light_radiance_LinearIntensity", "light_radiance_GammaIntensity", "light_radiance_Gamma",
                "light_ambient_only", "light_not_drawn_full_sh", "light_intensity_multiplier",
                "light_without_ambient", "two_lights", "two_lights_first_drawn", "lights_parser_accepts",
                "lights_parser_rejects", "no_allocation_per_frame"}
    assert expected <= set(checks), expected - set(checks)
    assert all(c["ok"] for c in checks.values())
    # the matrix algebra is exact to rounding; irradiance agrees to the constants' 6 digits
    assert checks["unity_matrices"]["max_rel"] == 0.0
    assert checks["rotated_matrices_unity"]["max_rel"] < 1e-14
    assert checks["irradiance_unity"]["max_rel"] < 1e-6
    assert checks["ambient_shadesh9_from_matrices"]["max_rel"] < 1e-6
    # a white Lambertian surface facing the light shows ρE/π through Unity's Lambert to float rounding
    for mode in ("LinearIntensity", "GammaIntensity", "Gamma"):
        assert checks[f"light_radiance_{mode}"]["max_rel"] < 1e-6
    _print_agreement("generated vectors", report)


def _print_agreement(label, report):
    rows = ", ".join(f"{k} {v['max_rel']:.1e}" for k, v in report["checks"].items() if v["tolerance"] > 0)
    print(f"\n{label}: {report['cases']} cases; max relative error: {rows}")


def test_csharp_ambient_factors_match_the_python_constants():
    """The k factors in Sh9Math.cs are basis constant × Â_l/π of provider.core.geometry.sh (docs/contract.md §7)."""
    from provider.core.geometry import sh
    text = (PKG / "Runtime" / "Core" / "Sh9Math.cs").read_text()
    block = re.search(r"UnityAmbientFactors =\s*\{(.*?)\};", text, re.S).group(1)
    k = [float(v) for v in re.findall(r"^\s*([0-9.]+),", block, re.M)]
    basis = np.array([sh.C0, sh.C1, sh.C1, sh.C1, sh.C2, sh.C2, sh.C20, sh.C2, sh.C22])
    assert len(k) == 9
    assert np.allclose(k, basis * sh.A_HAT_PER_COEFF / math.pi, rtol=2e-6)
    # and the magnitudes of docs/contract.md §7's signed table
    design = [0.282095, -0.325735, 0.325735, -0.325735, 0.273137, -0.273137, 0.078848, -0.273137, 0.136569]
    assert np.allclose(k, np.abs(design), atol=1e-6)


# ---- Unity-facing code against the stand-in --------------------------------------------------

def test_monobehaviours_compile_against_standin(build_dir):
    """SH9LightingClient and the sample script type-check against the UnityEngine stand-in."""
    assert RUNTIME and SAMPLES
    _compile(build_dir / "Runtime.dll", [*CORE, *RUNTIME, *SAMPLES, STANDIN], target="library")


# Patterns Unity's compiler rejects because the member is a property returning a struct (CS1612:
# "Cannot modify the return value of ... because it is not a variable"), a property passed by ref
# (CS0206), or a generic constraint. The stand-in must reject them too, or a package change that Unity would not compile
# passes here. Each line alone, compiled against the stand-in, must fail with that error.
UNITY_REJECTS = {
    "RenderSettings.ambientProbe[0, 0] = 1f;": "CS1612",
    "new GameObject(\"g\").transform.rotation.x = 1f;": "CS1612",
    "new GameObject(\"g\").transform.position.y = 1f;": "CS1612",
    "new GameObject(\"g\").AddComponent<Light>().color.r = 1f;": "CS1612",
    "new Material((Shader)null).color.g = 1f;": "CS1612",
    "Bump(ref new GameObject(\"g\").AddComponent<Light>().intensity);": "CS0206",
    # generic constraints as Unity declares them (GameObject.AddComponent<T> where T : Component)
    "new GameObject(\"g\").AddComponent<System.Text.StringBuilder>();": "CS0311",
}


def test_standin_rejects_what_unity_rejects(tmp_path):
    """The stand-in declares properties where Unity has properties: assigning through them fails."""
    # control: the harness compiles when the line is valid
    ok_lines = ["var sh = RenderSettings.ambientProbe; sh[0, 0] = 1f; RenderSettings.ambientProbe = sh;",
                "var t = new GameObject(\"g\").transform; var q = t.rotation; q.x = 1f; t.rotation = q;",
                "var m = new Matrix4x4(); m[1, 2] = 3f; Matrix4x4 copy = m; copy[1, 2] = 4f;"
                " if (m[1, 2] != 3f || m.m12 != 3f) throw new System.Exception(\"not a value type\");"]
    lines = {**{l: None for l in ok_lines}, **UNITY_REJECTS}
    for i, (line, code) in enumerate(lines.items()):
        src = tmp_path / f"probe{i}.cs"
        src.write_text("using UnityEngine; using UnityEngine.Rendering;\n"
                       "static class Probe { static void Bump(ref float v) { v += 1; }\n"
                       f"  static void Main() {{ {line} }} }}\n")
        mcs, _ = _mono_tools()
        r = subprocess.run([mcs, "-nologo", "-target:exe", f"-out:{tmp_path / f'probe{i}.exe'}", str(STANDIN), str(src)],
                           capture_output=True, text=True, timeout=120)
        if code is None:
            assert r.returncode == 0, f"valid line did not compile: {line}\n{r.stdout}{r.stderr}"
        else:
            assert r.returncode != 0 and code in r.stdout + r.stderr, \
                f"the stand-in accepts what Unity rejects ({code}): {line}\n{r.stdout}{r.stderr}"


def test_mrtk_ambient_helper(build_dir):
    """SH9MrtkAmbient switches on the "Spherical Harmonics" toggle (property and keyword) of MRTK2
    and MRTK3 Graphics Tools materials so that the ambient probe reaches them, reports MRTK3
    materials on which it cannot show (unlit), moves renderers off baked light probes, leaves other
    materials alone, and puts everything back on disable (the materials are shared assets)."""
    exe = _compile(build_dir / "MrtkAmbientTest.exe", [*CORE, *RUNTIME, STANDIN, CSHARP / "MrtkAmbientTest.cs"])
    _, mono = _mono_tools()
    r = subprocess.run([mono, str(exe)], capture_output=True, text=True, timeout=60)
    report = json.loads(r.stdout.strip().splitlines()[-1])
    assert r.returncode == 0 and not report["failures"], json.dumps(report, indent=1)
    assert {"mrtk2_switched_on", "mrtk3_switched_on", "others_untouched", "unlit_reported", "light_probes_off",
            "restored", "scope_whole_scene", "static_helper", "reflections_opt_in", "reflections_switched_on",
            "reflections_others_untouched", "reflections_counts", "reflections_faint_reported", "reflections_restored",
            "reflections_static_helper", "mrtk2_lod_curve"} <= set(report["checks"])


def test_mrtk_shader_names_match_their_sources():
    """The shader, property and keyword names the helper looks for, as read in MRTK2's
    MixedRealityStandard.shader and MRTK3 Graphics Tools' GraphicsToolsStandard*.shader (cited in
    Sh9MrtkShaders.cs); a typo here would make the helper silently skip every material."""
    text = (PKG / "Runtime" / "Core" / "Sh9MrtkShaders.cs").read_text()
    rows = re.findall(r'new Sh9AmbientSwitch\("([^"]+)", "([^"]+)", "([^"]+)", (\w+)', text)
    assert {r[0]: r[1:] for r in rows} == {
        "Mixed Reality Toolkit/Standard": ("_SphericalHarmonics", "_SPHERICAL_HARMONICS", "null"),
        "Graphics Tools/Standard": ("_SphericalHarmonics", "_SPHERICAL_HARMONICS", "GraphicsToolsLit"),
        "Graphics Tools/Non-SRP/StandardNonSrp": ("_SphericalHarmonics", "_SPHERICAL_HARMONICS", "GraphicsToolsLit"),
        "Graphics Tools/Standard Canvas": ("_SphericalHarmonics", "_SPHERICAL_HARMONICS", "GraphicsToolsLit"),
        "Graphics Tools/Non-SRP/Standard CanvasNonSrp": ("_SphericalHarmonics", "_SPHERICAL_HARMONICS", "GraphicsToolsLit"),
    }
    assert 'GraphicsToolsLit = { "_DIRECTIONAL_LIGHT", "_DISTANT_LIGHT" }' in text
    # the "Reflections" toggle: MRTK2 MixedRealityStandard.shader line 31 and GraphicsToolsStandard*.shader
    # line 40 both read `[Toggle(_REFLECTIONS)] _Reflections("Reflections", Float) = 0.0`
    assert 'ReflectionsProperty = "_Reflections"' in text and 'ReflectionsKeyword = "_REFLECTIONS"' in text
    models = re.findall(r'new Sh9AmbientSwitch\("([^"]+)",[^;]*?Sh9MrtkReflectionModel\.(\w+)\)', text, re.S)
    assert dict(models) == {"Mixed Reality Toolkit/Standard": "Mrtk2", "Graphics Tools/Standard": "GraphicsTools",
                            "Graphics Tools/Non-SRP/StandardNonSrp": "GraphicsTools",
                            "Graphics Tools/Standard Canvas": "GraphicsTools",
                            "Graphics Tools/Non-SRP/Standard CanvasNonSrp": "GraphicsTools"}


def test_core_has_no_unity_dependency(build_dir):
    """The core compiles alone (no UnityEngine), as its asmdef's noEngineReferences promises."""
    for f in CORE:
        assert "UnityEngine" not in re.sub(r"//.*", "", f.read_text()), f.name
    _compile(build_dir / "Core.dll", CORE, target="library")
    asmdef = json.loads((PKG / "Runtime" / "Core" / "Shlight.SH9Lighting.Core.asmdef").read_text())
    assert asmdef["noEngineReferences"] is True


# ---- the package's client against a live `shlight serve` ---------------------------------------

Z_ODD = [2, 5, 7]       # L10, L2-1, L21 change sign under z -> -z


def _unity_coefficients(coefficients: np.ndarray) -> np.ndarray:
    """(9, 3) wire coefficients in Unity's frame (x, y, -z): the z-odd ones negated."""
    c = np.array(coefficients, np.float64).reshape(9, 3)
    c[Z_ODD] *= -1
    return c


def _ambient_from_coefficients(unity_coeffs: np.ndarray) -> np.ndarray:
    """SphericalHarmonicsL2 layout [9 * rgb + i] = k_i · L_i (Python side of the conversion)."""
    from provider.core.geometry import sh
    k = np.array([sh.C0, sh.C1, sh.C1, sh.C1, sh.C2, sh.C2, sh.C20, sh.C2, sh.C22]) * sh.A_HAT_PER_COEFF / math.pi
    return (k[:, None] * unity_coeffs).T.reshape(-1)


def _shade_sh9(ambient: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """UnityCG.cginc ShadeSH9 (linear) on a SphericalHarmonicsL2, normals (N, 3) in Unity's frame."""
    c = np.asarray(ambient, np.float64).reshape(3, 9)
    x, y, z = normals.T
    basis = np.stack([np.ones_like(x), y, z, x, x * y, y * z, 3 * z * z - 1, x * z, x * x - y * y], 1)
    # SHA.w = c0 - c6 and SHB.z = 3 c6: the same as c6 · (3z² - 1)
    return basis @ c.T


def _quaternion_matrix(q) -> np.ndarray:
    x, y, z, w = np.asarray(q, np.float64) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _equirect_direction(u: float, v: float) -> np.ndarray:
    """docs/contract.md §1: the right-handed direction of equirect pixel centre (u, v)."""
    theta, phi = math.pi * v, 2 * math.pi * (u - 0.5)
    return np.array([math.sin(phi) * math.sin(theta), math.cos(theta), -math.cos(phi) * math.sin(theta)])


def _irradiance_rgb(ev: dict, n: np.ndarray) -> np.ndarray:
    """E(n) = ñᵀ M ñ of the matrices a client applied (n in Unity's frame)."""
    m = np.array(ev["matrices"]).reshape(3, 4, 4)
    nt = np.append(n / np.linalg.norm(n), 1.0)
    return np.einsum("i,cij,j->c", nt, m, nt)


def _write_panorama(path: Path, u: float, v: float, colour) -> None:
    """A 64×32 equirect (8-bit PNG) with one bright patch centred at (u, v), written atomically
    (the image source re-reads the file when it changes)."""
    import cv2
    img = np.full((32, 64, 3), 30, np.uint8)
    cx, cy = int(u * 64), int(v * 32)
    img[cy - 3:cy + 3, cx - 4:cx + 4] = colour
    tmp = path.with_name(path.stem + ".tmp.png")
    assert cv2.imwrite(str(tmp), np.ascontiguousarray(img[..., ::-1]))
    os.replace(tmp, path)


#: Room lightings that differ, each a bright patch at (u, v) off the z = 0 plane (so the z-odd
#: terms matter): _write_panorama's (u, v, colour).
SCENES = {"A": (0.65, 0.30, (255, 190, 90)), "B": (0.20, 0.70, (80, 140, 255)),
          "C": (0.90, 0.20, (250, 250, 250))}


class _SceneLightings:
    """The coefficients compute_sh9 gives for some of SCENES (panoramas written to
    ``tmp_path``/NAME.png), to tell which scene a LiveClient event shows."""

    def __init__(self, tmp_path: Path, names: str):
        from provider import compute_sh9
        self.coefficients = {}
        for name in names:
            path = tmp_path / f"{name}.png"
            _write_panorama(path, *SCENES[name])
            self.coefficients[name] = compute_sh9(str(path)).coefficients

    def shown(self, ev, name: str) -> bool:
        """Whether the event's wire coefficients are scene ``name``'s (to 1e-9 of their scale)."""
        want = self.coefficients[name]
        got = np.array(ev["wire_coefficients"]).reshape(9, 3)
        return np.allclose(got, want, rtol=0, atol=1e-9 * np.abs(want).max())


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class _Relay:
    """A TCP relay on 127.0.0.1 in front of a server: the network between headset and PC. With ``tls``
    (an ssl.SSLContext) it terminates TLS, as a TLS proxy (nginx, stunnel) in front of ``shlight serve``
    does. ``hold()`` turns every open connection into a black hole: bytes stop passing either way and
    nothing is closed, as when the headset slept and its Wi-Fi connection died unnoticed. Connections
    made afterwards pass normally."""

    def __init__(self, target_port: int, tls=None):
        self.target_port, self.tls = target_port, tls
        self.listener = socket.socket()
        self.listener.bind(("127.0.0.1", 0))
        self.listener.listen(16)
        self.port = self.listener.getsockname()[1]
        self.pairs: list[dict] = []
        self.handshake_errors: list[str] = []
        self.closed = False
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self):
        while not self.closed:
            try:
                client, _ = self.listener.accept()
            except OSError:
                return
            threading.Thread(target=self._serve, args=(client,), daemon=True).start()

    def _serve(self, client):
        if self.tls is not None:
            try:
                client.settimeout(10)
                client = self.tls.wrap_socket(client, server_side=True)
                client.settimeout(None)
            except (OSError, ValueError) as exc:
                self.handshake_errors.append(str(exc))
                client.close()
                return
        try:
            upstream = socket.create_connection(("127.0.0.1", self.target_port), timeout=10)
            upstream.settimeout(None)
        except OSError:
            client.close()
            return
        # OpenSSL forbids SSL_read and SSL_write on one connection at once (the two pumps
        # would: now and then bytes were lost): the TLS side's reads and writes take turns,
        # and its reader waits for data outside its turn.
        pair = {"held": False, "socks": (client, upstream),
                "tls_turn": threading.Lock() if self.tls is not None else None}
        self.pairs.append(pair)
        for a, b in ((client, upstream), (upstream, client)):
            threading.Thread(target=self._pump, args=(a, b, pair), daemon=True).start()

    @staticmethod
    def _pump(a, b, pair):
        turn = pair["tls_turn"]
        a_turn = turn if a is pair["socks"][0] else None
        b_turn = turn if b is pair["socks"][0] else None
        try:
            while True:
                if a_turn is not None:
                    if not a.pending() and not select.select([a], [], [], 0.05)[0]:
                        continue
                    with a_turn:        # not blocking in its turn: a record that is not
                        a.setblocking(False)    # data (a ticket) would hold the writer
                        try:
                            data = a.recv(65536)
                        except ssl.SSLWantReadError:
                            continue
                        finally:
                            a.setblocking(True)
                else:
                    data = a.recv(65536)
                if not data:
                    break
                if not pair["held"]:
                    if b_turn is not None:
                        with b_turn:
                            b.sendall(data)
                    else:
                        b.sendall(data)
        except (OSError, ValueError):          # ValueError: select on a closed socket
            pass
        if not pair["held"]:
            for sock in (a, b):
                try:
                    sock.close()
                except OSError:
                    pass

    def hold(self) -> int:
        for pair in self.pairs:
            pair["held"] = True
        return len(self.pairs)

    def close(self):
        self.closed = True
        self.listener.close()
        for pair in self.pairs:
            for sock in pair["socks"]:
                try:
                    sock.close()
                except OSError:
                    pass


class _Serve(ServeProcess):
    """``shlight serve`` on a fixed port (so that it can come back on it), started at once."""

    def __init__(self, port: int, image: Path, token: str):
        super().__init__("--source", str(image), "--port", str(port), "--token", token,
                         "--fps", "10", "--keepalive", "0.25", "--stale-after", "0.5",
                         "--reconnect-max", "0.5", "--log-level", "info")
        self.__enter__()

    def latest(self, token: str) -> dict:
        import urllib.request
        with urllib.request.urlopen(f"{self.http}/latest.json?probe=default&token={token}",
                                    timeout=10) as r:
            return json.loads(r.read())

    def kill(self) -> None:
        """Like a crash: no close frames to the clients."""
        if self.proc.poll() is None:
            self.proc.kill()
        self.stop()


def _check_applied(ev: dict, *, rotation=None, intensity: float = 1.0):
    """What the client uploaded equals the Python conversion of the coefficients it received."""
    from provider.core.geometry import sh
    coeffs = np.array(ev["wire_coefficients"]).reshape(9, 3)
    wire_m = np.array(ev["wire_matrices"]).reshape(3, 4, 4)
    applied = np.array(ev["matrices"]).reshape(3, 4, 4)          # float32 read back from the stand-in
    ambient = np.array(ev["ambient"])
    M = sh.irradiance_matrices(coeffs)
    scale = np.abs(M).max()
    assert np.allclose(wire_m, M, rtol=0, atol=1e-9 * scale), "the server's matrices disagree with its coefficients"
    expected = S4 @ M @ S4                                         # Unity's frame: (x, y, -z)
    lu = _unity_coefficients(coeffs)
    if rotation is not None:
        expected = sh.rotate_matrices(expected, rotation)            # M' = R̃ M R̃ᵀ
        lu = sh.rotate_coefficients(lu, rotation)
    expected = expected * intensity
    assert np.allclose(applied, expected, rtol=0, atol=2e-7 * scale * intensity), \
        f"applied matrices: max error {np.abs(applied - expected).max():.3g} (scale {scale:.3g})"
    # the ambient probe: k_i · L_i in Unity's frame (agreeing to the 6 digits of the R&H constants
    # c1..c5, which the client's path through the matrices uses); ShadeSH9 on it gives E/π
    expected_ambient = _ambient_from_coefficients(lu) * intensity
    assert np.allclose(ambient, expected_ambient, rtol=0, atol=3e-6 * np.abs(expected_ambient).max()), \
        f"ambient probe: max error {np.abs(ambient - expected_ambient).max():.3g}"
    normals = sh.fibonacci_sphere(64)
    e_matrix = np.stack([np.einsum("ni,ij,nj->n", np.c_[normals, np.ones(len(normals))], expected[c],
                                   np.c_[normals, np.ones(len(normals))]) for c in range(3)], 1)
    assert np.allclose(_shade_sh9(ambient, normals), e_matrix / math.pi, rtol=0, atol=1e-6 * scale * intensity)
    assert ev["has_lighting"] is True and ev["ambient_mode"] == "Skybox"


def test_live_client_against_shlight_serve(live_exe, tmp_path):
    """LiveClient.exe (package Runtime code + the compile-only stand-in, NOT Unity) against a real
    `shlight serve` over a real WebSocket: live messages converted and applied like in Unity, the
    source lost (stale, last lighting kept) and back (fresh), the server killed and restarted (the
    client reconnects by itself), a rotated transform with the token in the query, a wrong token."""

    token = "s3cret-token"
    port = _free_port()
    image = tmp_path / "room.png"
    url = f"ws://127.0.0.1:{port}/"
    is_scene = _SceneLightings(tmp_path, "ABC").shown

    q = np.array([0.2, 0.5, -0.1, 0.8], np.float32)   # transform.rotation of the rotated client
    rotation = _quaternion_matrix(q.astype(np.float64))
    _write_panorama(image, *SCENES["A"])
    clients, servers = [], []
    t0 = time.monotonic()
    try:
        servers.append(_Serve(port, image, token))
        main = _LiveClient(live_exe, url, token, "default", "50")
        rotated = _LiveClient(live_exe, url, token, "default", "50", *map(str, q.tolist()),
                              "--token-in-query", "--intensity=2")
        intruder = _LiveClient(live_exe, url, "not-the-token", "default", "50")
        clients += [main, rotated, intruder]

        # 1. live: state Live, values converted to Unity's frame exactly as Python does it
        i, ev = main.wait_for("a live message", lambda e: e["event"] == "applied" and not e["stale"])
        assert ev["state"] == "Live" and ev["connections"] == 1 and ev["hello_probes"] == 1
        assert ev["probe"] == "default" and is_scene(ev, "A"), "the client did not get image A's lighting"
        _check_applied(ev)
        # parsing: the client's numbers are the server's, to the last bit
        latest = servers[0].latest(token)
        assert ev["wire_coefficients"] == latest["coefficients"] and ev["wire_matrices"] == latest["matrices"]
        main.wait_for("state Live", lambda e: e["event"] == "state" and e["state"] == "Live")
        _, rev = rotated.wait_for("a live message (rotated client)", lambda e: e["event"] == "applied" and not e["stale"])
        _check_applied(rev, rotation=rotation, intensity=2.0)
        # one-sided light, independent of the algebra above: the patch of image A lies along d
        # (docs/contract.md §1), so Unity sees it along (x, y, -z), and the rotated client along R (x, y, -z)
        d_unity = _equirect_direction(*SCENES["A"][:2]) @ S3
        e_main = _irradiance_rgb(ev, d_unity), _irradiance_rgb(ev, -d_unity)
        assert np.all(e_main[0] > 1.5 * e_main[1]) and e_main[0][0] > 5 * e_main[1][0], e_main  # orange light
        assert np.allclose(_irradiance_rgb(rev, rotation @ d_unity), 2 * e_main[0], rtol=1e-5)
        assert np.allclose(_irradiance_rgb(rev, -rotation @ d_unity), 2 * e_main[1], rtol=1e-5)
        live = main.wait_for("a later live message", lambda e: e["event"] == "applied" and not e["stale"], i + 1)[1]
        assert live["seq"] > ev["seq"]

        # 2. the source goes away: stale messages, state Stale, the last lighting kept
        n = len(main.events)
        os.replace(image, tmp_path / "gone.png")
        i, st = main.wait_for("a stale message", lambda e: e["event"] == "applied" and e["stale"], n)
        assert st["state"] == "Stale" and st["has_lighting"] and is_scene(st, "A")
        last_live = next(e for e in reversed(main.events[:i]) if e["event"] == "applied" and not e["stale"])
        assert st["matrices"] == last_live["matrices"] and st["ambient"] == last_live["ambient"], \
            "the client changed the lighting while stale"
        main.wait_for("state Stale", lambda e: e["event"] == "state" and e["state"] == "Stale", n)
        _, st2 = main.wait_for("a later stale message", lambda e: e["event"] == "applied" and e["stale"], i + 1)
        assert st2["seq"] > st["seq"] and st2["wire_age_s"] > st["wire_age_s"] > 0
        assert st2["matrices"] == last_live["matrices"]

        # 3. the source comes back with new content: fresh messages resume by themselves
        n = len(main.events)
        _write_panorama(image, *SCENES["B"])
        i, fresh = main.wait_for("fresh messages after the source returned",
                                 lambda e: e["event"] == "applied" and not e["stale"], n)
        assert fresh["state"] == "Live" and is_scene(fresh, "B") and fresh["connections"] == 1
        _check_applied(fresh)
        assert fresh["matrices"] != last_live["matrices"]
        main.wait_for("state Live again", lambda e: e["event"] == "state" and e["state"] == "Live", n)

        # 4. the server dies; it comes back on the same port with other lighting: the client
        #    reconnects by itself (backoff) and gets fresh messages from the new server
        n, rn = len(main.events), len(rotated.events)
        servers[0].kill()
        main.wait_for("a disconnected state after the server died",
                      lambda e: e["event"] == "state" and e["state"] in ("Disconnected", "Connecting"), n)
        _, down = main.wait_for("an error after the server died",
                                lambda e: e["event"] == "state" and e["error"], n)
        _write_panorama(image, *SCENES["C"])
        servers.append(_Serve(port, image, token))
        _, back = main.wait_for("a message after the server restarted",
                                lambda e: e["event"] == "applied" and e["connections"] == 2, n, timeout=30)
        if not is_scene(back, "C"):   # the very first one may be the new server's first frame; then C follows
            _, back = main.wait_for("image C after the restart", lambda e: e["event"] == "applied" and is_scene(e, "C"), n)
        assert back["state"] == "Live" and not back["stale"]
        _check_applied(back)
        _, relive = main.wait_for("state Live after the restart",
                                  lambda e: e["event"] == "state" and e["state"] == "Live", n)
        assert relive["error"] == "", "LastError should clear once a connection works"
        _, rback = rotated.wait_for("the rotated client reconnected",
                                    lambda e: e["event"] == "applied" and e["connections"] == 2 and is_scene(e, "C"),
                                    rn, timeout=30)
        _check_applied(rback, rotation=rotation, intensity=2.0)

        # 5. the wrong token: a clear error and state, never lighting, no crash
        _, refused = intruder.wait_for("the refused token",
                                       lambda e: e["event"] == "state" and e["handshake_status"] == 401)
        assert "token" in refused["error"] and refused["state"] == "Disconnected"
        assert not intruder.applied() and all(e["state"] != "Live" for e in intruder.events if "state" in e)

        # 6. clean shutdown: OnDisable restores the ambient mode; every process exits with 0
        for c in clients:
            assert c.quit() == 0, c.describe()
            exit_event = c.wait_for("the exit event", lambda e: e["event"] == "exit")[1]
            assert exit_event["ambient_mode_restored"] == "Trilight"
        assert main.events[-1]["received"] >= 3 and intruder.events[-1]["received"] == 0
        # 7. no garbage per frame: the component's Update allocated nothing on the main thread in
        #    steady frames (no state change or connection event), including frames that applied a
        #    new message, across live, stale, back-live and reconnected stretches
        for c in (main, rotated):
            ex = c.events[-1]
            print(f"\nallocations ({' '.join(c.args[4:]) or 'main'}): {ex['steady_alloc_bytes']} bytes in "
                  f"{ex['steady_frames']} steady frames ({ex['steady_applied_frames']} applied a new message; "
                  f"{ex['event_frames']} event frames not counted)")
            assert ex["steady_frames"] >= 20, ex
            assert ex["steady_alloc_bytes"] == 0, f"Update allocated in steady frames: {ex}"
        print(f"\nlive client: {len(main.applied())} applied events, {down['error']!r} while down, "
              f"refused: {refused['error']!r}; {time.monotonic() - t0:.1f} s")
    finally:
        for c in clients:
            c.kill()
        for s in servers:
            s.kill()


def test_live_client_allocates_nothing_per_frame(live_exe, tmp_path):
    """Zero managed allocations per frame in the steady state, measured under Mono: a server sending
    every frame at 30 fps (so that most frames apply a new message), a client on a rotated transform
    with Intensity 2, the ambient probe and a Directional Light to drive (switched off: no lights on
    the wire); Update bracketed by GC.GetAllocatedBytesForCurrentThread in LiveClient.cs."""
    image = tmp_path / "room.png"
    _write_panorama(image, 0.65, 0.30, (255, 190, 90))
    with ServeProcess("--source", str(image), "--fps", "30", "--change-threshold", "0", "--keepalive", "0.25") as server:
        client = _LiveClient(live_exe, server.url, "-", "default", "60", "0.2", "0.5", "-0.1", "0.8",
                             "--intensity=2", "--light")
        try:
            first, _ = client.wait_for("a live message", lambda e: e["event"] == "applied" and not e["stale"])
            # the client prints at most 4 applied messages a second: 16 more are 4 s or more of
            # its own frames, however busy the machine (it needs 100 steady frames, 30 applied)
            client.wait_for("16 more applied messages",
                            lambda e: sum(x["event"] == "applied" for x in client.events[first:]) > 16, first, timeout=60)
            assert client.quit() == 0, client.describe()
            ex = client.wait_for("the exit event", lambda e: e["event"] == "exit")[1]
        finally:
            client.kill()
    print(f"\nallocations per frame: {ex['steady_alloc_bytes']} bytes in {ex['steady_frames']} steady frames, "
          f"{ex['steady_applied_frames']} of which applied a new message (worst frame {ex['worst_steady_frame_bytes']} B; "
          f"{ex['event_frames']} event frames not counted)")
    assert ex["steady_frames"] >= 100 and ex["steady_applied_frames"] >= 30, ex
    assert ex["steady_alloc_bytes"] == 0, ex
    # the driven light was switched off (no lights on the wire) and restored on disable
    applied = [e for e in client.events if e["event"] == "applied"]
    assert applied and all(e["light"]["enabled"] is False and e["main_light_scale"] == 0 for e in applied)
    assert ex["light_restored"]["enabled"] is True and ex["light_restored"]["intensity"] == 1.25


def test_live_client_reconnects_at_once_on_resume(live_exe, tmp_path):
    """Suspend/resume as a HoloLens app meets it: while the app is suspended its connection dies
    without either side noticing (the relay turns it into a black hole) and the room's light
    changes. On resume (OnApplicationPause(false) + OnApplicationFocus(true)) the client reconnects
    at once and shows the new light; a client that gets no resume call (the control) stays on the
    dead connection, which only the 30 s receive watchdog would end. Focus coming back alone
    reconnects only when the stream has gone quiet, not after every system menu."""
    image = tmp_path / "room.png"
    is_scene = _SceneLightings(tmp_path, "AB").shown

    _write_panorama(image, *SCENES["A"])
    clients = []
    with ServeProcess("--source", str(image), "--fps", "10", "--keepalive", "0.25") as server:
        relay = _Relay(server.port)
        url = f"ws://127.0.0.1:{relay.port}/"
        try:
            app, control, menu = (_LiveClient(live_exe, url, "-", "default", "60") for _ in range(3))
            clients += [app, control, menu]
            for c in clients:
                c.wait_for("scene A", lambda e: e["event"] == "applied" and is_scene(e, "A"))

            # a system menu opens and closes on a healthy connection: no reconnect (its
            # focused event below says how many connections it had made by then)
            n = len(menu.events)
            menu.send("blur")
            n, _ = menu.wait_for("blurred", lambda e: e["event"] == "blurred", n)
            menu.send("focus")
            menu.wait_for("focus back", lambda e: e["event"] == "focused", n)

            # suspend: the app stops; its connection (and the others') dies silently; the room changes
            app.send("pause")
            app.wait_for("paused", lambda e: e["event"] == "paused")
            menu.send("blur")
            assert relay.hold() == 3
            _write_panorama(image, *SCENES["B"])

            n_app, n_control, n_menu = len(app.events), len(control.events), len(menu.events)
            app.send("resume")
            _, fresh = app.wait_for("scene B after resume",
                                    lambda e: e["event"] == "applied" and is_scene(e, "B"), n_app, timeout=10)
            assert fresh["connections"] == 2 and fresh["state"] == "Live" and fresh["has_lighting"]
            # at once on resume, not after the 30 s receive watchdog
            assert any("reconnecting now (app resumed)" in line for line in app.log), app.describe()

            # focus alone reconnects too, once the stream has been quiet longer than the
            # client's 2.5 s (FocusSilenceSeconds); each focus before that is a menu's, ignored
            def refocused():
                if any("reconnecting now" in line for line in menu.log):
                    return True
                menu.send("focus")
                return False
            poll(refocused, timeout=20, interval=0.5, what="the menu client to reconnect on focus")
            menu.wait_for("scene B after focus", lambda e: e["event"] == "applied" and is_scene(e, "B"), n_menu, timeout=10)
            # the lighting was kept (never the grey fallback) between resume and fresh data
            assert all(e["has_lighting"] for e in app.events[n_app:] if e["event"] == "applied")
            for c in clients:
                assert c.quit() == 0, c.describe()
            # the menu's first focus, on a live stream, made no second connection (the next
            # focus event counts them before its own call)
            focused = [e for e in menu.events if e["event"] == "focused"]
            assert focused[1]["connections"] == 1, "focus on a live stream reconnected"
            # the control, never told, stayed on the dead connection with the old light to the end
            assert not any(e["event"] == "applied" and is_scene(e, "B") for e in control.events[n_control:]), \
                "the control client got the new light without a resume: the relay did not hold its connection"
        finally:
            for c in clients:
                c.kill()
            relay.close()


def _srgb_to_linear(v: float) -> float:
    return v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4 if v < 1 else v ** 2.2


def test_live_client_drives_the_directional_light(live_exe, tmp_path):
    """docs/contract.md §10 end to end: `shlight serve --lights auto --max-lights 1` on a panorama with a small, very bright
    source sends a light; the component shows it on its Directional Light (forward = minus the
    direction toward the light, in Unity's frame), with colour × intensity = E/π (linear colour space,
    lightsUseLinearIntensity on), _SHMainLightScale 1, and gives the ambient probe and SH9 globals the
    ambient SH only."""
    if "--lights" not in _serve_help():
        pytest.skip("`shlight serve --help` lists no --lights: the provider does not send lights yet "
                    "(needs `shlight serve --lights auto` adding docs/contract.md §10's fields to each sh9 message)")
    from provider.core.geometry import sh
    import cv2
    image = tmp_path / "sun.png"
    img = np.full((64, 128, 3), 20, np.uint8)
    img[14:16, 95:97] = 255                      # a sun at u = 0.75 (wire +X), 48° above the horizon
    assert cv2.imwrite(str(image), img)
    with ServeProcess("--source", str(image), "--lights", "auto", "--max-lights", "1",
                      "--keepalive", "0.25") as server:
        client = _LiveClient(live_exe, server.url, "-", "default", "40", "--light", "--color-space=linear",
                             "--linear-intensity")
        try:
            _, ev = client.wait_for("a message with a light (--lights auto, a sun-like source)",
                                    lambda e: e["event"] == "applied" and e["lights"] >= 1, timeout=30)
            assert client.quit() == 0
        finally:
            client.kill()
    d = np.array(ev["wire_light_directions"][:3])
    e = np.array(ev["wire_light_irradiance"][:3])
    # The patch's centre (u = 96/128, v = 15/64): θ = 15π/64 from the zenith, toward +X.
    theta = math.pi * 15 / 64
    toward = np.array([math.sin(theta), math.cos(theta), 0.0])
    assert d @ toward > math.cos(math.radians(3)), f"the light should come from {toward}: {d}"
    lt = ev["light"]
    assert ev["light_active"] and lt["enabled"] and ev["main_light_scale"] == 1 and not lt["use_color_temperature"]
    # forward: where the light travels, in Unity's frame (x, y, -z)
    assert np.allclose(lt["forward"], -(d @ S3), atol=1e-5), (lt["forward"], d)
    # colour.linear × intensity = E/π: a white Lambertian surface facing it shows ρE/π in Unity
    seen = np.array([_srgb_to_linear(c) for c in lt["color"]]) * lt["intensity"]
    assert np.allclose(seen, e / math.pi, rtol=1e-4), (seen, e / math.pi)
    # the SH9 and the ambient probe carry the ambient only (one light: nothing folded back)
    amb = np.array(ev["wire_ambient_coefficients"]).reshape(9, 3)
    expected = S4 @ sh.irradiance_matrices(amb) @ S4
    applied = np.array(ev["matrices"]).reshape(3, 4, 4)
    if ev["lights"] == 1:
        assert np.allclose(applied, expected, rtol=0, atol=2e-7 * np.abs(expected).max())
        lu = _unity_coefficients(amb)
        assert np.allclose(ev["ambient"], _ambient_from_coefficients(lu), rtol=0, atol=3e-6 * np.abs(lu).max())
    full = S4 @ sh.irradiance_matrices(np.array(ev["wire_coefficients"]).reshape(9, 3)) @ S4
    assert not np.allclose(applied, full), "the SH9 globals still hold the light"


# ---- TLS (wss://) ---------------------------------------------------------------------------------

def _openssl(*args, cwd):
    exe = shutil.which("openssl")
    if not exe:
        pytest.skip("openssl is not installed (apt-get install openssl)")
    r = subprocess.run([exe, *args], cwd=cwd, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout


def _private_ca(folder: Path, names=("localhost",)) -> dict:
    """A private CA and a server certificate signed by it, for DNS ``names`` (what a PC on a LAN gets
    from an own CA): the shape of certificate the README asks for (subjectAltName with the host name,
    serverAuth, SHA-256, RSA 2048)."""
    folder.mkdir(parents=True, exist_ok=True)
    _openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-sha256", "-days", "2", "-keyout", "ca.key",
             "-out", "ca.pem", "-subj", "/CN=shlight test private CA",
             "-addext", "basicConstraints=critical,CA:TRUE", "-addext", "keyUsage=critical,keyCertSign,cRLSign", cwd=folder)
    _openssl("req", "-newkey", "rsa:2048", "-nodes", "-sha256", "-keyout", "server.key", "-out", "server.csr",
             "-subj", f"/CN={names[0]}", cwd=folder)
    (folder / "ext.cnf").write_text("subjectAltName=" + ",".join(f"DNS:{n}" for n in names) + "\n"
                                    "extendedKeyUsage=serverAuth\nbasicConstraints=CA:FALSE\n"
                                    "keyUsage=critical,digitalSignature,keyEncipherment\n")
    _openssl("x509", "-req", "-sha256", "-in", "server.csr", "-CA", "ca.pem", "-CAkey", "ca.key", "-CAcreateserial",
             "-out", "server.pem", "-days", "2", "-extfile", "ext.cnf", cwd=folder)
    return {"ca": folder / "ca.pem", "cert": folder / "server.pem", "key": folder / "server.key"}


def _mono_home(folder: Path, trusted_ca: Path | None) -> dict:
    """A HOME for the Mono client whose certificate store trusts ``trusted_ca`` (or nothing): Mono's
    TLS (BoringSSL) reads trusted roots from ~/.config/.mono/new-certs/Trust/<subject hash>.0, which is
    where Mono's cert-sync installs them. The client code is the same either way: only the device's
    trust store differs, as between a HoloLens with and without the private CA's root installed."""
    trust = folder / ".config" / ".mono" / "new-certs" / "Trust"
    trust.mkdir(parents=True, exist_ok=True)
    if trusted_ca is not None:
        h = _openssl("x509", "-hash", "-noout", "-in", str(trusted_ca), cwd=folder).strip()
        shutil.copy(trusted_ca, trust / f"{h}.0")
    return {"HOME": str(folder)}


def _check_tls_clients(live_exe, url, tmp_path, pki, expected_scene=None):
    """A client that trusts the CA gets live lighting over wss:// (converted exactly as over ws://);
    one whose store lacks the CA is refused with a message that says what certificate is needed."""
    trusted = _LiveClient(live_exe, url, "tls-token", "default", "40", env=_mono_home(tmp_path / "home-trusts", pki["ca"]))
    untrusted = _LiveClient(live_exe, url, "tls-token", "default", "40", env=_mono_home(tmp_path / "home-bare", None))
    try:
        _, ev = trusted.wait_for("live lighting over TLS", lambda e: e["event"] == "applied" and not e["stale"])
        assert ev["state"] == "Live" and ev["connections"] == 1
        _check_applied(ev)
        if expected_scene is not None:
            assert np.allclose(np.array(ev["wire_coefficients"]).reshape(9, 3), expected_scene, rtol=0,
                               atol=1e-9 * np.abs(expected_scene).max())
        _, refused = untrusted.wait_for("the untrusted certificate refused",
                                        lambda e: e["event"] == "state" and "TLS" in e["error"])
        assert refused["state"] == "Disconnected" and not untrusted.applied()
        assert "trusts" in refused["error"] and "localhost" in refused["error"], refused["error"]
        print(f"\nuntrusted certificate: {refused['error']!r}")
        assert trusted.quit() == 0 and untrusted.quit() == 0
    finally:
        trusted.kill()
        untrusted.kill()


def test_live_client_over_tls_behind_a_tls_proxy(live_exe, tmp_path):
    """wss:// through a TLS-terminating proxy in front of `shlight serve` (the set-up the README
    describes for servers without TLS of their own), with a certificate from a private CA: trusted
    when the CA's root is in the device's store, refused with a clear message when it is not."""
    import ssl
    from provider import compute_sh9
    pki = _private_ca(tmp_path / "pki")
    image = tmp_path / "room.png"
    _write_panorama(image, 0.65, 0.30, (255, 190, 90))
    tls = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
    tls.load_cert_chain(pki["cert"], pki["key"])
    with ServeProcess("--source", str(image), "--token", "tls-token", "--keepalive", "0.25") as server:
        relay = _Relay(server.port, tls=tls)
        try:
            _check_tls_clients(live_exe, f"wss://localhost:{relay.port}/", tmp_path, pki,
                               compute_sh9(str(image)).coefficients)
            # the wrong scheme either way is named as such
            plain_to_tls = _LiveClient(live_exe, f"ws://localhost:{relay.port}/", "tls-token", "default", "20")
            tls_to_plain = _LiveClient(live_exe, f"wss://localhost:{server.port}/", "tls-token", "default", "20",
                                       env=_mono_home(tmp_path / "home-trusts", pki["ca"]))
            try:
                _, a = plain_to_tls.wait_for("ws:// to a TLS port", lambda e: e["event"] == "state" and e["error"])
                _, b = tls_to_plain.wait_for("wss:// to a plain port", lambda e: e["event"] == "state" and e["error"])
                assert "must start with wss://" in a["error"], a["error"]
                assert "does not serve wss://" in b["error"], b["error"]
                assert plain_to_tls.quit() == 0 and tls_to_plain.quit() == 0
            finally:
                plain_to_tls.kill()
                tls_to_plain.kill()
        finally:
            relay.close()


def test_live_client_over_tls_served_by_shlight(live_exe, tmp_path):
    """wss:// served by `shlight serve --tls-cert FILE --tls-key FILE` itself, with a certificate from
    a private CA: trusted when the CA's root is in the device's store, refused clearly when not."""
    if "--tls-cert" not in _serve_help():
        pytest.skip("`shlight serve --help` lists no --tls-cert: the provider cannot serve wss:// yet "
                    "(needs `shlight serve --tls-cert FILE --tls-key FILE`)")
    import ssl
    from provider import compute_sh9
    pki = _private_ca(tmp_path / "pki")
    image = tmp_path / "room.png"
    _write_panorama(image, 0.65, 0.30, (255, 190, 90))
    port = _free_port()
    # started on a fixed port and waited for by a TLS handshake, not by its log line (which may
    # read wss:// where servertools.SERVING expects ws://)
    proc = subprocess.Popen([sys.executable, "-m", "provider.cli", "serve", "--source", str(image), "--port", str(port),
                             "--token", "tls-token", "--keepalive", "0.25",
                             "--tls-cert", str(pki["cert"]), "--tls-key", str(pki["key"])],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        ctx = ssl.create_default_context(cafile=str(pki["ca"]))
        deadline = time.monotonic() + 60
        while True:
            try:
                with socket.create_connection(("localhost", port), timeout=2) as raw, \
                        ctx.wrap_socket(raw, server_hostname="localhost"):
                    break
            except OSError:
                if proc.poll() is not None or time.monotonic() > deadline:
                    pytest.fail("shlight serve with --tls-cert did not accept a TLS connection:\n" +
                                (proc.stdout.read() if proc.poll() is not None else "(still running)"))
                time.sleep(0.2)
        _check_tls_clients(live_exe, f"wss://localhost:{port}/", tmp_path, pki, compute_sh9(str(image)).coefficients)
    finally:
        stop_process(proc, 15)


def test_live_client_times_out_on_a_silent_server(live_exe):
    """A server that accepts TCP but never answers the handshake (a wedged process, a captive
    portal): Mono's ConnectAsync ignores its cancellation token then, so the client keeps its own
    deadline (5 s), says so, and retries instead of hanging in Connecting forever."""
    with socket.socket() as silent:
        silent.bind(("127.0.0.1", 0))
        silent.listen(8)
        client = _LiveClient(live_exe, f"ws://127.0.0.1:{silent.getsockname()[1]}/", "tok", "default", "40")
        try:
            i, ev = client.wait_for("the connect timeout", lambda e: e["event"] == "state" and "no answer" in e["error"])
            assert ev["state"] == "Disconnected" and ev["handshake_status"] == 0
            client.wait_for("a retry", lambda e: e["event"] == "state" and e["state"] == "Connecting", i + 1)
            assert client.quit() == 0
        finally:
            client.kill()


# ---- shaders ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["sh9_irradiance.hlsl", "sh9_lights.hlsl"])
def test_hlsl_include_identical_to_shaders_dir(name):
    """The package's includes must never drift from shaders/ (sh9_lights.hlsl: the shadow catchers')."""
    a = (ROOT / "shaders" / name).read_bytes()
    b = (PKG / "Shaders" / name).read_bytes()
    assert a == b, (f"unity_package/Shaders/{name} differs from shaders/{name}: "
                    f"copy shaders/{name} over it")


# The shader's passes, variants, SRP Batcher layout and stereo are tested in tests/clients/unity/test_unity_shaders.py.


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
                   "UnityCG.cginc", "UndoCosineRescaling", "PackCoefficients", "URP",
                   # the sections a HoloLens/MRTK/URP user needs (issue 15) and the lights mapping (§10)
                   "SH9MrtkAmbient", "Spherical Harmonics", "Graphics Tools/Standard", "DepthOnly",
                   "depth priming", "UnityPerMaterial", "OnApplicationPause", "--tls-cert",
                   "subjectAltName", "fullchain", "lightsUseLinearIntensity", "gamma colour space",
                   "Nothing in this package has been run inside Unity"):
        assert needle in readme, needle


def test_meta_files_present_and_guids_unique():
    """Immutable (git URL) packages ignore assets without .meta; GUIDs must be unique."""
    guids = {}
    for p in _package_assets():
        meta = p.with_name(p.name + ".meta")
        assert meta.exists(), f"{meta.relative_to(ROOT)} missing: run python3 tests/clients/unity/test_unity.py --write-meta"
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
    mat = (PKG / "Samples~" / "BasicLighting" / "SH9 Diffuse White.mat").read_text()
    assert f"guid: {shader_guid}, type: 3" in mat


if __name__ == "__main__":
    if "--write-meta" in sys.argv:
        for m in write_missing_meta():
            print("wrote", m.relative_to(ROOT))
