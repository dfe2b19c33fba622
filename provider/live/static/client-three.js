// shlight → three.js: drive a THREE.LightProbe with live SH9 lighting. Served at
// /client-three.js; it does not import three itself (pass your LightProbe in), so it
// works with any copy of three.js (r155 or newer: physically based lighting).
//
//   import * as THREE from "three";
//   import { connectLightProbe } from "http://HOST:8765/client-three.js";
//   const probe = new THREE.LightProbe();
//   scene.add(probe);
//   const conn = connectLightProbe("ws://HOST:8765/", probe, { probe: "room" });
//
// Convention (three.js r187, checked with a light from one side only in
// tests/test_js_client.py): SphericalHarmonics3 holds *raw radiance* SH in our order
// (src/math/SphericalHarmonics3.js:84-107 getAt evaluates radiance with the bare basis
// constants 0.282095, 0.488603 y/z/x, 1.092548 xy/yz/xz, 0.315392 (3z²−1),
// 0.546274 (x²−y²): the same basis and order as docs/contract.md §1), and getIrradianceAt
// (src/math/SphericalHarmonics3.js:119-142) folds in the cosine-lobe factors π, 2π/3, π/4:
// it returns our irradiance E(n). The shader does the same
// (src/renderers/shaders/ShaderChunk/lights_pars_begin.glsl.js:13 shGetIrradianceAt,
// summed per LightProbe × intensity in src/renderers/webgl/WebGLLights.js:283) and shades
// irradiance × BRDF_Lambert = diffuseColor / π (ShaderChunk/common.glsl.js:103,
// lights_lambert_pars_fragment.glsl.js:22): ρE/π, our convention. Both frames are
// right-handed +Y up. So our 27 coefficients go into the LightProbe as they are, with
// intensity 1.
import { connect, rotateCoefficients } from "./client.js";

/**
 * Set a THREE.LightProbe (anything with .sh.coefficients[9] of Vector3/Color-like .set)
 * from a Lighting, an "sh9" message, or 27 numbers. `rotation` (9 numbers, row-major):
 * the provider's frame → your world (e.g. the yaw between the room and a WebXR reference
 * space); `intensity` scales the light (default 1: physically as measured).
 */
export function setLightProbe(lightProbe, lighting, { rotation = null, intensity = 1 } = {}) {
  let c = lighting && lighting.coefficients !== undefined ? lighting.coefficients : lighting;
  if (!c || c.length !== 27) throw new Error("setLightProbe: expected 27 coefficients");
  if (rotation) c = rotateCoefficients(c, rotation);
  const sh = lightProbe.sh.coefficients;
  for (let k = 0; k < 9; k++) sh[k].set(c[3 * k], c[3 * k + 1], c[3 * k + 2]);
  lightProbe.intensity = intensity;
  return lightProbe;
}

/**
 * connect() (see client.js) and keep `lightProbe` set to the newest lighting. Options as
 * connect()'s, plus `rotation` and `intensity` (read at every message, so they may be
 * changed on the returned connection's `.options`).
 */
export function connectLightProbe(url, lightProbe, options = {}) {
  const settings = { rotation: options.rotation || null, intensity: options.intensity ?? 1 };
  const conn = connect(url, {
    ...options,
    onLighting: (lighting, c) => {
      setLightProbe(lightProbe, lighting, settings);
      if (options.onLighting) options.onLighting(lighting, c);
    },
  });
  conn.options = settings;
  conn.lightProbe = lightProbe;
  return conn;
}
