"""Unity shadows (issue 30, docs/shadows_consumers.md): the package's C# under Mono.

* tests/csharp/ShadowsTest.cs: ``light_angular_radius_deg`` parsed (absent: zeros, a hard
  shadow; wrong length or out of [0, 90]: refused with a line naming the field), the key light
  (brightest by Rec. 709, 10 % hysteresis), Hard/Soft from the angular radius, the penumbra
  width, a snapshot that draws the key light (its direction in Unity's frame, every other light
  folded into the ambient), and Sh9Shadows.ShadowRatio against provider.core.lights.shadows.
* tests/csharp/LiveClient.cs --light --shadows against a live ``shlight serve --lights auto``:
  the component's Directional Light casts Soft shadows at strength 1 for a 3° sun, and the
  globals SHShadowRatio reads (_SHLightCount, _SHLightDirection[0], _SHLightIrradiance[0]) hold
  the drawn light in Unity's frame.
"""
from __future__ import annotations

import json
import math
import subprocess

import numpy as np
import pytest

from provider.core.conventions.formats import light_sh
from provider.core.geometry import sh
from provider.core.lights.shadows import (occluded_ambient, shadow_ratio, sphere_light_visibility,
                                          sphere_occluder)

from servertools import ServeProcess
from unitytools import (CORE, CSHARP, S3, S4, _compile, _LiveClient, _mono_tools,  # noqa: F401
                        _serve_help)
from shadowtools import SUN, write_sun_and_sky


def _ratio_cases(rng) -> list[dict]:
    cases = []
    for i in range(40):
        k = int(rng.integers(0, 5))
        amb = rng.normal(size=(9, 3))
        amb[0] = np.abs(amb[0]) + (0.2 if i % 5 else -0.5)      # some ambients ring below 0
        d = rng.normal(size=(k, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        e = rng.uniform(0, 5, size=(k, 3))
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        v = rng.uniform(0, 1, size=k)
        A = sh.irradiance_matrices(amb)
        # an occluding sphere near the receiver: above, cut by its horizon, below, or around it (i % 4 == 3)
        point = rng.normal(size=3)
        centre = point + rng.normal(size=3) * (0.05 if i % 4 == 3 else 1.0)
        radius = float(rng.uniform(0.1, 0.6))
        o = occluded_ambient(n, A, *sphere_occluder(point, centre, radius))
        cases.append({"name": f"case{i}", "lights": k, "ambient_matrices": A.reshape(-1).tolist(),
                      "light_directions": d.reshape(-1).tolist(), "light_irradiance": e.reshape(-1).tolist(),
                      "normal": n.tolist(), "visibility": v.tolist(),
                      "ratio": shadow_ratio(n, A, d.reshape(-1, 3), e.reshape(-1, 3), v).tolist(),
                      "point": point.tolist(), "occluder": [*centre, radius], "occluded_ambient": o.tolist(),
                      "occluded_ratio": shadow_ratio(n, A, d.reshape(-1, 3), e.reshape(-1, 3), v,
                                                     occluded_ambient=o).tolist()})
    return cases


def _snapshot_cases(rng) -> list[dict]:
    cases = []
    k = 3
    amb = rng.normal(size=(9, 3))
    amb[0] = np.abs(amb[0]) + 1
    d = rng.normal(size=(k, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    e = rng.uniform(0.5, 4, size=(k, 3))
    radii = [0.27, 4.0, 9.5]
    full = amb + sum(light_sh(d[i], e[i]) for i in range(k))
    msg = {"type": "sh9", "version": 1, "probe": "p", "seq": 1, "time": 1e9, "frame": "rh-y-up",
           "coefficients": full.reshape(-1).tolist(), "lights": k,
           "light_directions": d.reshape(-1).tolist(), "light_irradiance": e.reshape(-1).tolist(),
           "light_angular_radius_deg": radii, "ambient_coefficients": amb.reshape(-1).tolist()}
    for drawn in range(k):
        rest = amb + sum(light_sh(d[i], e[i]) for i in range(k) if i != drawn)
        order = [drawn] + [i for i in range(k) if i != drawn]      # the shader slots: drawn first
        cases.append({"message": json.dumps(msg), "drawn": drawn, "unity_direction": (d[drawn] @ S3).tolist(),
                      "slot_directions": (d[order] @ S3).reshape(-1).tolist() + [0.0] * 3,
                      "slot_irradiance": e[order].reshape(-1).tolist() + [0.0] * 3,
                      "slot_radii": [radii[i] for i in order] + [0.0],
                      "irradiance": e[drawn].tolist(), "radius": [radii[drawn]],
                      "unity_ambient_matrices": (S4 @ sh.irradiance_matrices(rest) @ S4).reshape(-1).tolist()})
    return cases


def _visibility_cases(rng) -> list[dict]:
    """Receivers behind a sphere and lights of 0 to 60°, a third grazing the sphere's rim, one inside."""
    cases = []
    for i in range(60):
        centre, radius = rng.normal(size=3), float(rng.uniform(0.1, 1.0))
        to_c = rng.normal(size=3)
        to_c /= np.linalg.norm(to_c)
        point = centre - to_c * (0.5 * radius if i == 0 else radius / rng.uniform(0.05, 0.95))   # 0: inside
        r = float(rng.choice([0.0, 0.27, 3.0, 9.0, 60.0]))
        d = rng.normal(size=3)
        if i % 3 == 1:                 # grazing: the light's centre on the rim, ± its radius
            dist = np.linalg.norm(centre - point)
            side = np.cross(to_c, d)
            side /= np.linalg.norm(side)
            g = math.asin(min(radius / dist, 1.0)) + rng.uniform(-1, 1) * math.radians(r)
            d = math.cos(g) * to_c + math.sin(g) * side
        d /= np.linalg.norm(d)
        cases.append({"point": point.tolist(), "sphere": [*centre, radius], "direction": d.tolist(),
                      "radius_deg": r, "visibility": [float(sphere_light_visibility(point, centre, radius,
                                                                                    d[None], [r])[0])]})
    return cases


def test_shadow_logic_under_mono(build_dir, tmp_path):
    exe = _compile(build_dir / "ShadowsTest.exe", [*CORE, CSHARP / "Checks.cs", CSHARP / "ShadowsTest.cs"])
    rng = np.random.default_rng(30)
    vectors = tmp_path / "shadows.json"
    vectors.write_text(json.dumps({"ratios": _ratio_cases(rng), "snapshots": _snapshot_cases(rng),
                                   "visibility": _visibility_cases(rng)}))
    _, mono = _mono_tools()
    r = subprocess.run([mono, str(exe), str(vectors)], capture_output=True, text=True, timeout=60)
    report = json.loads(r.stdout.strip().splitlines()[-1])
    assert r.returncode == 0 and not report["failures"], json.dumps(report, indent=1)
    assert report["cases"] == 43 + 60
    assert report["checks"]["sphere_light_visibility"]["count"] == 60
    print(f"sphere_light_visibility C# vs Python: max abs "
          f"{report['checks']['sphere_light_visibility']['max_abs']:.2e}")
    assert report["checks"]["radius_refused"]["count"] == 6
    print(f"\nshadow_ratio C# vs Python: max abs {report['checks']['shadow_ratio']['max_abs']:.2e}")
    assert report["checks"]["occluded_ambient"]["count"] == 40 * 3     # 40 cases, RGB
    print(f"occluded ratio C# vs Python: max abs {report['checks']['occluded_ratio']['max_abs']:.2e}")


def test_live_client_key_light_casts_soft_shadows(live_exe, tmp_path):
    """`shlight serve --lights auto` on a sky with a 3° sun: with KeyLightShadows the component's
    Directional Light shows the sun, casts Soft shadows at strength 1, reports the wire's angular
    radius, and sets sh9_lights.hlsl's light 0 to the drawn light (Unity frame, E as sent)."""
    if "--lights" not in _serve_help():
        pytest.skip("the provider sends no lights")
    pano = tmp_path / "sun.hdr"
    write_sun_and_sky(pano)
    with ServeProcess("--source", str(pano), "--lights", "auto", "--keepalive", "0.25") as server:
        client = _LiveClient(live_exe, server.url, "-", "default", "40", "--light", "--shadows",
                             "--color-space=linear", "--linear-intensity")
        try:
            _, ev = client.wait_for("a message with a light", lambda e: e["event"] == "applied" and e["lights"] >= 1,
                                    timeout=30)
            assert client.quit() == 0
        finally:
            client.kill()
    k = ev["lights"]
    irr = np.reshape(ev["wire_light_irradiance"], (k, 3))
    key = int(np.argmax(irr @ [0.2126, 0.7152, 0.0722]))
    d = np.reshape(ev["wire_light_directions"], (k, 3))[key]
    assert d @ SUN > math.cos(math.radians(2))
    radius = ev["wire_light_angular_radius_deg"][key]
    assert 1.5 < radius < 4.5, radius                       # the 3° disc, as the provider measures it
    assert ev["light_active"] and ev["light"]["shadows"] == "Soft" and ev["light"]["shadow_strength"] == 1
    assert abs(ev["light_angular_radius_deg"] - radius) < 1e-5
    assert ev["sh_light_count"] == min(k, 4)                 # the drawn light first, then the others
    assert ev["sh_light_angular_radius"][0] == pytest.approx(math.radians(radius), rel=1e-6)
    np.testing.assert_allclose(ev["sh_light_direction"][:3], d @ S3, atol=1e-6)
    np.testing.assert_allclose(ev["sh_light_irradiance"][:3], irr[key], rtol=1e-6)
    assert np.allclose(ev["light"]["forward"], -(d @ S3), atol=1e-5)


def test_occluder_component_uploads_the_holograms_bounding_sphere(build_dir):
    """SH9ShadowOccluder under Mono against the UnityEngine stand-in (not Unity): _SHOccluderSphere is the
    bounding sphere of the renderers' union box, follows them each LateUpdate, leaves a disabled renderer
    out, takes the radius scale, is cleared (radius 0) on disable; the last enabled occluder wins."""
    from unitytools import RUNTIME, STANDIN
    exe = _compile(build_dir / "OccluderTest.exe", [*CORE, *RUNTIME, STANDIN, CSHARP / "Checks.cs",
                                                    CSHARP / "OccluderTest.cs"])
    _, mono = _mono_tools()
    r = subprocess.run([mono, str(exe)], capture_output=True, text=True, timeout=60)
    report = json.loads(r.stdout.strip().splitlines()[-1])
    assert r.returncode == 0 and not report["failures"], json.dumps(report, indent=1)
    assert {"union_sphere", "follows", "disabled_renderer_left_out", "radius_scale", "cleared_on_disable",
            "last_enabled_wins", "no_renderers_no_occluder"} <= set(report["checks"])
