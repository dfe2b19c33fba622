"""The glTF export's reflection cube (EXT_lights_image_based, provider/core/reflections/gltf_ibl.py) loaded by
the real Babylon.js (9.28, babylonjs + babylonjs-loaders from tests/node/node_modules) in headless
Chromium: its glTF loader builds the scene's environmentTexture from the PNGs, and PBRMaterial
spheres (metallic 1, white) seen from glTF +Z by an orthographic camera read it with Babylon's
own shaders. Read back: the PBR shader's environment reading (debugMode 41,
``reflectionOut.environmentRadiance``, gamma-encoded by the debug path and decoded here) into a
float render target.

Two facts of Babylon 9.28 the checks pin down (README "Reflections"):
* the loader's RawCubeTexture keeps ``gammaSpace = true``, so the PBR shader applies
  toLinearSpace (x^2.2) to the already linear decoded radiance: a user must set
  ``scene.environmentTexture.gammaSpace = false`` after loading (checked both ways);
* its reflection block mixes the cube's radiance with the SH irradiance by α = ρ² + 5e-4
  (``MIX_IBL_RADIANCE_WITH_IRRADIANCE``): reading = mix(cube(lod), E_sh(N)/π, α), the LOD
  log2(size·α)·(mips − 1)/log2(size) (tests/consumers.py babylon_lod), levels beyond those given
  black.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import consumer_pictures as cp
import consumers as cs
from browsertools import NEEDS_BROWSER, ROOT, browser, page_of  # noqa: F401
from envtools import write_caps
from provider.core.conventions import formats as cv
from provider.core.reflections import gltf_ibl
from provider.core.sh9.engine import compute_sh9
from provider.core.reflections.environment import EnvironmentProjector
from provider.core.radiometry.images import read_image
from provider.verify.cubemap import CubeSampler

BABYLON = ROOT / "tests" / "node" / "node_modules" / "babylonjs" / "babylon.js"
LOADERS = ROOT / "tests" / "node" / "node_modules" / "babylonjs-loaders" / "babylonjs.loaders.js"
pytestmark = NEEDS_BROWSER + [pytest.mark.skipif(
    not (BABYLON.exists() and LOADERS.exists()),
    reason="Babylon.js not installed: npm ci --prefix tests/node")]
SIZE = 32

#: Babylon's scene: the glTF asset (EXT_lights_image_based only) appended to a default
#: (left-handed) scene, a camera at (0, 0, 5) looking at the origin (the asset's +Z side: glTF
#: +X on the right, the loader's root node mirrors x), a unit PBRMaterial sphere, metal, white,
#: debugMode 41. render(ρ, kind) → the float render target's RGBA, row 0 at the bottom; kind
#: "normal": the interpolated world normal instead (debugMode 2).
SETUP = """async ([doc, S]) => {
  const canvas = document.createElement("canvas"); canvas.width = S; canvas.height = S;
  document.body.appendChild(canvas);
  const engine = new BABYLON.Engine(canvas, false, { preserveDrawingBuffer: true }, false);
  const scene = new BABYLON.Scene(engine);
  await BABYLON.SceneLoader.AppendAsync("", "data:" + JSON.stringify(doc), scene, null, ".gltf");
  await scene.whenReadyAsync();
  const camera = new BABYLON.FreeCamera("camera", new BABYLON.Vector3(0, 0, 5), scene);
  camera.setTarget(BABYLON.Vector3.Zero());
  camera.mode = BABYLON.Camera.ORTHOGRAPHIC_CAMERA;
  camera.orthoLeft = -1.05; camera.orthoRight = 1.05; camera.orthoTop = 1.05; camera.orthoBottom = -1.05;
  camera.minZ = 0.1; camera.maxZ = 10;
  const sphere = BABYLON.MeshBuilder.CreateSphere("sphere", { diameter: 2, segments: 128 }, scene);
  const material = new BABYLON.PBRMaterial("metal", scene);
  material.metallic = 1; material.roughness = 0; material.albedoColor = new BABYLON.Color3(1, 1, 1);
  material.debugMode = 41;
  const normals = new BABYLON.PBRMaterial("normals", scene);
  normals.metallic = 1; normals.roughness = 0; normals.debugMode = 2;      // normalize(vNormalW)·½ + ½
  sphere.material = material;
  const rt = new BABYLON.RenderTargetTexture("rt", S, scene, false, true, BABYLON.Constants.TEXTURETYPE_FLOAT);
  rt.renderList = [sphere]; rt.activeCamera = camera; rt.clearColor = new BABYLON.Color4(0, 0, 0, 0);
  async function render(roughness, kind) {
    material.roughness = roughness;
    sphere.material = kind === "normal" ? normals : material;
    await sphere.material.forceCompilationAsync(sphere);
    rt.render();
    return Array.from(await rt.readPixels());
  }
  const env = scene.environmentTexture;
  window.b = { engine, scene, env, camera, sphere, material, rt, render };
  return { size: env.getSize().width, lodGenerationScale: env.lodGenerationScale, gammaSpace: env.gammaSpace };
}"""


def _export(panorama, handedness="left"):
    """What ``shlight export --to gltf`` makes of a panorama: its SH9 and its cube prefiltered
    at Babylon's roughness."""
    env = EnvironmentProjector(panorama.shape[1], panorama.shape[0], size=SIZE,
                               mip_roughness=gltf_ibl.babylon_roughness(SIZE)).project(panorama)
    sh9 = compute_sh9(panorama, error_estimate=False).coefficients
    return cv.export(sh9, "gltf", babylon_handedness=handedness, environment=env.mips)


def _babylon(browser, ex, rough_list, gamma_space=False):
    """[(linear reading (S, S, 3), mask)] per roughness, Babylon's unit normals (S, S, 3) in
    the glTF frame (ours), and what the loader made."""
    def read(page, r, kind="radiance"):
        px = np.asarray(page.evaluate("([r, k]) => window.b.render(r, k)", [r, kind]), np.float64)
        return px.reshape(cp.SIZE, cp.SIZE, 4)[::-1]

    with page_of(browser, "about:blank") as page:
        page.add_script_tag(path=str(BABYLON))
        page.add_script_tag(path=str(LOADERS))
        made = page.evaluate(SETUP, [ex["document"], cp.SIZE])
        if not gamma_space:
            page.evaluate("() => { window.b.env.gammaSpace = false; }")
        out = []
        for r in rough_list:
            px = read(page, r)
            # the debug path writes toGammaSpace(x) = x^(1/2.2) unless the texture is gammaSpace
            out.append((np.maximum(px[..., :3], 0) ** (1.0 if gamma_space else 2.2), px[..., 3] > 0))
        normals = read(page, 0.0, "normal")[..., :3] * 2 - 1
    normals = normals * np.array([-1.0, 1.0, 1.0])          # Babylon's world → the asset's frame
    normals /= np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-9)
    return out, normals, made


def _babylon_formula(ex, roughness, normals):
    """Babylon's reading as its shader computes it, on the exported images (tests/consumers.py
    re-implementation, bilinear and seamless here) at unit ``normals`` (…, 3, the asset's frame,
    the unit sphere's points too): mix(cube(lookup(R), lod), E_sh(N)/π, α), R = reflect(−V, N)
    with V toward the camera's position (0, 0, 5) (Babylon's vEyePosition, orthographic or not)."""
    light = ex["light"]
    cube = cs.babylon_gltf_cube(light, ex["images"])
    levels = cube + [np.zeros((6, (SIZE >> k), (SIZE >> k), 3)) for k in range(len(cube), 6)]
    lod = float(np.clip(cs.babylon_lod(roughness, SIZE, len(cube)), 0, len(levels) - 1))
    v = np.array([0, 0, 5.0]) - normals
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    r = 2 * np.sum(normals * v, axis=-1, keepdims=True) * normals - v
    radiance = CubeSampler(levels).sample(cs.babylon_lookup(r), lod)[0]
    alpha = roughness ** 2 + 0.0005
    return (1 - alpha) * radiance + alpha * cs.babylon_gltf(light, normals)


def test_babylon_shows_the_caps_where_its_camera_sees_the_asset(browser, tmp_path):
    """One-sided scene (red around +X, green +Y, blue −Z): a mirror sphere in Babylon, seen from
    the asset's +Z, shows red on its right, green on top, nothing left, below or at the centre
    (which reflects +Z); Babylon's loader says size 32, lodGenerationScale (mips − 1)/log2(32)."""
    pano = tmp_path / "caps.hdr"
    write_caps(pano)
    ex = _export(read_image(pano))
    [(img, mask)], _, made = _babylon(browser, ex, [0.0])
    assert made["size"] == SIZE and made["lodGenerationScale"] == pytest.approx(4 / math.log2(SIZE))
    assert made["gammaSpace"] is True              # Babylon 9.28's default: see the module docstring
    S = img.shape[0]
    c, r = S // 2, int(0.35 * S)            # 0.74 of the radius: reflections 84° off the view
    right, top, left, bottom = img[c, c + r], img[c - r, c], img[c, c - r], img[c + r, c]
    assert right[0] > 1 and right[1:].max() < 0.05 * right[0], right
    assert top[1] > 1 and top[[0, 2]].max() < 0.05 * top[1], top
    assert left.max() < 0.05 * right[0] and bottom.max() < 0.05 * right[0], (left, bottom)
    assert img[c - 2:c + 3, c - 2:c + 3].mean(axis=(0, 1)).max() < 0.01 * right[0]


#: Babylon's reading against its formula on the exported images (_babylon_formula), bridge,
#: |Babylon − formula| / |formula| (floor 5 % of the largest), over the sphere but its silhouette.
#: Measured (median, 95th percentile): ρ 0: 0.00002, 0.0001; 0.35: 0.0001, 0.0002; 0.75: 0.0001,
#: 0.0002 (half floats). A lod off by 0.1, a mirrored face or V = +Z instead of toward the
#: camera's position is ≥ 0.02 (V = +Z: 0.011, 0.81 on the mirror).
BABYLON_TOL = {0.0: (0.001, 0.003), 0.35: (0.001, 0.003), 0.75: (0.001, 0.003)}


def test_babylon_reads_the_exported_cube_at_its_lod_and_the_picture(browser, hdri):
    """A real panorama (bridge) exported as glTF and loaded by Babylon: at every pixel of a mirror,
    a glossy (0.35) and a rough (0.75) sphere, Babylon's own environment reading equals its
    formula on the exported images (BABYLON_TOL); with Babylon's default gammaSpace it is that
    reading to the power 2.2 (too dark: the README's ``gammaSpace = false``).
    SHLIGHT_DOCS_SCREENSHOT=1: docs/babylon_environment_bridge.png, Babylon's spheres above the
    reference PF(R, ρ) (tests/consumer_pictures.py)."""
    panorama = hdri("bridge")
    ex = _export(panorama)
    shown, normals, _ = _babylon(browser, ex, cp.ROUGHNESS)
    for rho, (img, mask) in zip(cp.ROUGHNESS, shown):
        inside = mask & (np.linalg.norm(normals[..., :2], axis=-1) < 0.85)   # not the silhouette
        want = np.zeros_like(img)
        want[inside] = _babylon_formula(ex, rho, normals[inside])
        rel = cp.relative_error(img, want, inside)
        print(f"\nBabylon roughness {rho}: vs its formula on the glTF's images median "
              f"{np.median(rel):.4f} p95 {np.quantile(rel, 0.95):.4f}")
        median_tol, p95_tol = BABYLON_TOL[rho]
        assert np.median(rel) < median_tol and np.quantile(rel, 0.95) < p95_tol, rho
    [(dark, mask)], _, _ = _babylon(browser, ex, [0.0], gamma_space=True)
    ratio = np.median(dark[mask] / np.maximum(shown[0][0][mask], 1e-6) ** 2.2)
    print(f"default gammaSpace: reading / (linear reading)^2.2, median {ratio:.4f}")
    assert abs(ratio - 1) < 0.05                  # measured 1.012 (half floats, pow)
    if cp.wanted():
        top = [cp.srgb_tile(img, mask) for img, mask in shown]
        bottom = [cp.srgb_tile(*cp.provider_reference(panorama, r)) for r in cp.ROUGHNESS]
        cp.write("babylon_environment_bridge", cp.compose([
            ("Babylon.js 9.28 glTF loader + PBRMaterial (Chromium)", top),
            ("the reference: PF(R, roughness)", bottom)]))
