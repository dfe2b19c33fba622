"""Shadows in three.js (issue 30, docs/shadows_consumers.md): client-three.js's opt-in
``shadows`` turns the provider's key light into a DirectionalLight that casts shadows and keeps
a ShadowMaterial floor (a shadow catcher) at the key light's share of the floor's irradiance.

Real ``shlight serve --lights auto`` on a panorama with a sun disc and a sky, real headless
Chromium, three.js r187's own shadow maps (tests/node/node_modules). A sphere floats above the
catcher; seen from above with a transparent canvas:
* in the umbra the catcher's alpha (the darkening it multiplies the camera image by, 1 − α) is
  1 − shadow_ratio(up, V_key = 0) of the CPU (provider.core.lights.shadows), within UMBRA_TOL;
* away from the shadow the catcher is fully transparent (α = 0: the image untouched);
* the shadow lies where the key light's direction puts it, and with a larger angular radius
  the penumbra widens as shadowRadiusTexels says.
SHLIGHT_DOCS_SCREENSHOT=1 also writes docs/shadows_three.png.
"""
from __future__ import annotations

import os

import cv2
import numpy as np
import pytest

from browsertools import NEEDS_BROWSER, ROOT, browser, page_of, three_version  # noqa: F401
from envtools import THREE_URL, equirect_directions, png_of
from servertools import ServeProcess, http_get, poll
from shadowtools import SUN, SUN_RADIUS_DEG, write_sun_and_sky

pytestmark = NEEDS_BROWSER

#: Catcher alpha in the umbra against the CPU: 8-bit alpha (±0.5/255) and three's PCF noise
#: (5 Vogel taps rotated per pixel: none inside a full umbra); measured within 0.004.
UMBRA_TOL = 0.01

PAGE = """async ([threeUrl, provider]) => {
  const THREE = await import(threeUrl);
  const a = await import(provider + "/client-three.js");
  const S = 256;
  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true, alpha: true });
  renderer.setSize(S, S, false);
  renderer.setClearColor(0x000000, 0);
  renderer.toneMapping = THREE.NoToneMapping;
  document.body.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  // seen from straight above: +X right, −Z up in the picture, the floor 4 × 4 units
  const camera = new THREE.OrthographicCamera(-2, 2, 2, -2, 0.1, 20);
  camera.position.set(0, 10, 0);
  camera.up.set(0, 0, -1);
  camera.lookAt(0, 0, 0);
  const sphere = new THREE.Mesh(new THREE.SphereGeometry(0.3, 64, 32),
                                new THREE.MeshLambertMaterial({ color: 0xffffff }));
  sphere.position.set(0, 0.8, 0);
  sphere.castShadow = true;
  scene.add(sphere);
  const probe = new THREE.LightProbe();
  scene.add(probe);
  window.keys = 0;
  const conn = a.connectLightProbe(provider + "/", probe, {
    shadows: { THREE, scene, renderer, casterHeight: 0.8 },
    onLighting: () => { window.keys++; } });
  function render() {
    renderer.render(scene, camera);
    return renderer.domElement.toDataURL("image/png");
  }
  function onlyCatcher(on) { sphere.material.colorWrite = !on; sphere.material.depthWrite = !on; }
  window.t = { THREE, a, conn, renderer, scene, camera, sphere, probe, render, onlyCatcher, S };
  return true;
}"""


def cpu_umbra_ratio(msg: dict, key: int) -> tuple[float, np.ndarray]:
    """The floor's (normal +Y) ratio with the key light blocked and the others not, from the
    CPU reference (provider.core.lights.shadows): (Rec. 709 luminance of E_lit(n, V) over that
    of E_lit(n, 1): what one alpha can show; the per-colour shadow_ratio)."""
    from provider.core.lights.shadows import lit_irradiance, shadow_ratio
    k = msg["lights"]
    args = (np.array([0.0, 1.0, 0.0]), np.reshape(msg["ambient_matrices"], (3, 4, 4)),
            np.reshape(msg["light_directions"], (k, 3)), np.reshape(msg["light_irradiance"], (k, 3)))
    visibility = np.ones(k)
    visibility[key] = 0.0
    lum = np.array([0.2126, 0.7152, 0.0722])
    blocked, open_ = lit_irradiance(*args, visibility) @ lum, lit_irradiance(*args, np.ones(k)) @ lum
    return float(blocked / open_), shadow_ratio(*args, visibility)


def _alpha(page) -> np.ndarray:
    return png_of(page.evaluate("window.t.render()"))[..., 3].astype(float) / 255


def _floor_xz(S: int, row: float, col: float) -> tuple[float, float]:
    return -2 + 4 * (col + 0.5) / S, -2 + 4 * (row + 0.5) / S


def _shadow_profile(alpha: np.ndarray, S: int, centre, direction) -> tuple[np.ndarray, np.ndarray]:
    """Alpha along the floor line through `centre` (x, z) perpendicular to the light's
    horizontal direction: (offsets in floor units, alpha)."""
    perp = np.array([-direction[2], direction[0]])
    perp /= np.linalg.norm(perp)
    s = np.linspace(-0.8, 0.8, 321)
    x, z = centre[0] + s * perp[0], centre[1] + s * perp[1]
    cols, rows = (x + 2) / 4 * S - 0.5, (z + 2) / 4 * S - 0.5
    vals = cv2.remap(alpha.astype(np.float32), cols.astype(np.float32)[None], rows.astype(np.float32)[None],
                     cv2.INTER_LINEAR)[0]
    return s, vals


def _width_10_90(s, a, top):
    """Distance over which the profile's right flank falls from 90 % to 10 % of `top`."""
    right = s > 0
    ss, aa = s[right], a[right]
    return ss[np.argmax(aa < 0.1 * top)] - ss[np.argmax(aa < 0.9 * top)]


@pytest.mark.parametrize("scene", ["sun", "sky", "lab"])
def test_sphere_shadow_on_the_catcher_matches_the_cpu_ratio(browser, tmp_path, scene):
    """`sun`: the synthetic 3° sun (also the penumbra's growth with the radius, and the picture);
    `sky` and `lab`: real panoramas (a sun of 1.3°; two softboxes of about 10°, the key one
    blocked and the other not)."""
    if scene == "sun":
        pano = tmp_path / "sun.hdr"
        write_sun_and_sky(pano)
    else:
        pano = ROOT / "tests" / "data" / "hdri" / f"{scene}.exr"
    with ServeProcess("--source", str(pano), "--lights", "auto", "--keepalive", "60") as proc:
        import json
        status, _, body = poll(lambda: (r := http_get(proc.http + "/latest.json"))[0] == 200 and r,
                               what="first lighting")
        msg = json.loads(body)
        assert msg["lights"] >= 1
        with page_of(browser, proc.http + "/healthz") as page:
            page.evaluate(PAGE, [THREE_URL.format(version=three_version()), proc.http])
            page.wait_for_function("window.keys > 0", timeout=60000)
            got = page.evaluate("""() => { const s = window.t.conn.shadows, m = window.t.conn.latest.message;
              return { key: s.key && { index: s.key.index, direction: s.key.direction, share: s.key.share,
                                       radius: s.key.angularRadiusDeg },
                       opacity: s.catcher.material.opacity, intensity: s.light.intensity,
                       castShadow: s.light.castShadow, shadowRadius: s.light.shadow.radius,
                       position: s.light.position.toArray(), msg: m }; }""")
            msg = got["msg"]
            key = got["key"]
            assert key is not None and got["castShadow"]
            irr = np.reshape(msg["light_irradiance"], (-1, 3)) @ [0.2126, 0.7152, 0.0722]
            assert key["index"] == int(np.argmax(irr))                         # the brightest
            d = np.reshape(msg["light_directions"], (-1, 3))[key["index"]]
            if scene == "sun":
                assert d @ SUN > np.cos(np.radians(2)), (d, SUN)               # the sun
            np.testing.assert_allclose(key["direction"], d / np.linalg.norm(d), atol=1e-5)
            # the key light: brightest by Rec. 709, kept within 10 %, handed over beyond
            picks = page.evaluate("""() => { const k = window.t.a.keyLightIndex, e = [1,1,1, 3,3,3, 2.9,2.9,2.9];
              return [k(e), k(e, 2), k(e, 0), k(e, 7), k([]), k([2,0,2, 0,1,0])]; }""")
            assert picks == [1, 2, 1, 1, -1, 1], picks
            # the LightProbe gets the full SH9 less the key light's E·Y(d): the ambient plus the others
            from provider.core.conventions.formats import light_sh
            others = np.reshape(msg["ambient_coefficients"], (9, 3)) + sum(
                (light_sh(np.reshape(msg["light_directions"], (-1, 3))[i], np.reshape(msg["light_irradiance"], (-1, 3))[i])
                 for i in range(msg["lights"]) if i != key["index"]), np.zeros((9, 3)))
            probe = page.evaluate("() => window.t.probe.sh.coefficients.flatMap((v) => [v.x, v.y, v.z])")
            np.testing.assert_allclose(probe, others.reshape(-1), rtol=1e-5, atol=1e-6 * np.abs(msg["coefficients"]).max())
            # the catcher's opacity is the key light's share in Rec. 709 luminance (the synthetic
            # sky is grey, so there the per-colour ratios are alike)
            cpu_lum, cpu = cpu_umbra_ratio(msg, key["index"])
            if scene == "sun":
                assert np.all(np.abs(cpu - cpu_lum) < 0.02), (cpu, cpu_lum)
            assert abs(got["opacity"] - (1 - cpu_lum)) < 1e-4, (got["opacity"], cpu_lum)

            page.evaluate("window.t.onlyCatcher(true)")
            alpha = _alpha(page)
            S = alpha.shape[0]
            # where the shadow's centre falls: the sphere's centre projected along −d to y = 0
            centre = np.array([0.0, 0.8, 0.0]) - 0.8 / d[1] * d
            col, row = (centre[0] + 2) / 4 * S - 0.5, (centre[2] + 2) / 4 * S - 0.5
            r0, c0 = int(round(row)), int(round(col))
            umbra = alpha[r0 - 3:r0 + 4, c0 - 3:c0 + 4]
            print(f"umbra alpha {umbra.mean():.4f} (min {umbra.min():.4f}, max {umbra.max():.4f}); "
                  f"CPU 1 − ratio {1 - cpu_lum:.4f}; shadow.radius {got['shadowRadius']:.2f} texels")
            assert np.all(np.abs(umbra - (1 - cpu_lum)) < UMBRA_TOL), (umbra, 1 - cpu_lum)
            # away from the shadow (more than 0.5 units from its centre, on the floor): untouched
            rows, cols = np.mgrid[0:S, 0:S]
            x, z = -2 + 4 * (cols + 0.5) / S, -2 + 4 * (rows + 0.5) / S
            far = np.hypot(x - centre[0], z - centre[2]) > 0.7
            assert alpha[far].max() == 0, alpha[far].max()
            # where three's PCF disc (shadow.radius texels) stays inside the sphere's shadow: umbra
            blur = got["shadowRadius"] * 4 / 1024
            near = np.hypot(x - centre[0], z - centre[2]) < 0.27 - blur
            assert alpha[near].min() > 0.9 * (1 - cpu_lum)
            if scene != "sun":
                return

            # a larger angular radius: a wider penumbra, as shadowRadiusTexels says
            s_prof, a_prof = _shadow_profile(alpha, S, centre[[0, 2]], d)
            w_small = _width_10_90(s_prof, a_prof, 1 - cpu_lum)
            wide = page.evaluate("""() => { const t = window.t, s = t.conn.shadows;
              const key = { ...s.key, angularRadiusDeg: 6 };
              t.a.setKeyLight(s.light, key, { casterHeight: 0.8 });
              return s.light.shadow.radius; }""")
            expect = 0.8 * np.tan(np.radians(6)) * 1024 / 4
            assert abs(wide - expect) < 1e-6 * expect
            alpha_wide = _alpha(page)
            s_prof, a_wide = _shadow_profile(alpha_wide, S, centre[[0, 2]], d)
            w_wide = _width_10_90(s_prof, a_wide, 1 - cpu_lum)
            print(f"penumbra 90→10 %: {w_small:.3f} (radius {key['radius']:.2f}°) → "
                  f"{w_wide:.3f} units at 6°")
            assert w_wide > w_small + 0.03, (w_small, w_wide)

            if os.environ.get("SHLIGHT_DOCS_SCREENSHOT"):
                page.evaluate("window.t.onlyCatcher(false)")
                page.evaluate("""() => { const t = window.t, s = t.conn.shadows;
                  t.a.setKeyLight(s.light, s.key, { casterHeight: 0.8 }); }""")
                picture(png_of(page.evaluate("window.t.render()")), alpha, a_prof, s_prof,
                        1 - cpu_lum, msg, key)


def picture(rgba, alpha, profile, s, umbra, msg, key):
    """docs/shadows_three.png: the page over a grey 'camera image', and the catcher's
    multiplier across the shadow against the CPU ratio."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    grey = 0.55
    a = rgba[..., 3:4].astype(float) / 255
    shown = rgba[..., :3].astype(float) / 255 * a + grey * (1 - a)
    fig, ax = plt.subplots(1, 2, figsize=(10, 4.4))
    ax[0].imshow(shown, extent=(-2, 2, 2, -2))
    ax[0].set_title("three.js r187: sphere over a ShadowMaterial catcher\n(seen from above, over a grey image)")
    ax[0].set_xlabel("x"); ax[0].set_ylabel("z")
    ax[1].plot(s, 1 - profile, label="catcher: image multiplier 1 − α")
    ax[1].axhline(1 - umbra, color="k", ls="--", label=f"CPU shadow_ratio, key light blocked ({1 - umbra:.3f})")
    ax[1].set_ylim(0, 1.05); ax[1].set_xlabel("across the shadow (floor units)")
    ax[1].set_title(f"key light: angular radius {key['radius']:.2f}°, share {key['share']:.3f}")
    ax[1].legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "shadows_three.png", dpi=90)
    plt.close(fig)


# ---- the WebXR example page (xr.html?shadows=1) on a real inline XRSession -----------------

#: Seen from straight above the preview's floor (y = −1.3); the sphere drawn into the shadow
#: map only. Returns the catcher's alpha at floor points [x, z] (bilinear, from the canvas).
XR_TOP_VIEW = """(points) => { const s = window.shlight, THREE = s.THREE;
  s.camera.position.set(0, 6, 0); s.camera.up.set(0, 0, -1); s.camera.lookAt(0, -1.3, 0);
  s.camera.updateMatrixWorld();
  s.sphere.material = new THREE.MeshLambertMaterial({ colorWrite: false, depthWrite: false });
  const c = s.renderer.domElement;
  return points.map(([x, z]) => { const p = new THREE.Vector3(x, -1.3, z).project(s.camera);
    return [(p.x + 1) / 2 * c.width - 0.5, (1 - p.y) / 2 * c.height - 0.5]; });
}"""


def occluded_share(ambient_matrices, total_luminance, points, centre, radius, up=(0.0, 1.0, 0.0)):
    """The CPU's share of the floor's light that a sphere hides of the ambient at floor points
    (n, 3): Rec. 709 luminance of min(occluded_ambient, max(E_a(up), 0)) over the open
    irradiance's luminance (provider.core.lights.shadows)."""
    from provider.core.geometry import sh
    from provider.core.lights.shadows import occluded_ambient, sphere_occluder
    A = np.reshape(ambient_matrices, (3, 4, 4))
    n = np.broadcast_to(np.asarray(up, float), (len(points), 3))
    o = occluded_ambient(n, A, *sphere_occluder(points, centre, radius))
    a = np.maximum(sh.irradiance_from_matrices(A, n), 0.0)
    return (np.minimum(o, a) @ [0.2126, 0.7152, 0.0722]) / total_luminance


def test_the_catchers_glsl_is_the_shipped_glsl():
    """client-three.js's occluder GLSL is a verbatim copy of shaders/sh9_lights.glsl's functions."""
    import re
    shipped = (ROOT / "shaders" / "sh9_lights.glsl").read_text()
    js = (ROOT / "provider" / "live" / "server" / "static" / "client-three.js").read_text()
    for name in ("shRadianceFromMatrix", "shOccludedAmbient", "shOccludedAmbientOfSphere", "shCapSegment",
                 "shCapHalfChord", "shCapOverlapFraction", "shSphereLightVisibility"):
        body = re.search(r"^(float|vec3) " + name + r"\(.*?^}\n", shipped, re.S | re.M).group(0)
        assert body in js, name


def test_the_occluder_darkens_the_floor_around_the_sphere_as_the_cpu(browser, tmp_path):
    """connectLightProbe's `shadows.occluder` = the sphere: the catcher's alpha is the key light's
    share in its umbra plus, everywhere, the share of the floor's light the sphere hides of the
    ambient (per pixel, from its bounding sphere), as the CPU computes (occluded_ambient), within
    UMBRA_TOL; far from the sphere it fades to 0."""
    import json
    pano = tmp_path / "sun.hdr"
    write_sun_and_sky(pano)
    with ServeProcess("--source", str(pano), "--lights", "auto", "--keepalive", "60") as proc:
        poll(lambda: (r := http_get(proc.http + "/latest.json"))[0] == 200 and r, what="first lighting")
        with page_of(browser, proc.http + "/healthz") as page:
            page.evaluate(PAGE, [THREE_URL.format(version=three_version()), proc.http])
            page.wait_for_function("window.keys > 0", timeout=60000)
            page.evaluate("() => { window.t.conn.shadows.occluder = window.t.sphere; }")
            got = page.evaluate("""() => { const s = window.t.conn.shadows;
              const b = window.t.a.occluderSphere(window.t.THREE, window.t.sphere);
              return { key: s.key.index, share: s.key.share, msg: window.t.conn.latest.message,
                       centre: b.center.toArray(), radius: b.radius }; }""")
            msg = got["msg"]
            np.testing.assert_allclose(got["centre"], [0, 0.8, 0], atol=1e-6)
            assert abs(got["radius"] - 0.3) < 1e-3                     # the sphere's own, not its box's
            page.evaluate("window.t.onlyCatcher(true)")
            alpha = _alpha(page)
    S = alpha.shape[0]
    k = msg["lights"]
    lum = np.array([0.2126, 0.7152, 0.0722])
    d = np.reshape(msg["light_directions"], (k, 3))[got["key"]]
    total = (np.maximum(np.reshape(msg["ambient_matrices"], (3, 16))[:, 15]
                        + np.reshape(msg["ambient_matrices"], (3, 4, 4))[:, 1, 1]
                        + 2 * np.reshape(msg["ambient_matrices"], (3, 4, 4))[:, 1, 3], 0) @ lum
             + sum(np.reshape(msg["light_irradiance"], (k, 3))[i] @ lum
                   * max(0.0, np.reshape(msg["light_directions"], (k, 3))[i][1]) for i in range(k)))
    rows, cols = np.mgrid[0:S, 0:S]
    x, z = -2 + 4 * (cols + 0.5) / S, -2 + 4 * (rows + 0.5) / S
    points = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], -1)
    occ = occluded_share(msg["ambient_matrices"], total, points, [0, 0.8, 0], 0.3).reshape(S, S)
    umbra_centre = np.array([0.0, 0.8, 0.0]) - 0.8 / d[1] * d
    dist = np.hypot(x - umbra_centre[0], z - umbra_centre[2])
    open_ = dist > 0.7                                   # the key light's shadow does not reach
    umbra = dist < 0.1
    print(f"occluded share: max {occ.max():.4f}; open floor |alpha − CPU| max "
          f"{np.abs(alpha - occ)[open_].max():.4f}; umbra alpha {alpha[umbra].mean():.4f} vs "
          f"{(got['share'] + occ)[umbra].mean():.4f}")
    assert occ.max() > 0.05                              # the sphere does hide a visible share
    assert np.abs(alpha - occ)[open_].max() < UMBRA_TOL
    assert np.abs(alpha - np.minimum(1, got["share"] + occ))[umbra].max() < UMBRA_TOL
    assert alpha[np.hypot(x, z) > 1.9].max() < 0.02      # it fades away from the sphere
    if os.environ.get("SHLIGHT_DOCS_SCREENSHOT"):
        occluder_picture(alpha, occ, x, z, umbra_centre)


def occluder_picture(alpha, occ, x, z, umbra_centre):
    """docs/shadows_three_occluder.png: the catcher's darkening (its alpha) with the sphere as the
    occluder, the CPU's occluded share alone, and a profile through the sphere's foot and the umbra."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 3, figsize=(13, 4.2))
    ext = (-2, 2, 2, -2)
    ax[0].imshow(alpha, vmin=0, vmax=0.7, cmap="gray_r", extent=ext)
    ax[0].set_title("three.js catcher alpha (darkening), occluder on\nsphere r 0.3, centre 0.8 above, 3° sun")
    ax[1].imshow(occ, vmin=0, vmax=0.7, cmap="gray_r", extent=ext)
    ax[1].set_title("CPU: share of the floor's light the sphere\nhides of the ambient (occluded_ambient)")
    S = alpha.shape[0]
    row = S // 2
    ax[2].plot(x[row], alpha[row], label="catcher alpha (8-bit, run)")
    ax[2].plot(x[row], occ[row], "k--", label="CPU occluded share (no key shadow)")
    ax[2].set_xlabel("x on the floor, z = 0"); ax[2].set_ylim(0, 0.7); ax[2].legend(loc="upper right", fontsize=8)
    ax[2].set_title("through the sphere's foot (x = 0)")
    for a_ in ax[:2]:
        a_.set_xlabel("x"); a_.set_ylabel("z")
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "shadows_three_occluder.png", dpi=80)
    plt.close(fig)


LAMP = np.array([-0.5, 0.75, 0.4])
LAMP /= np.linalg.norm(LAMP)


def write_sun_lamp_and_sky(path, h: int = 256) -> None:
    """write_sun_and_sky's panorama plus a bluish lamp of 8° toward LAMP (E⊥ ≈ 0.6): the provider
    finds two lights, the sun (key) and the lamp."""
    d = equirect_directions(h, 2 * h)
    img = np.where(d[..., 1:2] > 0, 0.3, 0.05).astype(np.float32).repeat(3, axis=-1)
    img[d @ SUN > np.cos(np.radians(SUN_RADIUS_DEG))] = 150.0
    img[d @ LAMP > np.cos(np.radians(8.0))] = [10.0, 11.0, 14.0]
    assert cv2.imwrite(str(path), img[..., ::-1])


def test_two_lights_each_cast_their_shadow_with_the_occluder(browser, tmp_path):
    """Issue 30 part B: a 2-light message (a 3° sun, the key light, and an 8° lamp) and the sphere
    as `shadows.occluder`: the catcher shows the sun's shadow from the shadow map and the lamp's
    from the occluder sphere in the shader (shSphereLightVisibility). Wherever the sun's shadow map
    does not reach (beyond 0.12 units of its shadow), the alpha is 1 − the Rec. 709 luminance of
    the CPU's shadow_ratio(n, V, occluded_ambient) with V from sphere_light_visibility, within
    UMBRA_TOL; in the lamp's umbra it is well above the occluded ambient alone; in the sun's umbra
    it is the CPU's too."""
    import json
    from provider.core.lights.shadows import (lit_irradiance, occluded_ambient, sphere_light_visibility,
                                              sphere_occluder)
    pano = tmp_path / "two.hdr"
    write_sun_lamp_and_sky(pano)
    with ServeProcess("--source", str(pano), "--lights", "auto", "--keepalive", "60") as proc:
        poll(lambda: (r := http_get(proc.http + "/latest.json"))[0] == 200 and r, what="first lighting")
        with page_of(browser, proc.http + "/healthz") as page:
            page.evaluate(PAGE, [THREE_URL.format(version=three_version()), proc.http])
            page.wait_for_function("window.keys > 0 && window.t.conn.latest.message.lights === 2", timeout=60000)
            page.evaluate("() => { window.t.conn.shadows.occluder = window.t.sphere; }")
            got = page.evaluate("() => ({ key: window.t.conn.shadows.key.index, msg: window.t.conn.latest.message })")
            page.evaluate("window.t.onlyCatcher(true)")
            alpha = _alpha(page)
            page.evaluate("window.t.onlyCatcher(false)")
            shown = png_of(page.evaluate("window.t.render()")) if os.environ.get("SHLIGHT_DOCS_SCREENSHOT") else None
            # a message whose light_irradiance disagrees with its `lights` has no lights, for the
            # catcher as for keyLight/otherLights: the ambient's occluder term stays, no light's share
            bad = page.evaluate("""() => { const t = window.t, s = t.conn.shadows, u = s.catcher.userData.shOccluder;
              const m = t.conn.latest.message, b = { ...m, light_irradiance: m.light_irradiance.slice(0, 3) };
              const read = () => ({ share: u.shOtherShare.value.toArray(), scale: u.shOccluderScale.value });
              const good = read();
              t.a.setCatcherLighting(t.THREE, s.catcher, b, { key: s.key.index });
              return { good, bad: read(), key: t.a.keyLight(b), others: t.a.otherLights(b) }; }""")
    assert bad["good"]["share"][0] > 0 and bad["good"]["scale"] > 0, bad
    assert bad["bad"]["share"] == [0, 0, 0] and bad["bad"]["scale"] > bad["good"]["scale"], bad
    assert bad["key"] is None and bad["others"] == [], bad
    msg, key = got["msg"], got["key"]
    k = msg["lights"]
    d = np.reshape(msg["light_directions"], (k, 3))
    e = np.reshape(msg["light_irradiance"], (k, 3))
    radii = np.asarray(msg["light_angular_radius_deg"], float)
    assert k == 2 and d[key] @ SUN > 0.999 and d[1 - key] @ LAMP > 0.999
    S = alpha.shape[0]
    rows, cols = np.mgrid[0:S, 0:S]
    x, z = -2 + 4 * (cols + 0.5) / S, -2 + 4 * (rows + 0.5) / S
    points = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], -1)
    centre, radius = np.array([0.0, 0.8, 0.0]), 0.3
    A = np.reshape(msg["ambient_matrices"], (3, 4, 4))
    n = np.tile([0.0, 1.0, 0.0], (len(points), 1))
    v = sphere_light_visibility(points, centre, radius, d, radii)
    o = occluded_ambient(n, A, *sphere_occluder(points, centre, radius))
    lum = np.array([0.2126, 0.7152, 0.0722])
    from provider.core.geometry import sh
    amb = np.maximum(sh.irradiance_from_matrices(A, n), 0.0)
    lit = (lit_irradiance(n, A, d, e, v) - np.minimum(o, amb)) @ lum
    open_ = lit_irradiance(n, A, d, e, np.ones(k)) @ lum
    cpu = (1 - lit / open_).reshape(S, S)
    occ = ((np.minimum(o, amb) @ lum) / open_).reshape(S, S)
    v_key, v_lamp = v[:, key].reshape(S, S), v[:, 1 - key].reshape(S, S)
    # beyond the reach of the key light's shadow map (its shadow, with three's PCF blur, and a margin)
    key_shadow = (v_key < 1.0).astype(np.uint8)
    far_from_key = cv2.distanceTransform(1 - key_shadow, cv2.DIST_L2, 5) * 4 / S > 0.12
    lamp_umbra = (v_lamp < 1e-6) & far_from_key
    key_umbra = cv2.erode((v_key < 1e-6).astype(np.uint8), np.ones((9, 9), np.uint8)) > 0
    err_open = float(np.abs(alpha - cpu)[far_from_key].max())
    err_key = float(np.abs(alpha - cpu)[key_umbra].max())
    print(f"\nlamp umbra: alpha {alpha[lamp_umbra].mean():.4f} vs CPU {cpu[lamp_umbra].mean():.4f} "
          f"(occluded ambient alone {occ[lamp_umbra].mean():.4f}); beyond the sun's shadow max |alpha − CPU| "
          f"{err_open:.4f}; sun umbra max |alpha − CPU| {err_key:.4f}")
    assert lamp_umbra.sum() > 100 and key_umbra.sum() > 100
    assert err_open < UMBRA_TOL and err_key < UMBRA_TOL
    assert (alpha - occ)[lamp_umbra].min() > 0.1                 # the lamp's own shadow is there
    if shown is not None:
        two_lights_picture(shown, alpha, cpu, x, z, msg, key, radii)


def two_lights_picture(shown, alpha, cpu, x, z, msg, key, radii):
    """docs/shadows_three_two_lights.png: the page (sphere, catcher over a transparent canvas shown
    on grey), the catcher's darkening against the CPU's, and a profile through both shadows."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rgb = shown[..., :3].astype(float) / 255
    a = shown[..., 3:4].astype(float) / 255
    over_grey = rgb * a + 0.6 * (1 - a)
    d = np.reshape(msg["light_directions"], (2, 3))
    feet = [np.array([0.0, 0.8, 0.0]) - 0.8 / d[i][1] * d[i] for i in (key, 1 - key)]
    t = np.linspace(-0.5, 1.5, 400)
    line = feet[0][None] + t[:, None] * (feet[1] - feet[0])[None]
    S = alpha.shape[0]
    ij = np.clip(np.round((line[:, [2, 0]] + 2) / 4 * S - 0.5).astype(int), 0, S - 1)
    fig, ax = plt.subplots(1, 3, figsize=(13, 4.3))
    ext = (-2, 2, 2, -2)
    ax[0].imshow(np.clip(over_grey, 0, 1), extent=ext)
    ax[0].set_title(f"three.js: sphere over the catcher (on grey)\nsun {radii[key]:.1f}° (shadow map), "
                    f"lamp {radii[1 - key]:.1f}° (occluder sphere)", fontsize=9)
    ax[1].imshow(alpha, vmin=0, vmax=0.6, cmap="gray_r", extent=ext)
    ax[1].plot(line[:, 0], line[:, 2], "r:", lw=1)
    ax[1].set_title("catcher alpha (darkening), run in Chromium")
    ax[2].plot(t, alpha[ij[:, 0], ij[:, 1]], label="catcher alpha (8-bit)")
    ax[2].plot(t, cpu[ij[:, 0], ij[:, 1]], "k--", label="1 − CPU shadow_ratio (Rec. 709)")
    ax[2].set_xlabel("along the dotted line (0: sun's shadow, 1: lamp's)"); ax[2].set_ylim(0, 0.6)
    ax[2].legend(loc="upper center", fontsize=8); ax[2].set_title("through both shadows")
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "shadows_three_two_lights.png", dpi=80)
    plt.close(fig)


def test_webxr_page_shadow_from_xr_estimated_light(browser, tmp_path):
    """xr.html?shadows=1: in the preview the key light of the sh9 messages casts the shadow;
    in a session three's XREstimatedLight (fed by the polyfill) does, its catcher's opacity is
    the primary light's share computed from the server's webxr export and equals 1 − the CPU
    shadow_ratio of the sh9 message; the umbra shows it plus the share of the ambient that the
    sphere (the page's occluder) hides there, and the rest of the floor that share alone (CPU:
    occluded_ambient with the export's SH)."""
    from provider.core.geometry import sh
    from xrtools import INLINE_LE, START_SESSION, webxr_latest
    from browsertools import REFUSED, canvas_rgba
    pano = tmp_path / "sun.hdr"
    write_sun_and_sky(pano)
    with ServeProcess("--source", str(pano), "--lights", "auto", "--keepalive", "60") as proc:
        with page_of(browser, proc.http + "/xr.html?shadows=1", tolerate=f"{REFUSED}|{INLINE_LE}") as page:
            page.wait_for_function("window.shlight && window.shlight.conn.shadows && "
                                   "window.shlight.conn.shadows.key !== null", timeout=30000)
            preview = page.evaluate("""() => { const s = window.shlight, sh = s.conn.shadows;
              return { share: sh.key.share, opacity: s.floor.material.opacity, visible: sh.light.visible,
                       cast: sh.light.castShadow, sphere: s.sphere.castShadow, active: s.xrShadow.active,
                       msg: s.conn.latest.message }; }""")
            assert preview["cast"] and preview["sphere"] and preview["visible"] and not preview["active"]
            assert preview["opacity"] == preview["share"] > 0.3
            cpu_lum, _ = cpu_umbra_ratio(preview["msg"], int(np.argmax(
                np.reshape(preview["msg"]["light_irradiance"], (-1, 3)) @ [0.2126, 0.7152, 0.0722])))
            assert abs(preview["share"] - (1 - cpu_lum)) < 1e-4

            page.evaluate(START_SESSION)
            page.wait_for_function("window.started === 1 && !window.shlight.lightProbe.visible", timeout=20000)
            held = page.evaluate("""() => { const s = window.shlight; s.xrShadow.update();
              const dl = s.xrLight.directionalLight;
              return { share: s.xrShadow.share, opacity: s.floor.material.opacity, active: s.xrShadow.active,
                       radius: s.xrShadow.angularRadiusDeg, shadowRadius: dl.shadow.radius,
                       cast: dl.castShadow, preview: s.conn.shadows.light.visible,
                       position: dl.position.toArray() }; }""")
            assert held["active"] and held["cast"] and not held["preview"]
            latest = webxr_latest(proc.http)
            d = latest["primaryLightDirection"]
            d = np.array([d["x"], d["y"], d["z"]])
            e = latest["primaryLightIntensity"]
            e = np.array([e["x"], e["y"], e["z"]])
            lum = np.array([0.2126, 0.7152, 0.0722])
            e_probe = np.maximum(sh.irradiance(np.reshape(latest["sphericalHarmonicsCoefficients"], (9, 3)),
                                               np.array([[0.0, 1.0, 0.0]]))[0], 0) @ lum
            key = (e @ lum) * max(0.0, d[1])
            share = key / (e_probe + key)
            assert abs(held["share"] - share) < 1e-4, (held["share"], share)
            assert abs(held["share"] - (1 - cpu_lum)) < 2e-3, (held["share"], 1 - cpu_lum)
            assert held["opacity"] == held["share"]
            radius = preview["msg"].get("light_angular_radius_deg", [0])[0]
            assert abs(held["radius"] - radius) < 1e-9

            centre = np.array([0.0, 0.0, 0.0]) - (1.3 / d[1]) * d        # the umbra's centre
            points = [[centre[0], centre[2]], [1.6, -1.6], [2.0, 0.5], [-0.5, -2.0]]
            at = page.evaluate(XR_TOP_VIEW, points)
            alpha = canvas_rgba(page)[..., 3].astype(np.float32) / 255
            vals = [float(cv2.remap(alpha, np.float32([[x]]), np.float32([[y]]), cv2.INTER_LINEAR)[0, 0])
                    for x, y in at]
            # the occluder (the page's sphere: radius 1 at the origin, the catcher 1.3 below) also
            # hides part of the estimate's ambient from each floor point: its CPU share, added
            occ = occluded_share(sh.irradiance_matrices(np.reshape(latest["sphericalHarmonicsCoefficients"], (9, 3))),
                                 e_probe + key, np.array([[x, -1.3, z] for x, z in points]), [0, 0, 0], 1.0)
            want = [min(1.0, held["share"] + occ[0]), *occ[1:]]
            print(f"XR umbra alpha {vals[0]:.4f}, share {held['share']:.4f} + occluded {occ[0]:.4f}; "
                  f"away {vals[1:]} vs occluded {occ[1:]}")
            assert np.all(np.abs(np.array(vals) - want) < UMBRA_TOL), (vals, want)
            assert max(occ[1:]) < 0.1 < occ[0]
            if os.environ.get("SHLIGHT_DOCS_SCREENSHOT"):
                xr_picture(canvas_rgba(page), held)


def test_webxr_two_lights_each_cast_their_shadow_with_the_occluder(browser, tmp_path):
    """xr.html?shadows=1 in a session with a 2-light message (3° sun, 8° lamp): the estimate holds
    the sun as its primary light and the lamp in its SH; with the page's sphere as occluder,
    xrShadows takes the lamp's SH9 projection back out (otherLights from the sh9 messages) and the
    lamp casts its own shadow past the sphere: in its umbra the alpha is the occluded ambient's
    share plus the lamp's, as the CPU computes (occluded_ambient of the export's SH less the lamp,
    sphere_light_visibility), within UMBRA_TOL, well above the occluded ambient alone."""
    from provider.core.conventions.formats import light_sh
    from provider.core.geometry import sh
    from provider.core.lights.shadows import sphere_light_visibility
    from xrtools import INLINE_LE, START_SESSION, webxr_latest
    from browsertools import REFUSED, canvas_rgba
    pano = tmp_path / "two.hdr"
    write_sun_lamp_and_sky(pano)
    with ServeProcess("--source", str(pano), "--lights", "auto", "--keepalive", "60") as proc:
        with page_of(browser, proc.http + "/xr.html?shadows=1", tolerate=f"{REFUSED}|{INLINE_LE}") as page:
            page.wait_for_function("window.shlight && window.shlight.conn.shadows && "
                                   "window.shlight.conn.shadows.key !== null && "
                                   "window.shlight.conn.latest.message.lights === 2", timeout=30000)
            page.evaluate(START_SESSION)
            page.wait_for_function("window.started === 1 && !window.shlight.lightProbe.visible", timeout=20000)
            held = page.evaluate("""() => { const s = window.shlight; s.xrShadow.update();
              return { msg: s.conn.latest.message, share: s.xrShadow.share }; }""")
            latest = webxr_latest(proc.http)
            msg = held["msg"]
            lum = np.array([0.2126, 0.7152, 0.0722])
            d_l = np.reshape(msg["light_directions"], (2, 3))
            e_l = np.reshape(msg["light_irradiance"], (2, 3))
            key = int(np.argmax(e_l @ lum))
            lamp_d, lamp_e, lamp_r = d_l[1 - key], e_l[1 - key], msg["light_angular_radius_deg"][1 - key]
            assert lamp_d @ LAMP > 0.999
            d = latest["primaryLightDirection"]
            d = np.array([d["x"], d["y"], d["z"]])
            e = latest["primaryLightIntensity"]
            e = np.array([e["x"], e["y"], e["z"]])
            coeffs = np.reshape(latest["sphericalHarmonicsCoefficients"], (9, 3)) - light_sh(lamp_d, lamp_e)
            up = np.array([[0.0, 1.0, 0.0]])
            total = (np.maximum(sh.irradiance(coeffs, up)[0], 0) @ lum + (e @ lum) * max(0.0, d[1])
                     + (lamp_e @ lum) * max(0.0, lamp_d[1]))
            feet = {name: np.array([0.0, 0.0, 0.0]) - (1.3 / v[1]) * v for name, v in (("lamp", lamp_d), ("sun", d))}
            points = np.array([[feet["lamp"][0], -1.3, feet["lamp"][2]], [1.8, -1.3, 1.8]])
            at = page.evaluate(XR_TOP_VIEW, points[:, [0, 2]].tolist())
            alpha = canvas_rgba(page)[..., 3].astype(np.float32) / 255
            vals = [float(cv2.remap(alpha, np.float32([[x]]), np.float32([[y]]), cv2.INTER_LINEAR)[0, 0])
                    for x, y in at]
    occ = occluded_share(sh.irradiance_matrices(coeffs), total, points, [0, 0, 0], 1.0)
    v_lamp = sphere_light_visibility(points, np.zeros(3), 1.0, lamp_d[None], [lamp_r])[:, 0]
    want = occ + (lamp_e @ lum) * max(0.0, lamp_d[1]) / total * (1 - v_lamp)
    print(f"\nXR lamp umbra alpha {vals[0]:.4f} vs CPU {want[0]:.4f} (occluded ambient alone {occ[0]:.4f}); "
          f"open floor {vals[1]:.4f} vs {want[1]:.4f}")
    assert v_lamp[0] == 0.0 and v_lamp[1] == 1.0
    assert np.all(np.abs(np.array(vals) - want) < UMBRA_TOL), (vals, want)
    assert vals[0] - occ[0] > 0.1                                   # the lamp's own shadow is there


def test_xr_shadows_work_once_a_frame(browser, tmp_path):
    """three calls a catcher's onBeforeRender once per view (twice a frame in stereo): xrShadows'
    update runs once a frame (its angular-radius callback is asked once), and again the next frame."""
    from xrtools import INLINE_LE
    from browsertools import REFUSED
    pano = tmp_path / "sun.hdr"
    write_sun_and_sky(pano)
    with ServeProcess("--source", str(pano), "--lights", "auto", "--keepalive", "60") as proc:
        with page_of(browser, proc.http + "/xr.html?shadows=1", tolerate=f"{REFUSED}|{INLINE_LE}") as page:
            page.wait_for_function("window.shlight && window.shlight.xrShadow", timeout=30000)
            calls = page.evaluate("""async () => {
              const s = window.shlight, a = await import("/client-three.js");
              let asked = 0;
              const catcher = a.shadowCatcher(s.THREE);
              a.xrShadows(s.THREE, s.xrLight, { catcher, angularRadiusDeg: () => { asked++; return 1; } });
              const view = () => catcher.onBeforeRender(s.renderer, s.scene, s.camera, catcher.geometry,
                                                         catcher.material, null);
              view(); view();                        // the two eyes of one frame
              const one = asked;
              s.renderer.render(s.scene, s.camera);  // the next frame
              view(); view();
              return [one, asked];
            }""")
    assert calls == [1, 2], calls


def xr_picture(rgba, held):
    """docs/shadows_webxr.png: xr.html?shadows=1 in a session (XREstimatedLight fed by the polyfill),
    seen from above (the sphere drawn into the shadow map only), over a grey 'camera image'."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    a = rgba[..., 3:4].astype(float) / 255
    shown = rgba[..., :3].astype(float) / 255 * a + 0.55 * (1 - a)
    fig, ax = plt.subplots(figsize=(4.6, 4.6))
    ax.imshow(shown)
    ax.set_axis_off()
    ax.set_title(f"WebXR: XREstimatedLight's primary light (share {held['share']:.3f},\n"
                 f"angular radius {held['radius']:.2f}°) + the sphere's occluded ambient", fontsize=9)
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "shadows_webxr.png", dpi=90)
    plt.close(fig)
