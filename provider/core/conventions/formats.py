"""Our SH9 lighting in each consumer's own convention (numpy only, no I/O).

Input everywhere is the contract (docs/contract.md §1-2, §10):

* ``coefficients``: (9, 3) raw radiance projections ``L_lm = ∫ L(ω) Y_lm(ω) dω``, order
  L00, L1-1, L10, L11, L2-2, L2-1, L20, L21, L22, real SH with Y1-1 = 0.488603 y,
  Y10 = 0.488603 z, Y11 = 0.488603 x (no Condon-Shortley phase), RGB columns, right-handed
  +Y up ("rh-y-up");
* ``lights`` (optional): ``(direction, rgb_irradiance)`` pairs: the unit vector TOWARD the
  light and the RGB irradiance on a surface facing it (§10 ``light_directions`` /
  ``light_irradiance``); their radiance is ``E⊥·δ(ω − d)``, so ``light_sh(d, E⊥) = E⊥ Y(d)``;
* ``ambient`` (optional): (9, 3) SH9 of everything but the lights (§10
  ``ambient_coefficients``); derived as ``coefficients − Σ light_sh`` when not given.

A white Lambertian surface must show E(n)/π in every consumer, with
E(n) = Σ Â_l L_lm Y_lm(n) (+ Σ E_k max(0, n·d_k) for lights exported as lights).

``export(coefficients, fmt, ...)`` returns a JSON-ready dict: the payload in the target's
layout plus fields that say what it is: ``convention``, ``basis`` (a token of
:data:`~provider.core.conventions.notes.BASES`), ``condon_shortley``, ``quantity``
(``radiance`` | ``irradiance`` | ``irradiance_over_pi``), ``frame``, ``units``, ``layout``,
``usage``, ``description`` and ``sources`` (:mod:`provider.core.conventions.notes`).
The main payload is always the complete lighting, except where the target's own API
splits an ambient SH from a main light that the consumer adds itself (webxr, arcore,
openxr-android): there the SH exclude the primary light (the brightest by Rec. 709
luminance); every other light stays in the SH.

Conversions (L = ours, per coefficient; CS = Condon-Shortley signs + − + − + − + − +,
MZ / MX = mirror z / x: + + − + + − + − + / + + + − − + + − +; Â = π, 2π/3 ×3, π/4 ×5;
|Y| = our basis constants; citations: the docstring of each function below):

=================  ====================  ===================  ==================
format             numbers               quantity             frame
=================  ====================  ===================  ==================
threejs            L                     radiance             rh-y-up
webxr              L (three.js reading)  radiance             rh-y-up
unity              MZ·Â·|Y|/π · L        irradiance ÷ π       unity-lh-y-up
arcore             CS · L                radiance             rh-y-up
gltf               CS·MX·Â · L (left)    irradiance           Babylon world
openxr-android     CS · L                radiance             rh-y-up (XrSpace)
=================  ====================  ===================  ==================
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..geometry import cubemap, sh
from .notes import BASES, NOTES
from ..errors import InputError
from ..radiometry.photometry import LUMINANCE_WEIGHTS as _REC709

FORMATS = ("threejs", "webxr", "unity", "arcore", "gltf", "openxr-android")

#: Our basis-function constants |Y_i| (docs/contract.md §1), per coefficient.
BASIS_CONSTANTS = np.array([sh.C0, sh.C1, sh.C1, sh.C1, sh.C2, sh.C2, sh.C20, sh.C2, sh.C22])
#: Â_l per coefficient (π, 2π/3, π/4).
A_HAT = np.asarray(sh.A_HAT_PER_COEFF, dtype=np.float64)
#: Sign of each coefficient in a Condon-Shortley-phased real basis relative to ours
#: (−1 on m = ±1: L1-1, L11, L2-1, L21). Filament, ARCore's sample, Babylon, HDRP use it.
CONDON_SHORTLEY = np.array([1, -1, 1, -1, 1, -1, 1, -1, 1], dtype=np.float64)
#: Coefficient signs under the mirror z → −z (z-odd: L10, L2-1, L21).
MIRROR_Z = np.array([1, 1, -1, 1, 1, -1, 1, -1, 1], dtype=np.float64)
#: Coefficient signs under the mirror x → −x (x-odd: L11, L2-2, L21).
MIRROR_X = np.array([1, 1, 1, -1, -1, 1, 1, -1, 1], dtype=np.float64)
#: Unity's per-coefficient factors |Y_i|·Â_l/π = 0.282095, 0.325735 ×3, 0.273137 ×2,
#: 0.078848, 0.273137, 0.136569 (docs/contract.md §7's k without its signs).
UNITY_FACTORS = BASIS_CONSTANTS * A_HAT / math.pi

#: Formats whose export carries the reflection cube (gltf specularImages, arcore
#: environmentalHdrCubeMap), and the edge of ARCore's cube (HelloArActivity.java:115).
CUBE_FORMATS = ("gltf", "arcore")
ARCORE_CUBE_SIZE = 16

_TO_UNITY = np.array([1.0, 1.0, -1.0])          # ours (x, y, z) -> Unity (x, y, -z)


# ---------------------------------------------------------------------- inputs

def _as_coefficients(coefficients, name: str = "coefficients") -> np.ndarray:
    c = np.asarray(coefficients, dtype=np.float64)
    if c.size == 27:
        c = c.reshape(9, 3)
    if c.shape != (9, 3):
        raise InputError(f"{name} must be 27 numbers (9 coefficients × RGB), got shape {c.shape}")
    if not np.all(np.isfinite(c)):
        raise InputError(f"{name} must be finite")
    return c


def _as_lights(lights) -> list[tuple[np.ndarray, np.ndarray]]:
    out = []
    for item in lights or ():
        d, e = item
        d = np.asarray(d, dtype=np.float64).reshape(3)
        e = np.asarray(e, dtype=np.float64).reshape(3)
        n = float(np.linalg.norm(d))
        if not math.isfinite(n) or n == 0.0:
            raise InputError("a light direction must be a finite, non-zero 3-vector")
        if not np.all(np.isfinite(e)) or np.any(e < 0):
            raise InputError("a light's irradiance must be 3 finite numbers >= 0")
        out.append((d / n, e))
    return out


def lights_from_fields(fields: Mapping) -> tuple[list[tuple[np.ndarray, np.ndarray]],
                                                 np.ndarray | None]:
    """The lights and the ambient SH of docs/contract.md §10's fields, if any.

    ``fields`` is a wire message dict or an ``SH9Result.stats`` mapping: ``lights`` (k),
    ``light_directions`` (3k numbers), ``light_irradiance`` (3k), and optionally
    ``ambient_coefficients`` (27). Returns ``(lights, ambient)`` for :func:`export`; no
    lights (``lights`` absent or 0) gives ``([], None)``.
    """
    k = fields.get("lights") or 0
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 0:
        raise InputError(f"'lights' must be a count >= 0, got {k!r}")
    if k == 0:
        return [], None
    try:
        dirs = np.asarray(fields["light_directions"], np.float64).reshape(k, 3)
        irr = np.asarray(fields["light_irradiance"], np.float64).reshape(k, 3)
    except KeyError as exc:
        raise InputError(f"'lights' is {k} but {exc.args[0]!r} is missing") from None
    except ValueError:
        raise InputError(f"'lights' is {k}: light_directions and light_irradiance must hold "
                         f"{3 * k} numbers each") from None
    ambient = fields.get("ambient_coefficients")
    if ambient is not None:
        ambient = _as_coefficients(ambient, "ambient_coefficients")
    return _as_lights(zip(dirs, irr)), ambient


def _as_radii(radii, k: int):
    """Angular radii (k,) in degrees, or None; InputError unless k finite numbers in [0, 90]."""
    if radii is None:
        return None
    try:
        r = np.asarray(radii, np.float64).reshape(k)
    except (TypeError, ValueError):
        raise InputError(f"light_angular_radius_deg must hold {k} numbers (one per light)") from None
    if not (np.all(np.isfinite(r)) and np.all((r >= 0) & (r <= 90))):
        raise InputError("a light's angular radius must be a finite number of degrees in [0, 90]")
    return r


def light_radii_from_fields(fields: Mapping, k: int):
    """``light_angular_radius_deg`` of a wire message (docs/contract.md §10) for its k lights,
    or None when the message has none (an older provider's, or an empty list beside k > 0:
    lights added to a message by hand); InputError for another count."""
    radii = fields.get("light_angular_radius_deg")
    if radii is None or k == 0 or (isinstance(radii, (list, tuple)) and not radii):
        return None
    return _as_radii(radii, k)


def light_sh(direction, irradiance) -> np.ndarray:
    """SH9 (9, 3) of a distant light: radiance E⊥·δ(ω − d), so L_lm = E⊥ Y_lm(d).

    Its SH9 irradiance is the order-2 approximation of E⊥·max(0, n·d) (docs/contract.md §10:
    ``coefficients = ambient_coefficients + Σ light_sh(d_k, E_k)``).
    """
    d = np.asarray(direction, dtype=np.float64).reshape(3)
    d = d / np.linalg.norm(d)
    return sh.sh_basis(d)[:, None] * np.asarray(irradiance, dtype=np.float64).reshape(1, 3)


def _primary(lights) -> int:
    return int(np.argmax([float(_REC709 @ e) for _, e in lights]))


def _sh_keeping(L, lights, ambient, keep) -> np.ndarray:
    """SH9 of the scene without the lights NOT in ``keep`` (those are exported as lights)."""
    keep = set(keep)
    if ambient is not None:
        base = _as_coefficients(ambient, "ambient").copy()
        for k, (d, e) in enumerate(lights):
            if k in keep:
                base += light_sh(d, e)
        return base
    base = L.copy()
    for k, (d, e) in enumerate(lights):
        if k not in keep:
            base -= light_sh(d, e)
    return base


def _without_primary(L, lights, ambient):
    """(SH without the primary light, primary direction, primary irradiance)."""
    p = _primary(lights)
    rest = _sh_keeping(L, lights, ambient, keep=[k for k in range(len(lights)) if k != p])
    return rest, lights[p][0], lights[p][1]


def _f(x) -> list:
    a = np.asarray(x, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        raise InputError("non-finite value in an export")
    return (a + 0.0).tolist()       # + 0.0: no -0.0 in the JSON


def _quat_from_to(a, b) -> np.ndarray:
    """Unit quaternion (x, y, z, w) rotating unit vector a onto unit vector b."""
    a = np.asarray(a, float) / np.linalg.norm(a)
    b = np.asarray(b, float) / np.linalg.norm(b)
    c = float(a @ b)
    if c < -1 + 1e-12:              # opposite: 180° about any perpendicular axis
        axis = np.cross(a, [1.0, 0.0, 0.0])
        if np.linalg.norm(axis) < 1e-6:
            axis = np.cross(a, [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return np.array([axis[0], axis[1], axis[2], 0.0])
    v = np.cross(a, b)
    q = np.array([v[0], v[1], v[2], 1.0 + c])
    return q / np.linalg.norm(q)


def unity_shader_constants(unity_sh) -> np.ndarray:
    """Pack SphericalHarmonicsL2 values (9, 3) into unity_SHAr..unity_SHC, shape (7, 4).

    The packing of the engine's GetShaderConstantsFromNormalizedSH as Unity's C# copies
    write it (com.unity.rendering.hybrid Unity.Rendering.Hybrid/Probes/SHProperties.cs:31-44;
    HDRP Runtime/Lighting/SphericalHarmonics.cs:123-142 PackCoefficients):
    SHA = (S3, S1, S2, S0 − S6), SHB = (S4, S5, 3·S6, S7), SHC = (S8.r, S8.g, S8.b, 1).
    """
    S = np.asarray(unity_sh, dtype=np.float64)
    out = np.zeros((7, 4))
    for c in range(3):
        out[c] = [S[3, c], S[1, c], S[2, c], S[0, c] - S[6, c]]
        out[3 + c] = [S[4, c], S[5, c], 3.0 * S[6, c], S[7, c]]
    out[6] = [S[8, 0], S[8, 1], S[8, 2], 1.0]
    return out


def _describe(fmt, convention, *, basis="sh9-real", condon_shortley, quantity, frame,
              frame_note, units="input-linear") -> dict:
    notes = NOTES[fmt]
    return {"format": fmt, "convention": convention, "basis": basis,
            "basis_note": BASES[basis], "condon_shortley": bool(condon_shortley),
            "quantity": quantity, "frame": frame, "frame_note": frame_note, "units": units,
            "units_note": "linear, in the input's units: coefficients in its radiance "
                          "units, irradiance in those times steradians (scene-referred for "
                          "HDR input, exposure-relative for 8-bit input)",
            "source_frame": "rh-y-up", "source_quantity": "radiance",
            "layout": notes["layout"], "usage": notes["usage"],
            "description": notes["description"], "sources": list(notes["sources"])}


_RH_NOTE = "right-handed, +Y up: the provider's own frame, unchanged"


# ---------------------------------------------------------------------- the formats

def _threejs(L, lights, ambient):
    """three.js ``SphericalHarmonics3.fromArray(sh)`` for a ``LightProbe``: identity.

    three r187 src/math/SphericalHarmonics3.js:84-109 (getAt: our constants and signs),
    :119-144 (getIrradianceAt applies Â_l, so ``sh`` is radiance), :274-286 (fromArray:
    coefficient i at offset 3i); lights_pars_begin.glsl.js:13-46 evaluates at the world
    normal; common.glsl.js:103-107 BRDF_Lambert = diffuse/π. DirectionalLight: position =
    toward the light (WebGLLights.js:575-582), color × intensity = irradiance
    (WebGLLights.js:328-332, lights_lambert_pars_fragment.glsl.js:11-18).
    """
    out = _describe("threejs", "threejs-r187", condon_shortley=False, quantity="radiance",
                    frame="rh-y-up", frame_note="three.js world: " + _RH_NOTE)
    out["sh"] = _f(L.reshape(-1))
    if lights:
        out["sh_ambient"] = _f(_sh_keeping(L, lights, ambient, keep=()).reshape(-1))
        out["directionalLights"] = [
            # the split XREstimatedLight.js:102-111 uses: color <= 1, intensity >= 1
            {"position": _f(d), "color": _f(e / max(1.0, float(e.max()))),
             "intensity": max(1.0, float(e.max()))} for d, e in lights]
    return out


def _webxr(L, lights, ambient):
    """``XRLightEstimate`` as three.js ``XREstimatedLight`` consumes it.

    sphericalHarmonicsCoefficients: order per lighting-estimation index.bs:188-190; three
    copies them verbatim into LightProbe.sh (XREstimatedLight.js:97) → our basis, radiance.
    The primary light is removed from the SH because XREstimatedLight adds it back as a
    DirectionalLight (XREstimatedLight.js:102-112), as ARCore's ambient SH and Chromium's
    OpenXR path (KIND_AMBIENT) exclude it. primaryLightDirection: toward the light, w = 0
    (index.bs:192); primaryLightIntensity: RGB irradiance, w = 1 (index.bs:194); with no
    light the spec's defaults {0, 1, 0, 0} and {0, 0, 0, 1}.
    """
    out = _describe("webxr", "webxr-threejs", condon_shortley=False, quantity="radiance",
                    frame="rh-y-up",
                    frame_note="XRLightProbe.probeSpace, taken to be the provider's world: "
                               + _RH_NOTE)
    d, e = np.array([0.0, 1.0, 0.0]), np.zeros(3)
    shc = L
    if lights:
        shc, d, e = _without_primary(L, lights, ambient)
    out["sphericalHarmonicsCoefficients"] = _f(shc.reshape(-1))
    out["primaryLightDirection"] = dict(zip("xyzw", _f([*d, 0.0])))
    out["primaryLightIntensity"] = dict(zip("xyzw", _f([*e, 1.0])))
    return out


def _unity(L, lights, ambient, radii=None):
    """Unity ``SphericalHarmonicsL2`` for ``RenderSettings.ambientProbe``.

    S[rgb, i] = MZ_i · L_i · Â_l · |Y_i| / π. Unity's own conversion to its SH format
    multiplies irradiance SH (Â_l L) by the basis constants and 1/π with no sign change
    (UnityCsReference Editor/Mono/GI/PostProcessing.bindings.cs:36-130); HDRP's signed
    kNormalizationConstants (Runtime/Lighting/SphericalHarmonics.cs:58-90) belong to its
    Condon-Shortley canonical SH and cancel. Packing SHProperties.cs:31-44 and ShadeSH9
    (UnityCG.cginc:327-372) return E/π. MZ: Unity is left-handed, (x, y, z) → (x, y, −z)
    (docs/contract.md §1; ARCore Unity SDK LightEstimateApi.cs:131-133, 148-151). Layout
    channel-major, SphericalHarmonicsL2.bindings.cs:16-20, 73-79 (index rgb*9 + i).
    Main light: forward = −(toward light) in Unity axes, colour = E⊥/π because Unity's
    BRDF lacks 1/π (LightEstimateApi.cs:111-122); ``angularDiameter`` (degrees, given the
    lights' angular radii) = 2 × the primary's radius: HDRP's
    ``HDAdditionalLightData.angularDiameter`` of a directional light (the softness of its
    shadows; the built-in pipeline and URP have no such field).
    """
    out = _describe("unity", "unity-sphericalharmonicsl2", basis="unity-sh9-premultiplied",
                    condon_shortley=False, quantity="irradiance_over_pi",
                    frame="unity-lh-y-up",
                    frame_note="Unity world: left-handed, +Y up; ours (x, y, z) -> (x, y, -z)")
    factors = (MIRROR_Z * UNITY_FACTORS)[:, None]
    S = factors * L
    out["sh"] = _f(S.T.reshape(-1))
    out["shaderConstants"] = _f(unity_shader_constants(S).reshape(-1))
    if lights:
        rest, d, e = _without_primary(L, lights, ambient)
        Sa = factors * rest
        out["sh_ambient"] = _f(Sa.T.reshape(-1))
        out["shaderConstantsAmbient"] = _f(unity_shader_constants(Sa).reshape(-1))
        du = d * _TO_UNITY
        out["mainLight"] = {"towardLight": _f(du), "forward": _f(-du),
                            "colorLinear": _f(e / math.pi), "intensity": 1.0}
        if radii is not None:
            out["mainLight"]["angularDiameter"] = 2.0 * float(radii[_primary(lights)])
    return out


def _arcore(L, lights, ambient, condon_shortley, environment=None):
    """The 27 numbers of ArLightEstimate_getEnvironmentalHdrAmbientSphericalHarmonics.

    Layout [r0, g0, b0, ..., r8, g8, b8] (arcore_c_api.h:5854-5869). Google's maintained
    sample multiplies them by {0.282095, −0.325735, 0.325735, −0.325735, 0.273137,
    −0.273137, 0.078848, −0.273137, 0.136569} (HelloArActivity.java:98-110, 809-835) and
    evaluates 1, y, z, x, yx, yz, 3z²−1, zx, x²−y² (environmental_hdr.frag:132-144): raw =
    radiance SH with Condon-Shortley phase, world frame = ours → c = CS · L. Main light:
    toward the light (default [0, 1, 0], arcore_c_api.h:5825-5838), intensity = irradiance
    (albedo/π · I · N·L, environmental_hdr.frag:117-129). ``condon_shortley=False``: the
    archived ARCore Unity SDK's reading (LightEstimateApi.cs:125-159), c = L.
    """
    sign = (CONDON_SHORTLEY if condon_shortley else np.ones(9))[:, None]
    out = _describe("arcore", "arcore-android-sample" if condon_shortley else "arcore-unity-sdk",
                    condon_shortley=condon_shortley, quantity="radiance", frame="rh-y-up",
                    frame_note="ARCore world: " + _RH_NOTE)
    d, e = np.array([0.0, 1.0, 0.0]), np.zeros(3)     # ARCore's "no estimate" values
    shc = L
    if lights:
        shc, d, e = _without_primary(L, lights, ambient)
        out["sphericalHarmonicsTotal"] = _f((sign * L).reshape(-1))
    out["sphericalHarmonics"] = _f((sign * shc).reshape(-1))
    out["mainLightDirection"] = _f(d)
    out["mainLightIntensity"] = _f(e)
    if environment is not None:
        out["environmentalHdrCubeMap"] = (_encoded(environment, "arcore").fields
                                          if isinstance(environment, EncodedCube)
                                          else _arcore_cube(environment[0]))
    return out


def _arcore_cube(radiance) -> dict:
    """``ArLightEstimate_acquireEnvironmentalHdrCubemap``'s six images: faces in GL order
    +X −X +Y −Y +Z −Z, each an RGBA_FP16 image laid out as GL_RGBA16F (arcore_c_api.h:5876-
    5892), uploaded row 0 first to GL_TEXTURE_CUBE_MAP_POSITIVE_X + i and looked up with the
    world reflection vector (hello_ar_java SpecularCubemapFilter.java:265-274,
    environmental_hdr.frag:156-158, 214-215): our layout unchanged, radiance including the
    main light (environmental_hdr.frag:22-26), 16² in Google's sample (HelloArActivity.java:115;
    SpecularCubemapFilter.java:256-263 refuses other sizes). Base64 of little-endian halves."""
    import base64
    cube = np.asarray(radiance, np.float32)
    if cube.ndim != 4 or cube.shape[0] != 6 or cube.shape[1] != cube.shape[2] or cube.shape[3] != 3:
        raise InputError(f"the ARCore cube must be (6, n, n, 3), got {cube.shape}")
    rgba = np.ones(cube.shape[:3] + (4,), np.float32)
    rgba[..., :3] = np.clip(cube, 0.0, 65504.0)
    half = rgba.astype("<f2")
    return {"size": int(cube.shape[1]), "format": "AIMAGE_FORMAT_RGBA_FP16",
            "faces": ["+X", "-X", "+Y", "-Y", "+Z", "-Z"],
            "images": [base64.b64encode(half[f].tobytes()).decode("ascii") for f in range(6)]}


@dataclass(frozen=True)
class EncodedCube:
    """The cube part of a format's export, encoded once (PNG or float16 bytes; the costly
    part) and reused by the exports of every message until the cube changes: pass it as
    :func:`export`'s ``environment``. Made by :func:`encode_cube`."""

    fmt: str
    fields: dict
    babylon_handedness: str = "left"


def encode_cube(fmt: str, mips, *, babylon_handedness: str = "left") -> EncodedCube:
    """The cube part of ``fmt``'s export (one of :data:`CUBE_FORMATS`) from a cube's mips
    (our layout, (6, n_k, n_k, 3) each): gltf: every mip, already prefiltered at
    :func:`provider.core.reflections.gltf_ibl.babylon_roughness`, as RGBD PNG faces; arcore: the radiance
    (mip 0) at ARCore's 16², pooled exactly (solid-angle means) from a finer cube (a coarser
    one: InputError), as float16 faces."""
    if fmt == "gltf":
        from ..reflections import gltf_ibl
        return EncodedCube(fmt, gltf_ibl.specular_images(mips, babylon_handedness),
                           babylon_handedness)
    if fmt == "arcore":
        radiance = np.asarray(mips[0], np.float32)
        n = radiance.shape[1] if radiance.ndim == 4 else 0
        if n < ARCORE_CUBE_SIZE:
            raise InputError(f"ARCore's cube is {ARCORE_CUBE_SIZE}²; a {n}² cube is too coarse "
                             f"(make it {ARCORE_CUBE_SIZE} or more)")
        while n > ARCORE_CUBE_SIZE:
            radiance = cubemap.pool(radiance, cubemap.pool_shares(
                cubemap.texel_solid_angles(n), cubemap.texel_solid_angles(n // 2)))
            n //= 2
        return EncodedCube(fmt, _arcore_cube(radiance))
    raise InputError(f"format {fmt!r} carries no cube; those that do: {', '.join(CUBE_FORMATS)}")


def _gltf(L, lights, ambient, babylon_handedness, environment=None):
    """glTF ``EXT_lights_image_based`` light (its diffuse part), as Babylon.js reads it.

    irradianceCoefficients 9×3 (README.md:75-79, light.schema.json:26-39) = irradiance SH
    (Â_l L) in Babylon's Condon-Shortley basis (sphericalPolynomial.pure.ts:45-57): the
    loader multiplies by intensity and divides by π (EXT_lights_image_based.pure.ts:136-148),
    the default SH shader path evaluates the prescaled harmonics (:241-255, 342-350, 430-431)
    at the Babylon world normal. Left-handed scene (default): glTF (x, y, z) → (−x, y, z)
    via the root node (glTFLoader.pure.ts:762-768), c = CS·MX·Â·L; right-handed: the lookup
    z is negated (materialHelper.functions.ts:931), c = CS·MZ·Â·L. intensity is always
    written: Babylon multiplies by it unguarded (EXT_lights_image_based.pure.ts:141). The
    extension also requires specularImages and specularImageSize (light.schema.json:63-67):
    given ``environment`` (the cube's mips prefiltered at
    :func:`provider.core.reflections.gltf_ibl.babylon_roughness`), RGBD PNG faces in Babylon's lookup
    frame (:mod:`provider.core.reflections.gltf_ibl`), else ``missing_required``.
    Lights: KHR_lights_punctual directional (shines along the node's −Z; ``node_rotation``
    takes +Z to the toward-light vector), intensity in lux = E⊥. KHR_lights_punctual has no
    field for a light's angular size: the lights' angular radii are not in this export.
    """
    if babylon_handedness not in ("left", "right"):
        raise InputError(f"babylon_handedness must be 'left' or 'right', got {babylon_handedness!r}")
    left = babylon_handedness == "left"
    sign = (CONDON_SHORTLEY * (MIRROR_X if left else MIRROR_Z) * A_HAT)[:, None]
    out = _describe("gltf", f"gltf-babylon-{babylon_handedness}", condon_shortley=True,
                    quantity="irradiance",
                    frame="babylon-lh-y-up" if left else "babylon-rh-y-up",
                    frame_note=("glTF asset in a left-handed Babylon.js scene (the default): "
                                "glTF (x, y, z) -> (-x, y, z) through the loader's root node"
                                if left else
                                "glTF asset in a right-handed Babylon.js scene: glTF frame, "
                                "with the normal's z negated at the lookup"))
    out["light"] = {"name": "shlight", "intensity": 1.0, "rotation": [0.0, 0.0, 0.0, 1.0],
                    "irradianceCoefficients": _f(sign * L)}
    if environment is not None:
        from ..reflections import gltf_ibl
        spec = (_encoded(environment, "gltf", babylon_handedness).fields
                if isinstance(environment, EncodedCube)
                else gltf_ibl.specular_images(environment, babylon_handedness))
        out["light"]["specularImageSize"] = spec["specularImageSize"]
        out["light"]["specularImages"] = spec["specularImages"]
        out["images"] = spec["images"]
        out["specular_roughness"] = gltf_ibl.babylon_roughness(spec["specularImageSize"],
                                                               len(spec["specularImages"]))
        out["specular_clipped_texels"] = spec["specular_clipped_texels"]
        out["document"] = gltf_ibl.document(out["light"], out["images"])
    else:
        out["missing_required"] = ["specularImages", "specularImageSize"]
        out["warning"] = ("EXT_lights_image_based also requires 'specularImages' (prefiltered "
                          "specular cube-map mip levels) and 'specularImageSize'; this export "
                          "does not provide them, so 'light' is not a valid light until they "
                          "are added")
    if lights:
        out["irradianceCoefficientsAmbient"] = _f(sign * _sh_keeping(L, lights, ambient, keep=()))
        out["KHR_lights_punctual"] = [
            {"type": "directional", "color": _f(e / (float(e.max()) or 1.0)),
             "intensity": float(e.max()), "node_rotation": _f(_quat_from_to([0.0, 0.0, 1.0], d))}
            for d, e in lights]
    return out


def _encoded(cube: EncodedCube, fmt: str, babylon_handedness: str = "left") -> EncodedCube:
    """``cube`` if it was encoded for ``fmt`` (and, for gltf, this handedness)."""
    if cube.fmt != fmt or (fmt == "gltf" and cube.babylon_handedness != babylon_handedness):
        raise InputError(f"a cube encoded for {cube.fmt} ({cube.babylon_handedness}) cannot "
                         f"serve a {fmt} export ({babylon_handedness})")
    return cube


def _openxr_android(L, lights, ambient, condon_shortley):
    """``XrSphericalHarmonicsANDROID`` (TOTAL and AMBIENT) and ``XrDirectionalLightANDROID``.

    coefficients[9][3]: rows = coefficients, columns R, G, B
    (android_light_estimation.adoc:261-296) of the "environment light radiance function",
    TOTAL including the main light, AMBIENT excluding it (xr.xml:7922-7923), in the XrSpace
    of XrLightEstimateGetInfoANDROID (:186-187; right-handed, +Y up). Phase: ARCore's
    Condon-Shortley reading, which Godot's OpenXR vendors plugin applies to this data
    (openxr_android_light_estimation.cpp:47-59, 347-352); direction toward the light
    (``looking_at(-direction)``, :317); intensity = RGB irradiance.
    """
    sign = (CONDON_SHORTLEY if condon_shortley else np.ones(9))[:, None]
    out = _describe("openxr-android",
                    "openxr-android-arcore-cs" if condon_shortley else "openxr-android-rh2001",
                    condon_shortley=condon_shortley, quantity="radiance", frame="rh-y-up",
                    frame_note="the XrSpace of XrLightEstimateGetInfoANDROID: " + _RH_NOTE)
    out["total"] = {"kind": "XR_SPHERICAL_HARMONICS_KIND_TOTAL_ANDROID",
                    "coefficients": _f(sign * L)}
    amb, d, e, state = L, [0.0, 1.0, 0.0], [0.0, 0.0, 0.0], "INVALID"
    if lights:
        amb, d, e = _without_primary(L, lights, ambient)
        state = "VALID"
    out["ambient"] = {"kind": "XR_SPHERICAL_HARMONICS_KIND_AMBIENT_ANDROID",
                      "coefficients": _f(sign * amb)}
    out["directionalLight"] = {"direction": _f(d), "intensity": _f(e),
                               "state": f"XR_LIGHT_ESTIMATE_STATE_{state}_ANDROID"}
    return out


def export(coefficients, fmt: str, *, lights=None, ambient=None, babylon_handedness: str = "left",
           condon_shortley: bool = True, environment=None,
           light_angular_radius_deg=None) -> dict:
    """Our (9, 3) radiance SH9 (and optional lights) in ``fmt``'s layout (one of FORMATS).

    ``lights``: (direction toward the light, RGB irradiance) pairs in our frame;
    ``ambient``: the (9, 3) SH of everything but ``lights`` (derived when omitted).
    ``babylon_handedness`` ('left' | 'right') applies to gltf; ``condon_shortley`` to arcore
    and openxr-android. ``environment``: the reflection cube's mips (our layout, same
    units), for gltf prefiltered at :func:`provider.core.reflections.gltf_ibl.babylon_roughness` (its
    ``specularImages``), for arcore mip 0 (``environmentalHdrCubeMap``, 16² in ARCore);
    or that part already encoded (:func:`encode_cube`); ignored by the other formats.
    ``light_angular_radius_deg``: each light's angular radius (degrees, one per light), for
    the formats that have a field for it (unity: ``mainLight.angularDiameter``, HDRP's);
    threejs, webxr, arcore, gltf (KHR_lights_punctual) and openxr-android have none.
    Returns a JSON-ready dict (module docstring).
    """
    if fmt not in FORMATS:
        raise InputError(f"unknown format {fmt!r}; formats: {', '.join(FORMATS)}")
    L = _as_coefficients(coefficients)
    lights = _as_lights(lights)
    if ambient is not None:
        ambient = _as_coefficients(ambient, "ambient")
    radii = _as_radii(light_angular_radius_deg, len(lights))
    if fmt == "threejs":
        return _threejs(L, lights, ambient)
    if fmt == "webxr":
        return _webxr(L, lights, ambient)
    if fmt == "unity":
        return _unity(L, lights, ambient, radii)
    if fmt == "arcore":
        return _arcore(L, lights, ambient, bool(condon_shortley), environment)
    if fmt == "gltf":
        return _gltf(L, lights, ambient, babylon_handedness, environment)
    return _openxr_android(L, lights, ambient, bool(condon_shortley))
