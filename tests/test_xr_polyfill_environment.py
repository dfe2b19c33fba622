"""The WebXR polyfill's reflection cube: XRWebGLBinding.getReflectionCubeMap(probe) for a probe
of ours is a WebGL cube texture of the provider's live cube, 'reflectionchange' fires on each
new cube, and three.js r187's own XREstimatedLight(renderer, true) shows the room in
xrLight.environment: a mirror sphere lit by it shows a one-sided scene's caps where three's
camera sees them. Real ``shlight serve --environment``, real headless Chromium and WebGL 2;
the XR device (session, frames, binding) is the stand-in of tests/test_xr_polyfill.py.
"""
from __future__ import annotations

import cv2
import numpy as np

from browsertools import NEEDS_BROWSER, PageHost, browser, page_of, three_version  # noqa: F401
from envtools import json_rows, served_cube, write_caps
from servertools import ServeProcess
from test_xr_polyfill import APP_PAGE, STAND_INS

pytestmark = NEEDS_BROWSER

#: three's XREstimatedLight(renderer, true) on a stand-in session whose browser has no light
#: estimation; the polyfill answers. A mirror sphere (MeshStandardMaterial, metal) under
#: scene.environment = xrLight.environment, seen by an orthographic camera from +Z.
SETUP = """async ([provider, yaw]) => {
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
  const camera = new THREE.OrthographicCamera(-1.05, 1.05, 1.05, -1.05, 0.1, 10);
  camera.position.set(0, 0, 5);
  scene.add(new THREE.Mesh(new THREE.SphereGeometry(1, 192, 96),
    new THREE.MeshStandardMaterial({ color: 0xffffff, metalness: 1, roughness: 0 })));
  const target = new THREE.WebGLRenderTarget(160, 160, { type: THREE.FloatType });
  window.x = { renderer, session, xrLight, scene, camera, target, reflections: 0, probe: null,
    render() {
      renderer.setRenderTarget(target); renderer.render(scene, camera);
      const px = new Float32Array(160 * 160 * 4);
      renderer.readRenderTargetPixels(target, 0, 0, 160, 160, px);
      renderer.setRenderTarget(null);
      const rows = [];
      for (let i = 159; i >= 0; i--) rows.push(Array.from(px.subarray(i * 640, (i + 1) * 640)));
      return rows; } };
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
