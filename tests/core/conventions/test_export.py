"""Every export format proven with lights from one side only (provider/core/conventions/formats.py).

For each format: the SH9 of radiance (1, 0.5, 0.25) from the half sphere toward +X, +Y or −Z
only, exported, then evaluated THE WAY ITS CONSUMER DOES (tests/consumers.py: Unity's
ShadeSH9, ARCore's Android sample, Babylon.js loading glTF, Godot on OpenXR; three.js's own
code in tests/clients/three/test_export_threejs.py; Unity's formula in C# in tests/clients/unity/test_export_unity.py).
The lit side must land on the consumer-frame normal of the light, with E/π = (1 + a·n)/2 ×
colour: the colour facing the light, half of it sideways, 0 opposite.
"""
from __future__ import annotations

import json
import math

import jsonschema
import numpy as np
import pytest

import consumers as cs
from provider.core.conventions import formats as cv
from provider.core.geometry import sh
from provider.core.sh9.engine import SH9Result
from provider.core.errors import InputError
from provider.live.wire.export import ExportCache, check_format, export_message
from provider.live.wire.message import coefficient_message, load_schema
from provider.verify import contract
from provider.verify.export_vectors import (AXES, OBLIQUE_LIGHT, PROSE, export_normals,
                                            hemisphere_sh, white)

VALIDATOR = jsonschema.Draft202012Validator(load_schema())
NORMALS = np.vstack([np.eye(3), -np.eye(3)])
RGB = np.array([1.0, 0.5, 0.25])
TOL = 2e-4                      # the consumers' published constants have 6 digits
LIGHT_E = np.array([3.0, 2.0, 1.0])


def expected(axis, normals=NORMALS, rgb=RGB):
    return 0.5 * (1 + normals @ np.asarray(axis, float))[:, None] * rgb[None, :]


def assert_lit_side(shown, axis, normals=NORMALS):
    """Brightest at the normal toward the light, zero opposite, E/π everywhere."""
    i_lit = int(np.argmin(np.linalg.norm(normals - axis, axis=1)))
    i_dark = int(np.argmin(np.linalg.norm(normals + axis, axis=1)))
    np.testing.assert_allclose(shown[i_lit], RGB, rtol=TOL, atol=TOL)
    np.testing.assert_allclose(shown[i_dark], 0.0, atol=TOL)
    np.testing.assert_allclose(shown, expected(axis, normals), rtol=TOL, atol=TOL)


def ambient_and_light(d):
    """+Y ambient with a directional light toward d: (total SH, ambient SH, lights, want)."""
    amb = hemisphere_sh(AXES["+y"])
    lights = [(d, LIGHT_E)]
    return amb + cv.light_sh(d, LIGHT_E), amb, lights, white(amb, lights, NORMALS)


def test_the_one_sided_light_is_what_it_claims():
    """hemisphere_sh against a numeric projection, and its E/π is exactly (1 + a·n)/2."""
    n = 200_000
    dirs = sh.fibonacci_sphere(n)
    for a in AXES.values():
        L = (sh.sh_basis(dirs) * ((dirs @ a) > 0)[:, None]).sum(0) * 4 * math.pi / n
        np.testing.assert_allclose(L, hemisphere_sh(a, (1, 1, 1))[:, 0], atol=3e-3)
        np.testing.assert_allclose(sh.irradiance(hemisphere_sh(a), NORMALS) / math.pi,
                                   expected(a), rtol=1e-5, atol=1e-6)


# ---- Unity (ShadeSH9) ------------------------------------------------------------------------------

@pytest.mark.parametrize("name", list(AXES))
def test_unity_shadesh9_lights_the_right_side(name):
    a = AXES[name]
    ex = cv.export(hemisphere_sh(a), "unity")
    S = cs.unity_probe(ex["sh"])
    np.testing.assert_allclose(np.reshape(ex["shaderConstants"], (7, 4)), cs.unity_pack(S),
                               atol=1e-15)
    n_unity = NORMALS * cs.TO_UNITY
    shown = cs.shade_sh9(ex["shaderConstants"], n_unity)
    assert_lit_side(shown, a)
    # in Unity's own axes: +X stays +X, +Y stays +Y, our −Z is Unity's +Z
    np.testing.assert_allclose(n_unity[int(np.argmax(shown[:, 0]))], a * cs.TO_UNITY)
    assert ex["frame"] == "unity-lh-y-up" and ex["quantity"] == "irradiance_over_pi"


@pytest.mark.parametrize("name", list(AXES))
def test_unity_main_light(name):
    total, amb, lights, want = ambient_and_light(AXES[name])
    ex = cv.export(total, "unity", lights=lights)
    n_unity = NORMALS * cs.TO_UNITY
    ml = ex["mainLight"]
    direct = cs.lambert_directional(n_unity, -np.array(ml["forward"]),
                                    np.array(ml["colorLinear"]) * ml["intensity"], unity=True)
    np.testing.assert_allclose(cs.shade_sh9(ex["shaderConstantsAmbient"], n_unity) + direct,
                               want, rtol=TOL, atol=TOL)
    # 'sh' alone is the whole lighting (the light inside the SH9)
    np.testing.assert_allclose(cs.unity_shown(ex["sh"], n_unity),
                               sh.irradiance(total, NORMALS) / math.pi, rtol=TOL, atol=TOL)


def test_unity_factors_are_unitys_own_numbers():
    """UNITY_FACTORS against three independent Unity / Google sources."""
    pi = math.pi
    norm = [math.sqrt(1 / pi) / 2] + [math.sqrt(3 / pi) / 2] * 3 + \
        [math.sqrt(15 / pi) / 2] * 2 + [math.sqrt(5 / pi) / 4, math.sqrt(15 / pi) / 2,
                                        math.sqrt(15 / pi) / 4]
    ahat = [pi] + [2 * pi / 3] * 3 + [pi / 4] * 5
    # UnityCsReference Editor/Mono/GI/PostProcessing.bindings.cs:36-130 (normalisation × Â ÷ π)
    np.testing.assert_allclose(cv.UNITY_FACTORS, np.array(norm) * ahat / pi, rtol=1e-5)
    # HDRP Runtime/Lighting/SphericalHarmonics.cs:58-62 |kNormalizationConstants|
    hdrp = [0.28209479177387814347, 0.32573500793527994772, 0.32573500793527994772,
            0.32573500793527994772, 0.27313710764801976764, 0.27313710764801976764,
            0.07884789131313000151, 0.27313710764801976764, 0.13656855382400988382]
    np.testing.assert_allclose(cv.UNITY_FACTORS, hdrp, rtol=1e-5)
    # ARCore Unity SDK LightEstimateApi.cs:38-43 _shConstants / π
    np.testing.assert_allclose(cv.UNITY_FACTORS, cs.ARCORE_UNITY_SDK_CONSTANTS / pi, rtol=1e-5)


# ---- ARCore ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", list(AXES))
def test_arcore_sample_lights_the_right_side(name):
    a = AXES[name]
    ex = cv.export(hemisphere_sh(a), "arcore")
    assert ex["condon_shortley"] is True and ex["convention"] == "arcore-android-sample"
    assert ex["mainLightDirection"] == [0.0, 1.0, 0.0] and ex["mainLightIntensity"] == [0.0] * 3
    assert_lit_side(cs.arcore_sample(ex["sphericalHarmonics"], NORMALS), a)


@pytest.mark.parametrize("name", list(AXES))
def test_arcore_main_light(name):
    total, _, lights, want = ambient_and_light(AXES[name])
    ex = cv.export(total, "arcore", lights=lights)
    direct = cs.lambert_directional(NORMALS, ex["mainLightDirection"], ex["mainLightIntensity"])
    np.testing.assert_allclose(cs.arcore_sample(ex["sphericalHarmonics"], NORMALS) + direct,
                               want, rtol=TOL, atol=TOL)
    np.testing.assert_allclose(np.reshape(ex["sphericalHarmonicsTotal"], (9, 3)),
                               cv.CONDON_SHORTLEY[:, None] * total, atol=1e-12)


@pytest.mark.parametrize("name,unity_lit", [("+x", [-1, 0, 0]), ("+y", [0, -1, 0]),
                                            ("-z", [0, 0, 1])])
def test_arcore_google_samples_disagree(name, unity_lit):
    """The same raw numbers read by Google's archived ARCore Unity SDK light the opposite
    side in x and y (the four m = ±1 signs: a 180° turn about z). The export follows the
    maintained Android sample; --no-condon-shortley gives the Unity SDK's reading."""
    a = AXES[name]
    n_unity = NORMALS * cs.TO_UNITY
    raw = cv.export(hemisphere_sh(a), "arcore")["sphericalHarmonics"]
    shown = cs.shade_sh9(cs.unity_pack(cs.arcore_unity_sdk_probe(raw)), n_unity)
    np.testing.assert_allclose(n_unity[int(np.argmax(shown[:, 0]))], unity_lit)
    ex = cv.export(hemisphere_sh(a), "arcore", condon_shortley=False)
    assert ex["condon_shortley"] is False and ex["convention"] == "arcore-unity-sdk"
    assert_lit_side(cs.shade_sh9(cs.unity_pack(cs.arcore_unity_sdk_probe(
        ex["sphericalHarmonics"])), n_unity), a)


# ---- glTF EXT_lights_image_based in Babylon.js -----------------------------------------------------------

@pytest.mark.parametrize("handedness", ["left", "right"])
@pytest.mark.parametrize("name", list(AXES))
def test_gltf_in_babylon_lights_the_right_side(name, handedness):
    a = AXES[name]
    ex = cv.export(hemisphere_sh(a), "gltf", babylon_handedness=handedness)
    light = ex["light"]
    assert np.shape(light["irradianceCoefficients"]) == (9, 3)
    assert light["intensity"] == 1.0 and light["rotation"] == [0.0, 0.0, 0.0, 1.0]
    assert ex["missing_required"] == ["specularImages", "specularImageSize"]
    assert "specularImages" in ex["warning"] and "not provide" in ex["warning"]
    assert ex["convention"] == f"gltf-babylon-{handedness}" and ex["quantity"] == "irradiance"
    assert_lit_side(cs.babylon_gltf(light, NORMALS, handedness), a)


def test_gltf_lights_as_khr_lights_punctual():
    d = OBLIQUE_LIGHT[0]
    total, amb, lights, want = ambient_and_light(d)
    ex = cv.export(total, "gltf", lights=lights)
    (p,) = ex["KHR_lights_punctual"]
    x, y, z, w = p["node_rotation"]             # the node's +Z must point toward the light
    q = np.array([x, y, z])
    toward = 2 * q * (q @ [0, 0, 1.0]) + (w * w - q @ q) * np.array([0, 0, 1.0]) + \
        2 * w * np.cross(q, [0, 0, 1.0])
    np.testing.assert_allclose(toward, d, atol=1e-12)
    light = dict(ex["light"], irradianceCoefficients=ex["irradianceCoefficientsAmbient"])
    direct = cs.lambert_directional(NORMALS, toward, np.array(p["color"]) * p["intensity"])
    np.testing.assert_allclose(cs.babylon_gltf(light, NORMALS) + direct, want, rtol=TOL, atol=TOL)


def test_gltf_handedness_modes_differ_by_a_half_turn_about_y():
    left = cv.export(hemisphere_sh(AXES["+x"]), "gltf")["light"]
    shown_in_rh = cs.babylon_gltf(left, NORMALS, "right")
    np.testing.assert_allclose(NORMALS[int(np.argmax(shown_in_rh[:, 0]))], [-1, 0, 0])


def test_gltf_intensity_is_always_written():
    """Babylon multiplies by an omitted intensity unguarded: NaN (EXT_lights_image_based.pure.ts:141)."""
    light = dict(cv.export(hemisphere_sh(AXES["+y"]), "gltf")["light"], intensity=float("nan"))
    assert np.all(np.isnan(cs.babylon_gltf(light, NORMALS)))


# ---- OpenXR XR_ANDROID_light_estimation ------------------------------------------------------------------

@pytest.mark.parametrize("name", list(AXES))
def test_openxr_android_lights_the_right_side(name):
    a = AXES[name]
    ex = cv.export(hemisphere_sh(a), "openxr-android")
    assert np.shape(ex["total"]["coefficients"]) == (9, 3)
    assert_lit_side(cs.openxr_android_godot(ex["total"]["coefficients"], NORMALS), a)
    assert ex["ambient"]["coefficients"] == ex["total"]["coefficients"]
    assert ex["directionalLight"]["state"] == "XR_LIGHT_ESTIMATE_STATE_INVALID_ANDROID"


@pytest.mark.parametrize("name", list(AXES))
def test_openxr_android_ambient_plus_light_and_total(name):
    total, _, lights, want = ambient_and_light(AXES[name])
    ex = cv.export(total, "openxr-android", lights=lights)
    dl = ex["directionalLight"]
    assert dl["state"] == "XR_LIGHT_ESTIMATE_STATE_VALID_ANDROID"
    direct = cs.lambert_directional(NORMALS, dl["direction"], dl["intensity"])
    np.testing.assert_allclose(cs.openxr_android_godot(ex["ambient"]["coefficients"], NORMALS)
                               + direct, want, rtol=TOL, atol=TOL)
    np.testing.assert_allclose(cs.openxr_android_godot(ex["total"]["coefficients"], NORMALS),
                               sh.irradiance(total, NORMALS) / math.pi, rtol=TOL, atol=TOL)


# ---- WebXR: the documented disagreement -------------------------------------------------------------------

def test_webxr_export_is_not_for_babylons_webxr_light_estimation():
    """Babylon reads XRLightEstimate SH as Condon-Shortley-phased and already convolved (÷π);
    three.js as plain radiance. Our webxr export (three.js's reading) of light from above
    shows lit from BELOW in Babylon, band 1 at 3/2 strength. The README says so."""
    ex = cv.export(hemisphere_sh(AXES["+y"], (1, 1, 1)), "webxr")
    shown = cs.babylon_webxr(ex["sphericalHarmonicsCoefficients"], NORMALS)
    np.testing.assert_allclose(NORMALS[int(np.argmax(shown[:, 0]))], [0, -1, 0])
    np.testing.assert_allclose(shown[4, 0] - shown[1, 0], 1.5, rtol=TOL)   # -Y minus +Y
    assert "Babylon" in ex["description"]


def test_webxr_primary_light_only_leaves_the_sh():
    d1, e1 = np.array([0, 1.0, 0]), np.array([5.0, 5.0, 5.0])
    d2, e2 = np.array([1.0, 0, 0]), np.array([1.0, 1.0, 1.0])
    amb = hemisphere_sh(AXES["-z"])
    total = amb + cv.light_sh(d1, e1) + cv.light_sh(d2, e2)
    for fmt, key in (("webxr", "sphericalHarmonicsCoefficients"), ("arcore", "sphericalHarmonics")):
        ex = cv.export(total, fmt, lights=[(d2, e2), (d1, e1)], condon_shortley=False)
        np.testing.assert_allclose(np.reshape(ex[key], (9, 3)), amb + cv.light_sh(d2, e2),
                                   atol=1e-12)
    ex = cv.export(total, "webxr", lights=[(d2, e2), (d1, e1)])
    assert ex["primaryLightDirection"] == {"x": 0.0, "y": 1.0, "z": 0.0, "w": 0.0}
    assert ex["primaryLightIntensity"] == {"x": 5.0, "y": 5.0, "z": 5.0, "w": 1.0}


# ---- every format: self-description, lights from the §10 fields, bad input -------------------------------

@pytest.mark.parametrize("fmt", cv.FORMATS)
def test_every_export_says_what_it_is_and_validates(fmt):
    r = SH9Result(hemisphere_sh(AXES["+x"]), sh.irradiance_matrices(hemisphere_sh(AXES["+x"])))
    msg = coefficient_message(r, probe="room", seq=7)
    for with_lights in (False, True):
        if with_lights:
            d, e = OBLIQUE_LIGHT
            msg = dict(msg, lights=1, light_directions=list(d), light_irradiance=list(e))
        ex = export_message(msg, fmt)
        VALIDATOR.validate(ex)
        json.dumps(ex, allow_nan=False)
        assert ex["type"] == "export" and ex["format"] == fmt and ex["probe"] == "room"
        assert ex["seq"] == 7 and ex["lights"] == int(with_lights)
        for key in ("convention", "basis", "condon_shortley", "quantity", "frame", "units",
                    "layout", "usage", "description", "sources"):
            assert ex[key] not in (None, "", []), key
        assert all(":" in s for s in ex["sources"])        # file:lines citations


def test_the_wire_message_says_what_it_is():
    msg = coefficient_message(SH9Result(np.ones((9, 3)), np.zeros((3, 4, 4))))
    VALIDATOR.validate(msg)
    assert (msg["frame"], msg["basis"], msg["condon_shortley"], msg["coefficients_mode"],
            msg["matrices_mode"], msg["units"]) == ("rh-y-up", "sh9-real", False, "radiance",
                                                    "irradiance", "input-linear")
    props = load_schema()["$defs"]["sh9"]["properties"]
    for key in ("basis", "condon_shortley", "units"):
        assert props[key]["description"]


def test_lights_from_a_message_or_from_stats():
    """docs/contract.md §10 fields, from a wire message (lists) or arrays; with
    ambient_coefficients given, that ambient is used as is."""
    d, e = OBLIQUE_LIGHT
    amb = hemisphere_sh(AXES["-z"])
    total = amb + cv.light_sh(d, e)
    lights, ambient = cv.lights_from_fields({"lights": 1, "light_directions": (2 * d).tolist(),
                                             "light_irradiance": e.tolist()})
    np.testing.assert_allclose(lights[0][0], d)
    assert ambient is None
    lights, ambient = cv.lights_from_fields({"lights": np.int64(1), "light_directions": d[None],
                                             "light_irradiance": e[None],
                                             "ambient_coefficients": amb.reshape(-1)})
    np.testing.assert_allclose(ambient, amb)
    a = cv.export(total, "webxr", lights=lights)
    b = cv.export(total, "webxr", lights=lights, ambient=ambient)
    np.testing.assert_allclose(a["sphericalHarmonicsCoefficients"],
                               b["sphericalHarmonicsCoefficients"], atol=1e-12)
    # the wire path: export_message takes them from the message (a message without lights has
    # lights 0 and the ambient equal to the full SH9)
    msg = coefficient_message(SH9Result(total, np.zeros((3, 4, 4))))
    assert msg["lights"] == 0 and np.allclose(msg["ambient_coefficients"], total.reshape(-1))
    without_ambient = {k: v for k, v in msg.items() if not k.startswith("ambient_")}
    for ex in (export_message(dict(without_ambient, lights=1, light_directions=d.tolist(),
                                   light_irradiance=e.tolist()), "arcore"),
               export_message(dict(msg, lights=1, light_directions=d.tolist(),
                                   light_irradiance=e.tolist(),
                                   ambient_coefficients=amb.reshape(-1).tolist()), "arcore")):
        assert ex["lights"] == 1
        np.testing.assert_allclose(ex["mainLightDirection"], d)
        np.testing.assert_allclose(np.reshape(ex["sphericalHarmonics"], (9, 3)),
                                   cv.CONDON_SHORTLEY[:, None] * amb, atol=1e-12)
    assert export_message(msg, "arcore")["lights"] == 0
    assert cv.lights_from_fields({"coefficients": [0] * 27}) == ([], None)
    assert cv.lights_from_fields({"lights": 0}) == ([], None)


@pytest.mark.parametrize("fields,needle", [
    ({"lights": 2, "light_directions": [0, 1, 0], "light_irradiance": [1, 1, 1]}, "6 numbers"),
    ({"lights": 1, "light_irradiance": [1, 1, 1]}, "light_directions"),
    ({"lights": 1, "light_directions": [0, 0, 0], "light_irradiance": [1, 1, 1]}, "non-zero"),
    ({"lights": 1, "light_directions": [0, 1, 0], "light_irradiance": [1, -1, 1]}, ">= 0"),
    ({"lights": "1"}, "count"),
    ({"lights": 1, "light_directions": [0, 1, 0], "light_irradiance": [1, 1, 1],
      "ambient_coefficients": [0.0] * 26}, "27 numbers"),
])
def test_bad_light_fields_are_one_clear_error(fields, needle):
    with pytest.raises(InputError, match=needle):
        cv.lights_from_fields(fields)


def test_bad_input_is_one_clear_error():
    with pytest.raises(InputError, match="27 numbers"):
        cv.export(np.zeros((9, 2)), "threejs")
    with pytest.raises(InputError, match="threejs, webxr, unity, arcore, gltf, openxr-android"):
        cv.export(np.zeros((9, 3)), "babylon")
    with pytest.raises(InputError, match="finite"):
        cv.export(np.full((9, 3), np.nan), "unity")
    with pytest.raises(InputError, match="left"):
        cv.export(np.zeros((9, 3)), "gltf", babylon_handedness="up")
    assert check_format(None) is None and check_format("sh9") is None
    assert check_format("webxr") == "webxr"
    for bad in ("WEBXR", "", 3, ["webxr"]):
        with pytest.raises(InputError, match="formats: threejs"):
            check_format(bad)


def test_export_cache_converts_once_per_message_and_format(caplog):
    msg = coefficient_message(SH9Result(hemisphere_sh(AXES["+x"]), np.zeros((3, 4, 4))),
                              probe="p", seq=3)
    cache = ExportCache()
    first = cache.text(msg, "webxr")
    assert cache.text(msg, "webxr") is first and cache.conversions == 1
    cache.text(msg, "unity")
    assert cache.conversions == 2
    cache.text(dict(msg, seq=4), "webxr")
    assert cache.conversions == 3
    assert cache.text(None, "webxr") is None
    broken = dict(msg, seq=5, lights=1, light_directions=[0, 0, 0], light_irradiance=[1, 1, 1])
    assert cache.text(broken, "webxr") is None        # logged, never raised into the server
    assert cache.text(dict(broken, seq=6), "webxr") is None
    assert len([r for r in caplog.records if "cannot convert" in r.getMessage()]) == 1
    assert cache.text(dict(msg, seq=7), "webxr") is not None


# ---- the golden vectors ------------------------------------------------------------------------------------

def _vectors():
    return json.loads(contract.VECTORS_PATH.read_text())


def test_export_vectors_are_what_the_generator_writes():
    """shaders/contract_vectors.json "exports" is current (`shlight validate-shaders
    --write-vectors` writes it), within the tolerances tests/shadertools.py states (the sky
    case carries the engine's float32 sums: its last digits depend on the CPU)."""
    from shadertools import vectors_mismatches
    committed, fresh = _vectors(), json.loads(contract.dumps(contract.contract_vectors()))
    assert committed["exports_description"] == fresh["exports_description"]
    assert vectors_mismatches(fresh["exports"], committed["exports"], "exports") == []


def test_export_vectors_through_every_consumer():
    """Each golden vector, read by its consumer's own evaluation, shows 'white'."""
    for case in _vectors()["exports"]:
        n = np.reshape(case["normals"], (-1, 3))
        want = np.reshape(case["white"], (-1, 3))
        scale = np.abs(want).max()
        assert np.allclose(n, export_normals(len(n)))
        lights = list(zip(np.reshape(case["light_directions"], (-1, 3)),
                          np.reshape(case["light_irradiance"], (-1, 3))))
        n_unity = n * cs.TO_UNITY
        u = case["unity"]
        shown = {
            "unity": cs.shade_sh9(u["shaderConstantsAmbient" if lights else "shaderConstants"],
                                  n_unity),
            "arcore": cs.arcore_sample(case["arcore"]["sphericalHarmonics"], n),
            "gltf": cs.babylon_gltf(dict(case["gltf"]["light"], **(
                {"irradianceCoefficients": case["gltf"]["irradianceCoefficientsAmbient"]}
                if lights else {})), n),
            "openxr-android": cs.openxr_android_godot(
                case["openxr-android"]["ambient"]["coefficients"], n),
        }
        if lights:
            ml = u["mainLight"]
            shown["unity"] += cs.lambert_directional(n_unity, -np.array(ml["forward"]),
                                                     np.array(ml["colorLinear"]), unity=True)
            shown["arcore"] += cs.lambert_directional(n, case["arcore"]["mainLightDirection"],
                                                      case["arcore"]["mainLightIntensity"])
            for p in case["gltf"]["KHR_lights_punctual"]:
                shown["gltf"] += cs.lambert_directional(n, lights[0][0],
                                                        np.array(p["color"]) * p["intensity"])
            dl = case["openxr-android"]["directionalLight"]
            shown["openxr-android"] += cs.lambert_directional(n, dl["direction"], dl["intensity"])
        for fmt, got in shown.items():
            # ARCore's sample and Godot clamp their SH at 0; these scenes do not ring
            assert np.abs(got - want).max() <= TOL * max(scale, 1), (case["name"], fmt)
        for fmt in cv.FORMATS:
            assert not set(PROSE) & set(case[fmt]), fmt
            assert case[fmt]["format"] == fmt
