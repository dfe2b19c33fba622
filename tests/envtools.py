"""Helpers for the reflection-cube browser tests (tests/clients/three/test_three_environment.py,
tests/clients/three/test_xr_polyfill_environment.py): one-sided panoramas, the provider's KTX2 read back in
Python (docs/contract.md §12, "Transport"), and a page that renders three.js r187 spheres lit
by client-three.js's connectEnvironment."""
from __future__ import annotations

import json
import os
import struct
from pathlib import Path

import cv2
import numpy as np

from servertools import http_get, poll

#: The caps of the one-sided scene: radiance (r, g, b) within 45° of +X, +Y and −Z only.
CAPS = {"+X": ((1, 0, 0), (4.0, 0.0, 0.0)), "+Y": ((0, 1, 0), (0.0, 4.0, 0.0)),
        "-Z": ((0, 0, -1), (0.0, 0.0, 4.0))}


def equirect_directions(h: int, w: int) -> np.ndarray:
    """(h, w, 3) unit directions of equirect pixel centres (docs/contract.md §1: u = 0.5 looks
    along −Z, u = 0.75 along +X, v = 0 up)."""
    v, u = np.mgrid[0:h, 0:w] + 0.5
    phi = (u / w - 0.5) * 2 * np.pi
    theta = v / h * np.pi
    return np.stack([np.sin(theta) * np.sin(phi), np.cos(theta),
                     -np.sin(theta) * np.cos(phi)], axis=-1)


def write_caps(path: Path, h: int = 256) -> None:
    """A float panorama, black but for a red cap around +X, a green one around +Y and a blue
    one around −Z (each within 45° of its axis)."""
    d = equirect_directions(h, 2 * h)
    img = np.zeros((h, 2 * h, 3), np.float32)
    for axis, rgb in CAPS.values():
        img[d @ np.asarray(axis, float) > np.cos(np.radians(45))] = rgb
    tmp = path.with_name("next-" + path.name)
    assert cv2.imwrite(str(tmp), img[..., ::-1])                   # BGR on disk
    os.replace(tmp, path)


def read_ktx2_cube(data: bytes) -> list[np.ndarray]:
    """The mips (6, n, n, 3) float32 of the provider's KTX2 file, read by the specification's
    header and level index (independent of provider/live/reflections/ktx2.py's writer)."""
    assert data[:12] == bytes([0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A])
    vk, type_size, w, h, depth, layers, faces, levels, sc = struct.unpack_from("<9I", data, 12)
    assert (vk, type_size, faces, sc) == (97, 2, 6, 0) and w == h
    mips = []
    for k in range(levels):
        offset, length, _ = struct.unpack_from("<3Q", data, 80 + 24 * k)
        n = w >> k
        a = np.frombuffer(data, np.float16, 6 * n * n * 4, offset).reshape(6, n, n, 4)
        mips.append(a[..., :3].astype(np.float32))
    return mips


def served_cube(base: str, probe: str = "default") -> tuple[list[np.ndarray], int]:
    """(mips, seq) of the probe's newest cube at /environment.ktx2 (waiting for the first)."""
    status, headers, body = poll(lambda: (r := http_get(f"{base}/environment.ktx2?probe={probe}"))[0] == 200 and r,
                                 what="the first cube", timeout=60)
    return read_ktx2_cube(body), int(headers["X-Shlight-Seq"])


THREE_URL = "https://cdn.jsdelivr.net/npm/three@{version}/build/three.module.js"

#: A JS function, pasted into a page's setup: sphereView(THREE, renderer, scene, S, segments)
#: adds to ``scene`` a white metal sphere (MeshStandardMaterial) of radius 1, seen from +Z by
#: an orthographic camera that frames it in S×S pixels (+X right, +Y up), and returns
#: { camera, material, sphere, target, render, show }. render(kind = "shaded", roughness = 0)
#: → RGBA floats of a float render target, rows from the top: kind "radiance" is three's own
#: environment reading (lights_fragment_maps's getIBLRadiance, the prefiltered radiance its
#: BRDF gets) with material.roughness in alpha; "normal" the geometry normal; "shaded" the
#: material as it renders. show(kind, roughness) draws into the canvas (sRGB, for pictures).
SPHERE_VIEW = """function sphereView(THREE, renderer, scene, S, segments) {
  const camera = new THREE.OrthographicCamera(-1.05, 1.05, 1.05, -1.05, 0.1, 10);
  camera.position.set(0, 0, 5);
  const material = new THREE.MeshStandardMaterial({ color: 0xffffff, metalness: 1, roughness: 0 });
  const sphere = new THREE.Mesh(new THREE.SphereGeometry(1, segments, segments / 2), material);
  scene.add(sphere);
  const target = new THREE.WebGLRenderTarget(S, S, { type: THREE.FloatType });
  let kind = "shaded";
  material.onBeforeCompile = (shader) => {
    if (kind === "radiance") shader.fragmentShader = shader.fragmentShader.replace(
      "#include <opaque_fragment>", "gl_FragColor = vec4( radiance, material.roughness );");
    if (kind === "normal") shader.fragmentShader = shader.fragmentShader.replace(
      "#include <opaque_fragment>", "gl_FragColor = vec4( geometryNormal, 1.0 );");
  };
  material.customProgramCacheKey = () => kind;
  function use(k, roughness) {
    if (k !== kind || roughness !== material.roughness) {
      kind = k; material.roughness = roughness; material.needsUpdate = true; }
  }
  function render(k = "shaded", roughness = 0) {
    use(k, roughness);
    renderer.setRenderTarget(target);
    renderer.setClearColor(0x000000, 0); renderer.clear();
    renderer.render(scene, camera);
    const px = new Float32Array(S * S * 4);
    renderer.readRenderTargetPixels(target, 0, 0, S, S, px);
    renderer.setRenderTarget(null);
    const rows = [];
    for (let i = S - 1; i >= 0; i--) rows.push(Array.from(px.subarray(i * S * 4, (i + 1) * S * 4)));
    return rows;
  }
  function show(k = "shaded", roughness = 0) {
    use(k, roughness);
    renderer.setRenderTarget(null);
    renderer.render(scene, camera);
    return renderer.domElement.toDataURL("image/png");
  }
  return { camera, material, sphere, target, render, show };
}
"""

#: Sets up window.t: three.js, a WebGLRenderer and a :data:`SPHERE_VIEW` sphere under
#: client-three.js's connectEnvironment (window.t.conn; window.cubes counts its cubes).
SETUP = """async ([threeUrl, provider, extra]) => {
  const THREE = await import(threeUrl);
  const a = await import(provider + "/client-three.js");
  const c = await import(provider + "/client.js");
  const S = 200;
  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true, alpha: true });
  renderer.setSize(S, S, false);
  renderer.toneMapping = THREE.NoToneMapping;
  document.body.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  """ + SPHERE_VIEW + """
  const view = sphereView(THREE, renderer, scene, S, 256);
  window.cubes = 0;
  const conn = a.connectEnvironment(provider + "/", { THREE, scene, ...(extra || {}),
    onEnvironment: () => { window.cubes++; } });
  window.t = { THREE, a, c, renderer, scene, ...view, conn, S };
  return true;
}"""


def png_of(data_url: str) -> np.ndarray:
    """RGBA uint8 of a canvas's data URL."""
    import base64
    png = base64.b64decode(data_url.split(",", 1)[1])
    bgra = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
    return cv2.cvtColor(bgra, cv2.COLOR_BGRA2RGBA)


def json_rows(rows) -> np.ndarray:
    """(S, S, 4) float array of render()'s rows."""
    a = np.asarray(rows, np.float64)
    return a.reshape(a.shape[0], -1, 4)


__all__ = ["CAPS", "SETUP", "THREE_URL", "equirect_directions", "json_rows", "png_of",
           "read_ktx2_cube", "reflected_directions", "relative_error", "served_cube", "write_caps", "json"]


def reflected_directions(normal, rough):
    """Where three looks: normalize(mix(R, N, r⁴)), R = reflect(−V, N), V = +Z (orthographic)."""
    V = np.array([0, 0, 1.0])
    R = 2 * (normal @ V)[:, None] * normal - V
    d = R + (normal - R) * (rough ** 4)[:, None]
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def relative_error(shown, ref):
    """Per-pixel error of ``shown`` against ``ref``, relative to the larger of the pixel's
    value and 5 % of the brightest (a dark pixel is not judged by its own tiny value)."""
    err = np.abs(shown - ref).max(axis=1)
    return err / np.maximum(np.abs(ref).max(axis=1), 0.05 * np.abs(ref).max())
