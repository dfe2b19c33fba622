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
//
// Reflections (docs/contract.md §12): connectEnvironment() keeps `scene.environment` (and,
// optionally, `scene.background`) set to the provider's live cube. What three r187 wants
// there, read at its source (tests/node/node_modules/three):
//   * MeshStandardMaterial/MeshPhysicalMaterial (and Lambert/Phong without an envMap) always
//     read scene.environment as a PMREM (WebGLRenderer.js:2232, 2405-2407 usePMREM);
//     WebGLEnvironments.js:71-140 turns a plain cube texture into one with its own
//     PMREMGenerator once per texture object (re-filtered only for render targets whose
//     pmremVersion changed, :88), and takes a texture with isPMREMTexture = true as it is (:73).
//   * A PMREM is a cube whose mip l (of L = levels − 1) holds GGX-prefiltered radiance
//     (α = roughness², n = v = r) at roughness 1 − √(1 − l/L) (PMREMGenerator.js:229-240
//     lodToRoughness), read at lod L·r·(2 − r) (envmap_common_pars_fragment.glsl.js:12-16
//     roughnessToMip) toward normalize(mix(R, N, r⁴)) (envmap_physical_pars_fragment.glsl.js:
//     24-33); diffuse light is π × its last mip (:6-10); L = envMapMipmaps.length − 1, where
//     a CompressedCubeTexture's mips are image[0].mipmaps (WebGLPrograms.js:191, 225).
//   * A cube texture that is not a render target is read mirrored in x: the material's
//     envMapRotation is premultiplied by diag(−1, 1, 1) (WebGLMaterials.js:7-9, 245-250), after
//     Rᵀ of scene.environmentRotation.
// The provider's cube already is such a prefiltered chain (same GGX, α = roughness²), at
// roughness k/(K − 1) per mip. So environmentTexture() hands three a PMREM of the provider's
// own mips (no re-filtering in the browser, none of three's GGX passes): three's mip l
// (face P >> l, P = max(N, 128), down to 8×8 as three's own) is the provider's chain sampled as
// textureLod does at lod (K − 1)·(1 − √(1 − l/L)) toward each texel's direction mirrored in x
// (undoing the read above), uploaded as RGBA16F. scene.environmentRotation
// holds the rotation (provider frame → your world), so turning it costs nothing.
// Diffuse: with scene.environment three also lights every MeshStandard/Lambert/Phong surface
// by π × the roughest mip, which for the provider's cube (roughness 1: α = 1, a constant
// GGX D) is E(n) itself; a LightProbe with the SH9 would count it twice, so
// connectEnvironment hides the LightProbe it is given while a cube lights the scene
// (diffuse: "environment", the default) or keeps it (diffuse: "both").
import { bilinear, connect, faceDirection, registrationRotation, rotateCoefficients } from "./client.js";

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
/**
 * The exposure a physical camera sets for this lighting, as three's
 * `renderer.toneMappingExposure`: 1 / (1.2 · 2^EV100) (the saturation-based conversion
 * Filament and Unity HDRP use; docs/photometry.md), or null when the provider's lighting is
 * not in absolute units (no `ev100`: "coefficient_units": "relative"). With it, a LightProbe
 * at intensity 1 holding cd/m² renders the room's luminance at the room's exposure.
 */
export function physicalExposure(lighting) {
  const m = lighting ? (lighting.message || lighting) : {};
  return typeof m.ev100 === "number" && isFinite(m.ev100) ? 1 / (1.2 * Math.pow(2, m.ev100)) : null;
}

/** `options.renderer` given: its toneMappingExposure follows the room's EV100 (issue 31). */
function followExposure(options, lighting) {
  const e = options.renderer ? physicalExposure(lighting) : null;
  if (e !== null) options.renderer.toneMappingExposure = e;
}

export function connectLightProbe(url, lightProbe, options = {}) {
  const settings = { rotation: options.rotation || null, intensity: options.intensity ?? 1 };
  const conn = connect(url, {
    ...options,
    onLighting: (lighting, c) => {
      setLightProbe(lightProbe, lighting, settings);
      followExposure(options, lighting);
      if (options.onLighting) options.onLighting(lighting, c);
    },
  });
  conn.options = settings;
  conn.lightProbe = lightProbe;
  return conn;
}

// ---- reflections: the provider's cube as three's PMREM -----------------------------------

/** Log2 of three's smallest PMREM face (PMREMGenerator.js LOD_MIN = 3: 8×8). */
const PMREM_LOD_MIN = 3;

/**
 * Three's PMREM layout for a provider cube of `size` and `mipCount` mips: face size P =
 * max(size, 128) (so that every mip of three's, at its roughness, is at least as fine as the
 * provider's mips it reads), mips P … 8 (L = log2 P − 3), mip l at roughness 1 − √(1 − l/L)
 * (lodToRoughness), read from the provider's chain at lod (mipCount − 1)·roughness.
 * Returns [{ size, roughness, lod }] per mip.
 */
export function pmremSchedule(size, mipCount) {
  const P = Math.max(size, 128), L = Math.log2(P) - PMREM_LOD_MIN;
  return Array.from({ length: L + 1 }, (_, l) => {
    const roughness = L > 0 ? 1 - Math.sqrt(1 - l / L) : 0;
    return { size: P >> l, roughness, lod: roughness * (mipCount - 1) };
  });
}

/**
 * The six faces (Float32Array RGBA) of each of three's PMREM mips, from an EnvironmentCube
 * (client.js parseEnvironmentKtx2): [mip][face]. Each texel is the provider's chain sampled
 * as textureLod does (seamless bilinear, linear between mips) at its lod, toward the
 * direction three reads that texel for: its own direction mirrored in x (module comment).
 */
export function pmremFaces(cube) {
  const floats = cube.mips.map((_, k) => cube.floatFaces(k));
  const last = cube.mipCount - 1, acc = [0, 0, 0, 0];
  return pmremSchedule(cube.size, cube.mipCount).map(({ size: m, lod }) => {
    const k0 = Math.min(Math.floor(lod + 1e-9), last), k1 = Math.min(k0 + 1, last);
    const w = Math.min(Math.max(lod - k0, 0), 1);
    const faces = [];
    for (let f = 0; f < 6; f++) {
      const out = new Float32Array(m * m * 4);
      for (let i = 0; i < m; i++) {
        for (let j = 0; j < m; j++) {
          const e = faceDirection(f, (2 * (j + 0.5)) / m - 1, (2 * (i + 0.5)) / m - 1);
          const d = [-e[0], e[1], e[2]];
          acc.fill(0);
          bilinear(floats[k0], cube.size >> k0, d, 1 - w, acc);
          if (w > 0) bilinear(floats[k1], cube.size >> k1, d, w, acc);
          out.set(acc, 4 * (i * m + j));
        }
      }
      faces.push(out);
    }
    return faces;
  });
}

/**
 * A THREE.CompressedCubeTexture with isPMREMTexture = true holding the provider's cube in
 * three's PMREM layout (RGBA16F, uploaded from float32), for scene.environment. `texture`:
 * one made before for a cube of the same size, refilled in place (else a new one).
 */
export function environmentTexture(THREE, cube, texture = null) {
  const levels = pmremFaces(cube), P = levels[0][0].length ** 0.5 / 2;
  if (texture && texture.image[0].width === P && texture.image[0].mipmaps.length === levels.length) {
    for (let f = 0; f < 6; f++) {
      levels.forEach((faces, l) => { texture.image[f].mipmaps[l].data = faces[f]; });
    }
    texture.needsUpdate = true;
    return texture;
  }
  const images = [0, 1, 2, 3, 4, 5].map((f) => ({
    width: P, height: P,
    mipmaps: levels.map((faces, l) => ({ data: faces[f], width: P >> l, height: P >> l })),
  }));
  const tex = new THREE.CompressedCubeTexture(images, THREE.RGBAFormat, THREE.FloatType);
  tex.internalFormat = "RGBA16F";                    // filterable everywhere WebGL2 is
  tex.minFilter = THREE.LinearMipmapLinearFilter;
  tex.magFilter = THREE.LinearFilter;
  tex.generateMipmaps = false;
  tex.colorSpace = THREE.LinearSRGBColorSpace;
  tex.isPMREMTexture = true;
  tex.name = "shlight environment";
  tex.needsUpdate = true;
  return tex;
}

/** Set a THREE.Euler (scene.environmentRotation) from a row-major 3×3 rotation (null: none). */
function setEuler(THREE, euler, R) {
  if (!R) { euler.set(0, 0, 0); return euler; }
  const m = new THREE.Matrix4().set(R[0], R[1], R[2], 0, R[3], R[4], R[5], 0, R[6], R[7], R[8], 0, 0, 0, 0, 1);
  return euler.setFromRotationMatrix(m);
}

/** Row-major 3×3 rotation about +Y by `degrees` (a direction d appears at R·d). */
export function yawRotation(degrees) {
  const a = (degrees * Math.PI) / 180, c = Math.cos(a), s = Math.sin(a);
  return [c, 0, s, 0, 1, 0, -s, 0, c];
}

/**
 * connect() (client.js) with the reflection cube: keeps `scene.environment` (and with
 * `background: true`, `scene.background`) lit by the provider's live cube, and a LightProbe
 * (optional, `lightProbe`) by its SH9. Options as connect()'s, plus:
 *   THREE       the three.js module (required: this file does not import three itself)
 *   scene       the THREE.Scene to light (required)
 *   lightProbe  a THREE.LightProbe set from the sh9 messages (setLightProbe), or null
 *   diffuse     "environment" (default: the LightProbe is hidden while a cube lights the scene,
 *               three's PMREM gives the diffuse light) or "both"
 *   background  also show the cube as scene.background (default false)
 *   rotation    row-major 3×3, the provider's frame → your world (or `yaw` in degrees)
 *   intensity   scene.environmentIntensity and the LightProbe's intensity (default 1)
 *   renderer    optional: its toneMappingExposure follows the room's EV100 when the provider
 *               is in absolute units (physicalExposure; also an option of connectLightProbe)
 * The returned connection also has: texture (the THREE texture, null before the first cube),
 * rotation, setRotation(R), setYaw(degrees), setMarkerPose(worldFromMarker, {markerAxes})
 * (registration: R_world←camera from the tracker's marker pose and the newest message's
 * `registration`, client.js registrationRotation; false while the provider has none yet).
 */
export function connectEnvironment(url, options = {}) {
  const { THREE, scene } = options;
  if (!THREE || !scene) throw new TypeError("connectEnvironment: options.THREE and options.scene are required");
  const lightProbe = options.lightProbe || null;
  const diffuse = options.diffuse || "environment";
  const settings = { rotation: options.rotation ? Array.from(options.rotation, Number)
    : options.yaw ? yawRotation(+options.yaw) : null, intensity: options.intensity ?? 1 };
  let texture = null;

  function apply() {
    setEuler(THREE, scene.environmentRotation, settings.rotation);
    if (options.background) setEuler(THREE, scene.backgroundRotation, settings.rotation);
    scene.environmentIntensity = settings.intensity;
    if (lightProbe && conn.latest) setLightProbe(lightProbe, conn.latest, settings);
  }

  const conn = connect(url, {
    ...options,
    environment: true,
    onLighting: (lighting, c) => {
      if (lightProbe) setLightProbe(lightProbe, lighting, settings);
      followExposure(options, lighting);
      if (options.onLighting) options.onLighting(lighting, c);
    },
    onEnvironment: (cube, c) => {
      const previous = texture;
      texture = environmentTexture(THREE, cube, previous);
      if (previous && previous !== texture) previous.dispose();
      scene.environment = texture;
      if (options.background) scene.background = texture;
      if (lightProbe && diffuse === "environment") lightProbe.visible = false;
      apply();
      if (options.onEnvironment) options.onEnvironment(cube, c);
    },
  });
  conn.options = settings;
  conn.lightProbe = lightProbe;
  Object.defineProperty(conn, "texture", { get: () => texture });
  Object.defineProperty(conn, "rotation", { get: () => (settings.rotation ? settings.rotation.slice() : null) });
  conn.setRotation = (R) => {
    settings.rotation = R ? Array.from(R, Number) : null;
    apply();
  };
  conn.setYaw = (degrees) => conn.setRotation(+degrees ? yawRotation(+degrees) : null);
  conn.setMarkerPose = (worldFromMarker, { markerAxes = "aruco" } = {}) => {
    const reg = conn.latest && conn.latest.message && conn.latest.message.registration;
    if (!reg) return false;
    conn.setRotation(registrationRotation(worldFromMarker, reg, { markerAxes }));
    return true;
  };
  apply();
  return conn;
}
