"""Issue 31, consumers: Unity (and three.js) apply the room's exposure, colour temperature and light units.

The package's core (unity_package/Runtime/Core/Sh9Exposure.cs, plain C#) is compiled with Mono's mcs
and fed sh9 messages (tests/csharp/ExposureTest.cs); SH9LightingClient's glue is compiled against the
UnityEngine stand-in with and without Unity 2022.2's physical-camera properties. One shared vector file,
tests/data/exposure_vectors.json, is read by the C# core and by client-three.js physicalExposure under node.
Nothing here runs Unity.
"""
from __future__ import annotations

import json
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from unitytools import CORE, HARNESS, RUNTIME, STANDIN, _compile, _mono_tools

ROOT = Path(__file__).resolve().parents[3]
VECTORS = ROOT / "tests" / "data" / "exposure_vectors.json"
CLIENT_THREE = ROOT / "provider" / "live" / "server" / "static" / "client-three.js"
Y00 = 0.5 / math.sqrt(math.pi)                      # 0.282095: uniform radiance L has L00 = L / Y00
REC709 = np.array([0.2126, 0.7152, 0.0722])


@pytest.fixture(scope="module")
def exposure_exe(tmp_path_factory):
    out = tmp_path_factory.mktemp("exposure31") / "ExposureTest.exe"
    return _compile(out, [*CORE, ROOT / "tests" / "csharp" / "ExposureTest.cs"])


def run_cases(exe, cases):
    """cases: (mode, compensation_ev, aperture, iso, colour_space, kelvin_rgb, message) → the core's outputs."""
    _, mono = _mono_tools()
    lines = [f"{mode} {float(comp)!r} {float(n)!r} {float(s)!r} {space} " + " ".join(repr(float(v)) for v in k) + f"\t{json.dumps(msg)}"
             for mode, comp, n, s, space, k, msg in cases]
    r = subprocess.run([mono, str(exe)], input="\n".join(lines) + "\n", capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stdout + r.stderr
    out = [json.loads(line) for line in r.stdout.splitlines()]
    assert len(out) == len(cases)
    return out


def message(luminance=60.0, units="cd/m²", ev100="mean", light=None, **extra):
    """A room of uniform radiance `luminance` (grey, cd/m² when absolute); ev100 as the provider defines it,
    log2(L̄ · 100 / 12.5) with L̄ = Y00 · Y(L00) (docs/photometry.md). `light`: (direction, RGB irradiance)
    of one directional light split off, the uniform room being the ambient."""
    coeffs = np.zeros((9, 3))
    coeffs[0] = luminance / Y00
    m = {"type": "sh9", "version": 1, "probe": "default", "seq": 1, "time": 0.0, "frame": "rh-y-up",
         "coefficient_units": units}
    if units == "cd/m²":
        m["ev100"] = math.log2(luminance * 100 / 12.5) if ev100 == "mean" else ev100
    if light is not None:
        d, e = np.asarray(light[0], float), np.asarray(light[1], float)
        d = d / np.linalg.norm(d)
        m.update(lights=1, light_directions=d.tolist(), light_irradiance=e.tolist(),
                 ambient_coefficients=coeffs.reshape(-1).tolist())
        coeffs = coeffs + _light_sh(d, e)     # the full SH9: ambient + the light's projection (contract §10)
        if units == "cd/m²":
            m["light_illuminance_lux"] = [float(REC709 @ e)]
    m["coefficients"] = coeffs.reshape(-1).tolist()
    m.update(extra)
    return m


def _light_sh(d, e):
    """SH9 radiance projection of a directional light of irradiance e (RGB) toward d: L_lm = Y_lm(d) · e."""
    from provider.core.geometry import sh
    return np.outer(sh.sh_basis(np.asarray(d, float)), np.asarray(e, float))


WHITE = (1.0, 1.0, 1.0)


# ---- the shared vector: the same exposure in C# and three.js ------------------------------------------

def test_shared_exposure_vectors_match_the_formula():
    """The shared vector file holds 1 / (1.2 · 2^EV100) (null for relative lighting), HDRP's conversion."""
    cases = json.loads(VECTORS.read_text())["cases"]
    assert any(c["exposure"] is None for c in cases) and sum(c["exposure"] is not None for c in cases) >= 5
    for c in cases:
        if c["exposure"] is not None:
            assert c["exposure"] == pytest.approx(1 / (1.2 * 2 ** c["ev100"]), rel=1e-12)


def test_unity_camera_image_exposure_is_the_shared_vector(exposure_exe):
    """Camera Image mode's scale is the vector's exposure for absolute lighting; relative lighting is left
    as sent (scale 1, not applied) — what client-three.js does with the same vectors (below)."""
    cases = json.loads(VECTORS.read_text())["cases"]
    msgs = [message(units=c["coefficient_units"], ev100=c.get("ev100")) for c in cases]
    got = run_cases(exposure_exe, [("camera_image", 0.0, 2.8, 100.0, "linear_intensity", WHITE, m) for m in msgs])
    for c, g in zip(cases, got):
        if c["exposure"] is None:
            assert not g["absolute"] and not g["applied"] and g["scale"] == 1.0
        else:
            assert g["absolute"] and g["applied"] and g["scale"] == pytest.approx(c["exposure"], rel=1e-12)


def test_threejs_physical_exposure_is_the_shared_vector(tmp_path):
    """client-three.js physicalExposure (renderer.toneMappingExposure) gives the same vector's exposure."""
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed")
    cases = json.loads(VECTORS.read_text())["cases"]
    script = tmp_path / "vectors.mjs"
    script.write_text(f'import {{ physicalExposure }} from "{CLIENT_THREE.as_uri()}";\n'
                      f'const cases = {json.dumps(cases)};\n'
                      'console.log(JSON.stringify(cases.map(c => physicalExposure({message: c}))));\n')
    r = subprocess.run([node, str(script)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    for c, got in zip(cases, json.loads(r.stdout)):
        assert got == (None if c["exposure"] is None else pytest.approx(c["exposure"], rel=1e-12))


# ---- exposure: a surface renders at the camera image's brightness ---------------------------------------

def test_camera_image_mode_renders_the_rooms_mean_at_a_fixed_level(exposure_exe):
    """URP/built-in (passthrough): with absolute lighting, a white Lambertian surface in a room of uniform
    luminance L shows 12.5 / 120 of white, whatever L (a camera exposed for the room), × 2^c with an
    exposure compensation of c stops. Relative lighting is shown as today (L itself) in every mode."""
    cases, want = [], []
    for lum in (3.0, 60.0, 20000.0):
        for comp in (0.0, 1.0, -2.0):
            cases.append(("camera_image", comp, 2.8, 100.0, "linear_intensity", WHITE, message(lum)))
            want.append(12.5 / 120 * 2 ** comp)
        for mode in ("relative", "camera_image", "physical_camera"):
            cases.append((mode, 1.0, 2.8, 100.0, "linear_intensity", WHITE, message(lum, units="relative")))
            want.append(lum)
        cases.append(("relative", 0.0, 2.8, 100.0, "linear_intensity", WHITE, message(lum)))
        want.append(lum)                                   # Relative mode: absolute lighting as sent
    for g, w in zip(run_cases(exposure_exe, cases), want):
        assert g["up_radiance"] == pytest.approx([w] * 3, rel=1e-5)


def test_physical_camera_mode_gives_the_camera_ev100_and_keeps_lux(exposure_exe):
    """HDRP: the SH9 stays in the message's units (E/π of a white surface = L cd/m²), the camera takes
    EV100 − c, and the shutter set for its aperture and ISO gives that EV100 back:
    t = N² · (100 / S) / 2^EV100. Relative lighting gives no EV100."""
    cases = [("physical_camera", comp, n, s, "linear_intensity", WHITE, message(200.0))
             for comp, n, s in ((0.0, 2.8, 100.0), (1.0, 8.0, 400.0), (-0.5, 1.4, 1600.0))]
    cases.append(("physical_camera", 0.0, 2.8, 100.0, "linear_intensity", WHITE, message(200.0, units="relative")))
    got = run_cases(exposure_exe, cases)
    ev100 = math.log2(200.0 * 100 / 12.5)
    for (_, comp, n, s, *_), g in zip(cases[:3], got[:3]):
        assert g["applied"] and g["scale"] == 1.0 and g["light_factor"] == 1.0
        assert g["up_radiance"] == pytest.approx([200.0] * 3, rel=1e-5)
        assert g["camera_ev100"] == pytest.approx(ev100 - comp, rel=1e-12)
        assert g["shutter_s"] == pytest.approx(n * n * 100 / s / 2 ** (ev100 - comp), rel=1e-12)
        assert g["camera_ev100_back"] == pytest.approx(ev100 - comp, abs=1e-9)
    rel = got[3]
    assert not rel["applied"] and rel["camera_ev100"] is None and rel["shutter_s"] is None


# ---- the drawn light in the pipeline's units ---------------------------------------------------------

SUN = ([0.3, 0.8, -0.52], [52000.0, 50000.0, 46000.0])   # lux per channel on a surface facing it


def test_light_in_lux_for_hdrp_and_exposed_for_urp(exposure_exe):
    """The drawn directional light: HDRP (Physical Camera) shows E itself, lux (its Y is the message's
    light_illuminance_lux); URP/built-in (Camera Image) shows E/π × the exposure, so a white surface facing
    the light gets exposure · E/π as from the SH9; Relative shows E/π as before. Linear and gamma-intensity
    light settings alike (temperature off)."""
    msg = message(60.0, light=SUN)
    e = np.array(SUN[1])
    exposure = 1 / (1.2 * 2 ** msg["ev100"])
    cases, want = [], []
    for space in ("linear_intensity", "gamma_intensity"):
        cases.append(("physical_camera", 0.0, 2.8, 100.0, space, WHITE, msg))
        want.append(e)
        cases.append(("camera_image", 0.0, 2.8, 100.0, space, WHITE, msg))
        want.append(e / math.pi * exposure)
        cases.append(("relative", 0.0, 2.8, 100.0, space, WHITE, msg))
        want.append(e / math.pi)
    got = run_cases(exposure_exe, cases)
    for g, w in zip(got, want):
        assert g["light_active"] and not g["temperature"]
        assert g["light_seen"] == pytest.approx(w.tolist(), rel=1e-6)
    assert float(REC709 @ np.array(got[0]["light_seen"])) == pytest.approx(msg["light_illuminance_lux"][0], rel=1e-6)
    # the ambient (the room without the light) is what the SH9 gets while the light is drawn
    assert got[1]["up_radiance"] == pytest.approx([60.0 * exposure] * 3, rel=1e-5)


# ---- colour temperature ----------------------------------------------------------------------------

def blackbody_rgb(kelvin: float) -> np.ndarray:
    """A stand-in for the engine's linear RGB of a temperature (its chromaticity only matters here)."""
    t = kelvin / 1000.0
    return np.array([1.0, 0.39 * math.log(t) - 0.1, 0.55 * math.log(t) - 0.4]).clip(0.05, 1.0)


def test_color_temperature_keeps_the_lights_luminance(exposure_exe):
    """Use Color Temperature: the light's light_cct_k, else the ambient's cct_k; the colour is white, the
    intensity such that the shaders see the temperature's colour at the light's luminance
    (Y(kelvin RGB) · intensity = Y(E · factor)). No CCT in the message, or Unity's gamma-intensity light
    setting (where Unity ignores the temperature): the colour comes from RGB as before."""
    e = np.array(SUN[1])
    k_light, k_room = 3200.0, 5600.0
    with_light = message(60.0, light=SUN, light_cct_k=[k_light], cct_k=k_room)
    room_only = message(60.0, light=SUN, light_cct_k=[0.0], cct_k=k_room)
    none = message(60.0, light=SUN)
    cases = [("physical_camera", 0.0, 2.8, 100.0, "linear_intensity", tuple(blackbody_rgb(k_light)), with_light),
             ("camera_image", 0.0, 2.8, 100.0, "linear_intensity", tuple(blackbody_rgb(k_room)), room_only),
             ("physical_camera", 0.0, 2.8, 100.0, "linear_intensity", tuple(blackbody_rgb(k_room)), none),
             ("physical_camera", 0.0, 2.8, 100.0, "gamma_intensity", tuple(blackbody_rgb(k_light)), with_light)]
    got = run_cases(exposure_exe, cases)
    hdrp, urp, no_cct, gamma = got
    assert hdrp["kelvin"] == k_light and hdrp["temperature"] and hdrp["light_rgbi"][:3] == [1.0, 1.0, 1.0]
    seen = np.array(hdrp["light_seen"])
    assert float(REC709 @ seen) == pytest.approx(float(REC709 @ e), rel=1e-6)
    k = blackbody_rgb(k_light)
    assert seen / seen.max() == pytest.approx(k / k.max(), rel=1e-6)      # the temperature's chromaticity
    exposure = 1 / (1.2 * 2 ** room_only["ev100"])
    assert urp["kelvin"] == k_room and urp["temperature"]
    assert float(REC709 @ np.array(urp["light_seen"])) == pytest.approx(float(REC709 @ e) / math.pi * exposure,
                                                                        rel=1e-6)
    assert no_cct["kelvin"] is None and not no_cct["temperature"]
    assert no_cct["light_seen"] == pytest.approx(e.tolist(), rel=1e-6)
    assert gamma["kelvin"] == k_light and not gamma["temperature"]
    assert gamma["light_seen"] == pytest.approx(e.tolist(), rel=1e-6)


# ---- the MonoBehaviour glue ---------------------------------------------------------------------------

@pytest.mark.parametrize("defines", [(), ("UNITY_2022_2_OR_NEWER",)], ids=["unity2020.3", "unity2022.2"])
def test_lighting_client_glue_compiles_against_the_standin(tmp_path, defines):
    """SH9LightingClient's Exposure Mode, Physical Camera (Camera.aperture/iso/shutterSpeed, 2022.2+) and
    Use Color Temperature (Light.colorTemperature, GraphicsSettings.lightsUseColorTemperature,
    Mathf.CorrelatedColorTemperatureToRGB) type-check against the UnityEngine stand-in, with and without
    Unity 2022.2's camera properties."""
    _compile(tmp_path / "Runtime.dll", [*CORE, *RUNTIME, STANDIN], target="library", defines=defines)


# ---- live: the component against `shlight serve` with absolute lighting ---------------------------------

from servertools import ServeProcess  # noqa: E402
from photometrytools import exact_illuminance_up, scene, write_bracket  # noqa: E402
from unitytools import S4, _LiveClient  # noqa: E402


def _first_absolute_message_with_a_light(exe, serve_args, client_args):
    """Run ``shlight serve SERVE_ARGS --lights auto --max-lights 1`` and the LiveClient (with a light, linear
    colour space, CLIENT_ARGS) against it; its first event applying an absolute message with a light."""
    with ServeProcess(*serve_args, "--lights", "auto", "--max-lights", "1", "--keepalive", "0.25") as server:
        client = _LiveClient(exe, server.url, "-", "default", "90", "--light", "--color-space=linear",
                             *client_args)
        try:
            _, ev = client.wait_for("an absolute message with a light",
                                    lambda e: e["event"] == "applied" and e["lights"] >= 1
                                    and e["wire_units"] == "cd/m²", timeout=90)
            assert client.quit() == 0
        finally:
            client.kill()
    return ev


def test_live_client_applies_the_rooms_exposure_and_colour_temperature(live_exe, camera, tmp_path):  # noqa: F811
    """SH9LightingClient (compiled with the stand-in, Unity's player loop played by tests/csharp/LiveClient.cs)
    against `shlight serve --camera camera.json --lux E --lights auto`: in Camera Image mode with +1 EV of
    compensation the SH9 globals are the ambient SH9 × 2 / (1.2 · 2^EV100) of the message, and with Use Color
    Temperature the Directional Light shows the light's colour temperature (light_cct_k, else cct_k) with
    GraphicsSettings.lightsUseColorTemperature turned on, at the luminance Y(E)/π × the same exposure."""
    from provider.core.geometry import sh
    hdr = scene("sky")
    (frame,) = write_bracket(tmp_path, "sun", hdr, (0,), n=8.0, iso=100, ext="jpg")
    ev = _first_absolute_message_with_a_light(
        live_exe, ["--source", str(frame), "--camera", str(camera), "--lux", str(exact_illuminance_up(hdr))],
        ["--exposure=camera_image", "--exposure-compensation=1", "--color-temperature"])
    exposure = 2 / (1.2 * 2 ** ev["wire_ev100"])
    assert ev["exposure_scale"] == pytest.approx(exposure, rel=1e-12) and ev["camera_ev100"] is None
    amb = np.array(ev["wire_ambient_coefficients"]).reshape(9, 3)
    expected = S4 @ sh.irradiance_matrices(amb) @ S4 * exposure
    applied = np.array(ev["matrices"]).reshape(3, 4, 4)
    assert np.allclose(applied, expected, rtol=0, atol=1e-6 * np.abs(expected).max())
    light_k = ev["wire_light_cct_k"][0] if ev["wire_light_cct_k"] and ev["wire_light_cct_k"][0] > 0 else None
    kelvin = light_k or ev["wire_cct_k"]
    assert kelvin, "the provider sends a colour temperature for a room in cd/m²"
    lt = ev["light"]
    print(f"\nEV100 {ev['wire_ev100']:.3f}, exposure {exposure:.3g}, light {kelvin:.0f} K "
          f"({'light_cct_k' if light_k else 'cct_k'}), intensity {lt['intensity']:.4g}")
    assert ev["light_active"] and lt["enabled"] and lt["use_color_temperature"]
    assert ev["lights_use_color_temperature"]          # turned on by the component (off in the stand-in)
    assert lt["color_temperature"] == pytest.approx(kelvin, rel=1e-6)
    assert ev["light_color_temperature_k"] == pytest.approx(kelvin, rel=1e-6)
    e = np.array(ev["wire_light_irradiance"][:3])
    assert float(REC709 @ np.array(lt["light_seen"])) == pytest.approx(float(REC709 @ e) / math.pi * exposure,
                                                                       rel=1e-4)


def test_live_client_sets_the_physical_camera_for_hdrp(camera, tmp_path):  # noqa: F811
    """Physical Camera mode (HDRP, Unity 2022.2+: the component built with UNITY_2022_2_OR_NEWER) against
    `shlight serve --camera camera.json --lights auto`: the camera's shutter speed at its own aperture and
    ISO gives the message's EV100 − c, the SH9 globals stay in lux (the ambient SH9 unscaled), and the
    Directional Light is E itself, lux (HDRP's Lambert divides by π): Y of what the shaders see is the
    message's light_illuminance_lux."""
    from provider.core.geometry import sh
    exe = _compile(tmp_path / "LiveClient2022.exe",
                   [*CORE, *RUNTIME, STANDIN, HARNESS, ROOT / "tests" / "csharp" / "LiveClient.cs"],
                   defines=("UNITY_2022_2_OR_NEWER",))
    hdr = scene("lab")
    (frame,) = write_bracket(tmp_path, "lab", hdr, (0,), n=4.0, iso=400, ext="jpg")
    ev = _first_absolute_message_with_a_light(
        exe, ["--source", str(frame), "--camera", str(camera)],
        ["--linear-intensity", "--exposure=physical_camera", "--exposure-compensation=-0.5",
         "--physical-camera=2.8,400"])
    ev100 = ev["wire_ev100"] + 0.5
    cam = ev["camera"]
    assert ev["camera_ev100"] == pytest.approx(ev100, rel=1e-6) and ev["exposure_scale"] == 1.0
    assert cam["aperture"] == pytest.approx(2.8) and cam["iso"] == 400
    assert math.log2(cam["aperture"] ** 2 / cam["shutter_speed"] * 100 / cam["iso"]) == pytest.approx(ev100, abs=1e-5)
    amb = np.array(ev["wire_ambient_coefficients"]).reshape(9, 3)
    expected = S4 @ sh.irradiance_matrices(amb) @ S4
    applied = np.array(ev["matrices"]).reshape(3, 4, 4)
    assert np.allclose(applied, expected, rtol=0, atol=1e-6 * np.abs(expected).max())
    lt = ev["light"]
    assert ev["light_active"] and lt["enabled"] and not lt["use_color_temperature"]
    e = np.array(ev["wire_light_irradiance"][:3])
    assert np.allclose(lt["light_seen"], e, rtol=1e-4)
    assert float(REC709 @ np.array(lt["light_seen"])) == pytest.approx(ev["wire_light_illuminance_lux"][0], rel=1e-4)
    print(f"\nEV100 {ev100:.3f} at f/2.8 ISO 400: 1/{1 / cam['shutter_speed']:.0f} s; light "
          f"{float(REC709 @ np.array(lt['light_seen'])):.1f} lux")
