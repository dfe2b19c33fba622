"""How each consumer of `shlight export` evaluates what it gets, for the export tests.

Each function re-implements one consumer's own evaluation from the source lines cited in its
docstring (revisions: provider/core/conventions/notes.py REVISIONS), independently of
provider/core/conventions/formats.py. three.js is not here: its own npm code runs in node
(tests/node/threejs_eval.mjs); Unity's ShadeSH9 also runs in C# (tests/csharp/ExportTest.cs).
Every function returns what a white Lambertian surface shows (E/π) at the given normals, in
the consumer's frame, RGB per normal.
"""
from __future__ import annotations

import json
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np

NODE_DIR = Path(__file__).resolve().parent / "node"

#: Babylon.js sphericalPolynomial.pure.ts:45-57: basis constants WITH Condon-Shortley signs.
BABYLON_CS_CONSTANTS = np.array([
    math.sqrt(1 / (4 * math.pi)),
    -math.sqrt(3 / (4 * math.pi)), math.sqrt(3 / (4 * math.pi)), -math.sqrt(3 / (4 * math.pi)),
    math.sqrt(15 / (4 * math.pi)), -math.sqrt(15 / (4 * math.pi)), math.sqrt(5 / (16 * math.pi)),
    -math.sqrt(15 / (4 * math.pi)), math.sqrt(15 / (16 * math.pi))])
#: hello_ar_java HelloArActivity.java:98-110 (Filament's IndirectLight::radiance factors).
ARCORE_SAMPLE_FACTORS = np.array([0.282095, -0.325735, 0.325735, -0.325735, 0.273137,
                                  -0.273137, 0.078848, -0.273137, 0.136569])
#: ARCore Unity SDK LightEstimateApi.cs:38-43 _shConstants.
ARCORE_UNITY_SDK_CONSTANTS = np.array([0.886227, 1.023328, 1.023328, 1.023328, 0.858086,
                                       0.858086, 0.247708, 0.858086, 0.429043])
TO_UNITY = np.array([1.0, 1.0, -1.0])          # ours (x, y, z) -> Unity (x, y, -z)


def _poly(c, v) -> np.ndarray:
    """Σ c_i P_i(v) with P = 1, y, z, x, yx, yz, 3z²−1, zx, x²−y²; c (9, 3), v (N, 3)."""
    x, y, z = v[:, 0:1], v[:, 1:2], v[:, 2:3]
    return (c[0] + c[1] * y + c[2] * z + c[3] * x + c[4] * (y * x) + c[5] * (y * z)
            + c[6] * (3 * z * z - 1) + c[7] * (z * x) + c[8] * (x * x - y * y))


def lambert_directional(normals, toward, irradiance, *, unity=False) -> np.ndarray:
    """A directional light on white Lambert: E⊥·max(0, n·l)/π (three.js, ARCore), or without
    the 1/π for Unity, whose diffuse BRDF has none (the light's colour carries it)."""
    d = np.asarray(toward, float)
    k = 1.0 if unity else 1.0 / math.pi
    return np.maximum(0.0, np.asarray(normals) @ d)[:, None] * np.asarray(irradiance)[None, :] * k


# ---- Unity -------------------------------------------------------------------------------------

def unity_probe(sh27) -> np.ndarray:
    """SphericalHarmonicsL2[rgb, i] = sh[rgb*9 + i] (SphericalHarmonicsL2.bindings.cs:73-79),
    returned coefficient-major (9, 3)."""
    return np.asarray(sh27, float).reshape(3, 9).T


def unity_pack(S) -> np.ndarray:
    """SHProperties.cs:31-44 / HDRP PackCoefficients (SphericalHarmonics.cs:123-142)."""
    c = np.zeros((7, 4))
    for rgb in range(3):
        c[rgb] = [S[3, rgb], S[1, rgb], S[2, rgb], S[0, rgb] - S[6, rgb]]
        c[3 + rgb] = [S[4, rgb], S[5, rgb], 3 * S[6, rgb], S[7, rgb]]
    c[6] = [S[8, 0], S[8, 1], S[8, 2], 1.0]
    return c


def shade_sh9(constants, n_unity) -> np.ndarray:
    """UnityCG.cginc:327-372 (linear colour space): SHEvalLinearL0L1 + SHEvalLinearL2."""
    k = np.asarray(constants, float).reshape(7, 4)
    SHA, SHB, SHC = k[0:3], k[3:6], k[6]
    out = []
    for n in np.asarray(n_unity, float):
        n4 = np.array([n[0], n[1], n[2], 1.0])
        vB = np.array([n[0] * n[1], n[1] * n[2], n[2] * n[2], n[2] * n[0]])  # n.xyzz * n.yzzx
        vC = n[0] * n[0] - n[1] * n[1]
        out.append(SHA @ n4 + SHB @ vB + SHC[:3] * vC)
    return np.array(out)


def unity_shown(sh27, n_unity) -> np.ndarray:
    return shade_sh9(unity_pack(unity_probe(sh27)), n_unity)


# ---- ARCore and OpenXR (Android) ---------------------------------------------------------------------

def arcore_sample(raw27, normals) -> np.ndarray:
    """hello_ar_java: HelloArActivity.java:809-835 (× factors) then environmental_hdr.frag
    :132-144 (polynomial, clamped ≥ 0); the 1/π is in the factors (:163-177)."""
    c = np.asarray(raw27, float).reshape(9, 3) * ARCORE_SAMPLE_FACTORS[:, None]
    return np.maximum(_poly(c, np.asarray(normals, float)), 0.0)


def arcore_unity_sdk_probe(raw27) -> np.ndarray:
    """ARCore Unity SDK LightEstimateApi.cs:125-159: negate j = 2, 5, 7; × _shConstants / π;
    the result is a SphericalHarmonicsL2 (coefficient-major here)."""
    c = np.asarray(raw27, float).reshape(9, 3).copy()
    c[[2, 5, 7]] *= -1
    return c * ARCORE_UNITY_SDK_CONSTANTS[:, None] / math.pi


def openxr_android_godot(coefficients_9x3, normals) -> np.ndarray:
    """Godot OpenXR vendors openxr_android_light_estimation.cpp:47-59, 347-352: ARCore's
    factors on coefficients[i][rgb], evaluated like the ARCore sample."""
    return arcore_sample(np.asarray(coefficients_9x3, float).reshape(-1), normals)


# ---- Babylon.js ---------------------------------------------------------------------------------------

def babylon_gltf(light, gltf_normals, handedness="left") -> np.ndarray:
    """Babylon.js loading an EXT_lights_image_based light: EXT_lights_image_based.pure.ts
    :121-148 (× intensity, ÷ π) → preScaledHarmonics (sphericalPolynomial.pure.ts:241-255,
    342-350, 430-431) → computeEnvironmentIrradiance at the Babylon world normal (z negated
    for a right-handed scene, materialHelper.functions.ts:931) × texture level (= intensity,
    :121-123; materialHelper :305) × albedo. glTF normals reach a left-handed scene through the
    root node (glTFLoader.pure.ts:762-768): (x, y, z) → (−x, y, z)."""
    inten = light["intensity"]
    h = np.asarray(light["irradianceCoefficients"], float) * inten / math.pi
    pre = h * BABYLON_CS_CONSTANTS[:, None]
    n = np.asarray(gltf_normals, float)
    v = n * (np.array([-1.0, 1.0, 1.0]) if handedness == "left" else np.array([1.0, 1.0, -1.0]))
    return _poly(pre, v) * inten


def babylon_gltf_cube(light, images) -> list:
    """The cube Babylon.js builds from an EXT_lights_image_based light: per mip, (6, n, n, 3)
    in texture storage order (face +X −X +Y −Y +Z −Z, row 0 = t = 0). Each image's bytes
    (EXT_lights_image_based.pure.ts:92-107; data URIs, glTFLoader.pure.ts:2781-2819) decoded as
    a texture with invertY (environmentTextureTools.pure.ts:610-621: the image's bottom row
    becomes storage row 0), then fromRGBD = pow(rgb, 2.2) / a (helperFunctions.ts:105,
    rgbdDecode.fragment.ts:10)."""
    import base64

    import cv2
    mips = []
    for k, faces in enumerate(light["specularImages"]):
        assert len(faces) == 6
        out = []
        for index in faces:
            uri = images[index]["uri"]
            assert uri.startswith("data:image/png;base64,")
            raw = np.frombuffer(base64.b64decode(uri.split(",", 1)[1]), np.uint8)
            bgra = cv2.imdecode(raw, cv2.IMREAD_UNCHANGED)
            assert bgra is not None and bgra.ndim == 3 and bgra.shape[2] == 4, "RGBD needs alpha"
            rgba = bgra[..., [2, 1, 0, 3]].astype(np.float64) / 255.0
            rgba = rgba[::-1]                                   # invertY
            out.append(rgba[..., :3] ** 2.2 / rgba[..., 3:4])
        mips.append(np.stack(out))
        assert mips[-1].shape[1] == light["specularImageSize"] >> k
    return mips


def babylon_lookup(gltf_directions, handedness="left") -> np.ndarray:
    """The vector Babylon.js looks its environment cube up with for a glTF-frame reflection
    direction: the root node's (x, y, z) → (−x, y, z) in a left-handed scene
    (glTFLoader.pure.ts:762-768), the lookup's z negated in a right-handed one
    (materialHelper.functions.ts:931, pbrBlockReflection.ts:39-41)."""
    d = np.asarray(gltf_directions, float)
    return d * (np.array([-1.0, 1.0, 1.0]) if handedness == "left" else np.array([1.0, 1.0, -1.0]))


def babylon_lod(roughness, size, mips) -> np.ndarray:
    """The PBR shader's reflection LOD: log2(size · α) · lodGenerationScale, α = roughness² +
    5e-4 (pbrHelperFunctions.ts:4, 9-10; pbrIBLFunctions.ts:5; pbrBlockReflection.ts:92-95),
    lodGenerationScale = (mips − 1)/log2(size) (EXT_lights_image_based.pure.ts:147)."""
    alpha = np.asarray(roughness, float) ** 2 + 0.0005
    return np.log2(size * alpha) * (mips - 1) / math.log2(size)


def babylon_sample(cube_mips, lookup, lod) -> np.ndarray:
    """textureLod(cube, lookup, lod): nearest texel on each level (the OpenGL face table,
    tests/reference_cube.py), linear between the two levels around lod, clamped to the levels
    given. lookup (N, 3), lod scalar or (N,)."""
    import reference_cube as ref
    lookup = np.asarray(lookup, float)
    lod = np.clip(np.broadcast_to(np.asarray(lod, float), lookup.shape[:1]), 0,
                  len(cube_mips) - 1)
    lo = np.floor(lod).astype(int)
    hi = np.minimum(lo + 1, len(cube_mips) - 1)
    w = (lod - lo)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):     # np.choose evaluates every face
        at = [m.reshape(-1, 3)[ref.texel_of(lookup, m.shape[1])] for m in cube_mips]
    pick = np.stack(at)                                             # (levels, N, 3)
    n = np.arange(lookup.shape[0])
    return pick[lo, n] * (1 - w) + pick[hi, n] * w


def babylon_webxr(sh27, babylon_normals) -> np.ndarray:
    """Babylon.js WebXRLightEstimation.pure.ts:399-402: updateFromFloatsArray → harmonics kept
    by updateFromHarmonics (sphericalPolynomial.pure.ts:430-431) → preScaledHarmonics → the SH
    shader path at the world normal (left-handed scene): no Â and no 1/π applied."""
    pre = np.asarray(sh27, float).reshape(9, 3) * BABYLON_CS_CONSTANTS[:, None]
    return _poly(pre, np.asarray(babylon_normals, float))


# ---- three.js, its own code in node --------------------------------------------------------------------

def three_available() -> str | None:
    """None when node and the pinned three.js are installed, else why not."""
    if shutil.which("node") is None:
        return "node is not installed (apt-get install nodejs npm; scripts/test.sh does)"
    if not (NODE_DIR / "node_modules" / "three").is_dir():
        return "three.js is not installed: npm ci --prefix tests/node (scripts/test.sh does)"
    return None


def run_three(request: dict) -> dict:
    """tests/node/threejs_eval.mjs: three.js's own SphericalHarmonics3 / XREstimatedLight."""
    res = subprocess.run([shutil.which("node"), "threejs_eval.mjs"], input=json.dumps(request),
                         capture_output=True, text=True, cwd=NODE_DIR, timeout=120, check=False)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


def three_shown(sh27, normals) -> np.ndarray:
    """LightProbe(intensity 1) → shGetIrradianceAt (three's getIrradianceAt) × BRDF_Lambert."""
    out = run_three({"mode": "sh", "sh": list(sh27), "normals": np.asarray(normals).tolist()})
    return np.array(out["irradiance"]) / math.pi


def three_xr_shown(webxr_export, normals):
    """three's XREstimatedLight fed the export as an XRLightEstimate (through a stand-in
    XRSession/XRFrame: the interface the polyfill provides); what it built, evaluated:
    LightProbe (getIrradianceAt / π) + DirectionalLight (WebGLLights.js:575-582 direction,
    lights_lambert_pars_fragment.glsl.js:11-18). Returns (shown, node's report)."""
    normals = np.asarray(normals, float)
    out = run_three({"mode": "xr", "normals": normals.tolist(), "estimate": {
        k: webxr_export[k] for k in ("sphericalHarmonicsCoefficients", "primaryLightDirection",
                                     "primaryLightIntensity")}})
    dl = out["directional"]
    toward = np.array(dl["position"]) - np.array(dl["target"])
    toward = toward / np.linalg.norm(toward)
    direct = lambert_directional(normals, toward, np.array(dl["color"]) * dl["intensity"])
    probe = np.array(out["irradiance"]) * out["probeIntensity"] / math.pi
    return probe + direct, out
