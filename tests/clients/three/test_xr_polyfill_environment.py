"""The WebXR polyfill's reflection cube: XRWebGLBinding.getReflectionCubeMap(probe) for a probe
of ours is a WebGL cube texture of the provider's live cube, 'reflectionchange' fires on each
new cube, and three.js r187's own XREstimatedLight(renderer, true) shows the room in
xrLight.environment: a mirror sphere lit by it shows a one-sided scene's caps where three's
camera sees them. Real ``shlight serve --environment``, real headless Chromium and WebGL 2;
the XR device (session, frames, binding) is the stand-in of tests/clients/three/test_xr_polyfill.py.
"""
from __future__ import annotations

import cv2
import numpy as np

import consumer_pictures as cp
from browsertools import NEEDS_BROWSER, ROOT, PageHost, browser, page_of, three_version  # noqa: F401
from envtools import (SPHERE_VIEW, json_rows, reflected_directions, relative_error, served_cube,
                      write_caps)
from provider.core.radiometry.images import read_image
from provider.verify.cubemap import sample
from servertools import ServeProcess
from xrtools import APP_PAGE, STAND_INS

pytestmark = NEEDS_BROWSER

#: three's XREstimatedLight(renderer, true) on a stand-in session whose browser has no light
#: estimation; the polyfill answers. A mirror sphere (MeshStandardMaterial, metal) under
#: scene.environment = xrLight.environment, seen by an orthographic camera from +Z.
SETUP = """async ([provider, yaw, size]) => {
  const s = window.standIn;
  window.polyfill = m.installLightEstimationPolyfill({ url: provider, yaw, XRSession: s.Session,
    XRFrame: s.Frame, XRWebGLBinding: s.Binding, xr: s.xr });
  window.XRWebGLBinding = window.polyfill.XRWebGLBinding;   // three reads the global
  const renderer = new THREE.WebGLRenderer({ antialias: false });
  renderer.setSize(160, 160, false);
  renderer.toneMapping = THREE.NoToneMapping;
  const session = new s.Session(["viewer", "local"], false);
  const xrLight = new XREstimatedLight(renderer, true);
  const scene = new THREE.Scene();
  scene.add(xrLight);
  xrLight.addEventListener("estimationstart", () => { scene.environment = xrLight.environment; });
  renderer.xr.getSession = () => session;
  renderer.xr.dispatchEvent({ type: "sessionstart" });
  """ + SPHERE_VIEW + """
  window.x = { renderer, session, xrLight, scene, reflections: 0, probe: null,
    ...sphereView(THREE, renderer, scene, size || 160, 192) };
  return true;
}"""

#: Run the device's frames until three has an estimate and its environment holds our cube.
RUN = """() => { const x = window.x; x.session.frame();
  const tex = x.xrLight.environment && x.renderer.properties.get(x.xrLight.environment).__webglTexture;
  return x.xrLight.environment !== null && window.polyfill.cube !== null && tex instanceof WebGLTexture
    && window.polyfill.cubeFormat !== null; }"""


def _sides(img):
    S = img.shape[0]
    c, r = S // 2, int(0.42 * S)
    return {"right": img[c, c + r, :3], "top": img[c - r, c, :3], "left": img[c, c - r, :3],
            "bottom": img[c + r, c, :3]}


def test_xr_estimated_light_shows_the_providers_cube(browser, tmp_path):
    pano = tmp_path / "caps.hdr"
    write_caps(pano)
    host = PageHost(APP_PAGE.replace("VERSION", three_version()))
    try:
        with ServeProcess("--source", str(pano), "--environment", "--keepalive", "60",
                          "--allow-origin", host.origin) as proc:
            served_cube(proc.http)
            with page_of(browser, f"{host.origin}/?provider={proc.http}") as page:
                page.wait_for_function("window.ready === true", timeout=20000)
                page.evaluate(STAND_INS)
                page.evaluate(SETUP, [proc.http, 0])
                page.wait_for_function(RUN, timeout=30000, polling=100)
                got = page.evaluate("""() => ({ format: window.polyfill.cubeFormat,
                  seq: window.polyfill.cube.seq, size: window.polyfill.cube.size,
                  same: (() => { const b = new window.XRWebGLBinding(window.x.session, window.x.renderer.getContext());
                    return b instanceof window.standIn.Binding; })() })""")
                assert got["format"] == "rgba16f" and got["size"] == 32 and got["same"]
                # three re-filters it into its PMREM at the next render (needsPMREMUpdate).
                img = json_rows(page.evaluate("window.x.render()"))
                side = _sides(img)
                right, top = side["right"], side["top"]
                assert right[0] > 1 and right[1:].max() < 0.05 * right[0], side
                assert top[1] > 1 and top[[0, 2]].max() < 0.05 * top[1], side
                assert side["left"].max() < 0.05 * right[0] and side["bottom"].max() < 0.05 * right[0], side
                # HDR: the caps' radiance (4) arrives, not clipped to 1 as srgba8 would
                assert right[0] > 2.5 and top[1] > 2.5, side

                # A new cube: 'reflectionchange' fires, and three shows the new room.
                seq = page.evaluate("window.polyfill.cube.seq")
                page.evaluate("""() => { window.told = 0;
                  window.x.session.requestLightProbe().then((probe) => {
                    probe.addEventListener('reflectionchange', () => { window.told++; }); }); }""")
                page.wait_for_function("window.told >= 1", timeout=20000)     # the cube already there
                img = cv2.imread(str(pano), cv2.IMREAD_UNCHANGED)
                cv2.imwrite(str(tmp_path / "next-caps.hdr"), img[:, ::-1])   # mirrored: +X ↔ −X
                (tmp_path / "next-caps.hdr").replace(pano)
                page.wait_for_function(f"window.polyfill.cube.seq > {seq} && window.told >= 2",
                                       timeout=30000)
                page.wait_for_function(RUN, timeout=30000, polling=100)
                side = _sides(json_rows(page.evaluate("window.x.render()")))
                assert side["left"][0] > 1 and side["right"].max() < 0.05 * side["left"][0], side

                # yaw 90 (the provider's +X → the world's −Z): turned like the SH, red leaves
                # both sides; −X (now red) → +Z: the centre of the mirror reflects +Z.
                page.evaluate("window.polyfill.setYaw(90)")
                page.wait_for_function(RUN, timeout=30000, polling=100)
                img = json_rows(page.evaluate("window.x.render()"))
                side = _sides(img)
                c = img.shape[0] // 2
                centre = img[c - 2:c + 3, c - 2:c + 3, :3].mean(axis=(0, 1))
                assert centre[0] > 1 and side["left"][0] < 0.05 * centre[0] \
                    and side["right"][0] < 0.05 * centre[0], (centre, side)
                assert side["top"][1] > 1                                # +Y stays up
    finally:
        host.close()


#: three re-filters the polyfill's cube (level 0 only) into its own PMREM with its own blur
#: schedule: what its shader reads for a sphere of roughness ρ (getIBLRadiance) against the
#: provider's prefiltered radiance PF(ρ) toward three's direction, on bridge, |three − PF| /
#: |PF| (floor 5 % of the largest, tests/clients/three/test_three_environment.py's measure). Measured
#: (median, 95th percentile) on 160² spheres: ρ 0.35: 0.032, 0.212; 0.75: 0.020, 0.105; on
#: 200²: 0.2: 0.008, 0.176; 0.5: 0.012, 0.052; 1: 0.084, 0.454 (three's roughest mip is wider).
XR_TOL = {0.35: (0.05, 0.26), 0.75: (0.03, 0.13)}


def test_xr_estimated_light_spheres_read_the_providers_radiance(browser):
    """A real panorama (bridge) through the polyfill into three's XREstimatedLight(renderer,
    true): at every pixel of a glossy (0.35) and a rough (0.75) sphere, what three's own shader
    reads from xrLight.environment equals the provider's prefiltered radiance PF at three's
    roughness toward three's direction (XR_TOL). SHLIGHT_DOCS_SCREENSHOT=1:
    docs/xr_polyfill_environment_bridge.png, three's mirror, glossy and rough spheres above
    the reference PF(R, ρ) (tests/consumer_pictures.py)."""
    pano = ROOT / "tests" / "data" / "hdri" / "bridge.exr"
    host = PageHost(APP_PAGE.replace("VERSION", three_version()))
    try:
        with ServeProcess("--source", str(pano), "--environment", "--keepalive", "60",
                          "--allow-origin", host.origin) as proc:
            mips, _ = served_cube(proc.http)
            with page_of(browser, f"{host.origin}/?provider={proc.http}") as page:
                page.wait_for_function("window.ready === true", timeout=20000)
                page.evaluate(STAND_INS)
                page.evaluate(SETUP, [proc.http, 0, cp.SIZE])
                page.wait_for_function(RUN, timeout=30000, polling=100)
                normals = json_rows(page.evaluate("window.x.render('normal', 0)"))
                inside = (normals[..., 3] > 0) & (np.linalg.norm(normals[..., :2], axis=-1) < 0.85)
                n = normals[inside][:, :3]
                n /= np.linalg.norm(n, axis=1, keepdims=True)
                for roughness, (median_tol, p95_tol) in XR_TOL.items():
                    shown = json_rows(page.evaluate(f"window.x.render('radiance', {roughness})"))
                    rough = shown[inside][:, 3]
                    assert abs(np.median(rough) - roughness) < 0.03
                    d = reflected_directions(n, rough)
                    rel = relative_error(shown[inside][:, :3], sample(mips, d, rough * (len(mips) - 1)))
                    print(f"roughness {roughness}: three (XREstimatedLight) vs PF median "
                          f"{np.median(rel):.4f} p95 {np.quantile(rel, 0.95):.4f}")
                    assert np.median(rel) < median_tol and np.quantile(rel, 0.95) < p95_tol, \
                        (roughness, np.median(rel), np.quantile(rel, 0.95))
                if cp.wanted():
                    top, bottom = [], []
                    for r in cp.ROUGHNESS:
                        img = json_rows(page.evaluate(f"window.x.render('shaded', {r})"))
                        top.append(cp.srgb_tile(img[..., :3], img[..., 3] > 0))
                        bottom.append(cp.srgb_tile(*cp.provider_reference(read_image(pano), r)))
                    cp.write("xr_polyfill_environment_bridge", cp.compose([
                        ("three.js r187 XREstimatedLight via the polyfill (Chromium)", top),
                        ("the reference: PF(R, roughness)", bottom)]))
    finally:
        host.close()
