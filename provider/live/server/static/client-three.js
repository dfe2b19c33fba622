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
// tests/clients/three/test_js_client.py): SphericalHarmonics3 holds *raw radiance* SH in our order
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
import { bilinear, connect, faceDirection, irradiance, matricesFromCoefficients, registrationRotation,
  rotateCoefficients } from "./client.js";
import { passthroughToneMapping, startCameraSender } from "./passthrough.js";

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

/**
 * connect() (see client.js) and keep `lightProbe` set to the newest lighting. Options as
 * connect()'s, plus `rotation` and `intensity` (read at every message, so they may be
 * changed on the returned connection's `.options`), and, opt-in, `shadows`: an object
 *   THREE         the three.js module (required)
 *   scene         where to add the key light (and its target) and the catcher (optional)
 *   renderer      a WebGLRenderer whose shadowMap gets enabled (PCFShadowMap; optional)
 *   light         a THREE.DirectionalLight to drive (default: a new one, 1024² shadow map,
 *                 shadow camera ±2 world units)
 *   catcher       a shadow catcher (default: shadowCatcher(THREE), at the origin); null: none
 *   up            the catcher's normal in your world (default [0, 1, 0])
 *   casterHeight  world units between the catcher and the edges that cast (default 0.5):
 *                 sets the penumbra (shadowRadiusTexels)
 *   occluder      the hologram (a THREE.Object3D, or a THREE.Sphere): the catcher also
 *                 darkens by the ambient light its bounding sphere hides from the floor
 *                 (occluderSphere; docs/shadows.md); settable later as `.shadows.occluder`
 *   distance      how far from its target the light is put (default 5)
 * With `shadows`, the key light (keyLight) is a DirectionalLight casting shadows, the
 * LightProbe holds the rest of the SH9, and the catcher's opacity is the key light's share
 * of the catcher's irradiance (plus, with an occluder, the share of its light the occluder
 * hides of the ambient, per pixel); the connection's `.shadows` holds { light, catcher, key,
 * occluder }.
 * Without lights in the messages, the light is off and the catcher transparent.
 * A top-level `renderer` (a WebGLRenderer) has its toneMappingExposure follow the room's
 * EV100 when the lighting is in absolute units (physicalExposure; issue 31), unless
 * `passthrough` is given: on a video see-through headset, the renderer is tone-mapped as the
 * headset's camera renders the room (passthrough.js, docs/passthrough.md); an object
 *   THREE, renderer   (renderer: default the top-level one)
 *   session           an XRSession: send its camera views to /capture (startCameraSender,
 *                     where the browser has WebXR Raw Camera Access; `hz`, `maxWidth`,
 *                     `referenceSpace` as its options) and render through the answers
 *   socket            or any WebSocket on /capture whose answers to follow (a sender's)
 *   camera, exposure, wbGains   a model to start from (default sRGB, 1, [1, 1, 1])
 * or a controller made by passthroughToneMapping. The connection's `.passthrough` is the
 * controller (its handle(msg) takes /capture's answers from anywhere else), `.sender` the sender.
 */
export function connectLightProbe(url, lightProbe, options = {}) {
  const settings = { rotation: options.rotation || null, intensity: options.intensity ?? 1 };
  const shadows = options.shadows ? shadowSetup(options.shadows) : null;
  const passthrough = options.passthrough ? passthroughSetup(url, options, settings) : null;
  const conn = connect(url, {
    ...options,
    onLighting: (lighting, c) => {
      if (shadows) applyShadows(shadows, lightProbe, lighting, settings);
      else setLightProbe(lightProbe, lighting, settings);
      if (!passthrough) followExposure(options, lighting);
      if (options.onLighting) options.onLighting(lighting, c);
    },
  });
  conn.options = settings;
  conn.lightProbe = lightProbe;
  if (shadows) conn.shadows = shadows.state;
  if (passthrough) Object.assign(conn, passthrough);
  return conn;
}

// connectLightProbe's `passthrough`: the tone mapping, and where its answers come from.
function passthroughSetup(url, options, settings) {
  const p = options.passthrough;
  const tm = typeof p.handle === "function" ? p : passthroughToneMapping(p.THREE, p.renderer || options.renderer, p);
  let sender = null;
  if (p.session) {
    sender = startCameraSender(url, { ...p, renderer: p.renderer || options.renderer, probe: options.probe,
                                      token: options.token, rotation: settings.rotation });
  }
  const socket = p.socket || (sender && sender.socket);
  if (socket) socket.addEventListener("message", (e) => { if (typeof e.data === "string") tm.handle(e.data); });
  return { passthrough: tm, sender };
}

function shadowSetup(opts) {
  const { THREE } = opts;
  if (!THREE) throw new TypeError("connectLightProbe: shadows.THREE is required");
  let light = opts.light;
  if (!light) {
    light = new THREE.DirectionalLight(0xffffff, 0);
    setShadowCamera(light, { size: 4, near: 0.1, far: 20 });
    light.name = "shlight key light";
  }
  light.castShadow = true;
  const catcher = opts.catcher === undefined ? shadowCatcher(THREE) : opts.catcher;
  if (opts.scene) {
    opts.scene.add(light, light.target);
    if (catcher) opts.scene.add(catcher);
  }
  if (opts.renderer) {
    opts.renderer.shadowMap.enabled = true;
    opts.renderer.shadowMap.type = THREE.PCFShadowMap;
  }
  const state = { light, catcher, key: null, occluder: opts.occluder || null };
  if (catcher && catcher.userData.shOccluder) {
    // the hologram may move every frame: its sphere is taken just before the catcher is drawn
    const sphere = new THREE.Sphere();
    onceAFrame(catcher, () =>
      setCatcherOccluder(catcher, state.occluder ? occluderSphere(THREE, state.occluder, sphere) : null));
  }
  return { THREE, light, catcher, up: opts.up || [0, 1, 0], casterHeight: opts.casterHeight ?? 0.5,
           distance: opts.distance ?? 5, state };
}

// Run fn just before `catcher` is drawn, once a frame: three calls onBeforeRender once per view
// (twice a frame in stereo). Whatever onBeforeRender the catcher had (connectLightProbe's own,
// when xrShadows shares its catcher) runs first, every call, as before.
function onceAFrame(catcher, fn) {
  const before = catcher.onBeforeRender;
  let frame = -1;
  catcher.onBeforeRender = function (renderer, ...rest) {
    if (before) before.call(this, renderer, ...rest);
    const now = renderer && renderer.info ? renderer.info.render.frame : NaN;
    if (now === frame) return;
    frame = now;
    fn();
  };
}

// A shadow-casting light's map (1024²) and square shadow camera, `size` wide, from `near` to `far`
// along the light (connectLightProbe's light, xrShadows' XREstimatedLight one).
function setShadowCamera(light, { size, near, far }) {
  light.shadow.mapSize.set(1024, 1024);
  Object.assign(light.shadow.camera, { left: -size / 2, right: size / 2, top: size / 2, bottom: -size / 2, near, far });
  light.shadow.camera.updateProjectionMatrix();
  light.shadow.bias = -0.0005;
}

function applyShadows(s, lightProbe, lighting, settings) {
  const previous = s.state.key ? s.state.key.index : -1;
  const key = keyLight(lighting, { rotation: settings.rotation, up: s.up, previous });
  s.state.key = key;
  setLightProbe(lightProbe, key ? key.coefficients : lighting, settings);
  setKeyLight(s.light, key, { intensity: settings.intensity, distance: s.distance, casterHeight: s.casterHeight });
  if (s.catcher) s.catcher.material.opacity = key ? key.share : 0;
  if (s.catcher) setCatcherLighting(s.THREE, s.catcher, lighting, { rotation: settings.rotation, up: s.up,
                                                                    key: key ? key.index : -1 });
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

// ---- shadows (docs/contract.md §10, docs/shadows.md): the key light as a shadow caster -----
//
// Opt-in: connectLightProbe(url, probe, { shadows: { THREE, scene } }) or keyLight()/
// setKeyLight()/shadowCatcher() by hand; without `shadows` nothing below runs.
// * The key light is the brightest of the message's lights (Rec. 709 luminance of its
//   irradiance, as the provider's webxr export picks its primary light); it stays the key
//   light until another is more than KEY_HYSTERESIS brighter, so that two near-equal lamps do
//   not make the shadow jump between them.
// * It becomes a THREE.DirectionalLight with castShadow (colour × intensity = its irradiance
//   E_k: three lights a Lambert surface by E·max(0, n·l)·ρ/π, as our E(n)); the LightProbe then
//   holds the full SH9 less that light's own projection E_k·Y(d_k) (docs/contract.md §10: the
//   ambient plus each light's I_k·Y(d_k) is the full SH9), so nothing is counted twice.
// * Softness: three r187's PCF shadow (PCFShadowMap, shadowmap_pars_fragment.glsl.js:150-190)
//   averages the shadow map over a disc of `shadow.radius` texels. A disc light of angular
//   radius r seen past an edge `casterHeight` above the receiver gives a penumbra of width
//   2·h·tan r; a blur of radius ρ gives a transition of width 2ρ. So ρ = h·tan r / texel, with
//   texel = the shadow camera's width / mapSize. Exact only for edges at casterHeight (three
//   has no contact-hardening shadows); at least 1 texel (three's default).
// * The shadow catcher: a THREE.ShadowMaterial (black, alpha = opacity · (1 − shadow)) drawn
//   over the camera image (passthrough, or a transparent canvas over video): there it leaves
//   image × (1 − opacity·(1 − V)). With opacity = the key light's share of the floor's
//   irradiance, s = E_key⟨n·d⟩ / (E_ambient(n) + Σ_k E_k⟨n·d_k⟩), that is image ×
//   shadow_ratio(n, V) with V the key light's visibility and the other lights unblocked
//   (Rec. 709 luminance of the RGB ratio: the material's alpha is one number).

/** A key light stays key until another is brighter by more than this factor − 1. */
export const KEY_HYSTERESIS = 0.1;
const REC709 = [0.2126, 0.7152, 0.0722];
const luminance = (e) => REC709[0] * e[0] + REC709[1] * e[1] + REC709[2] * e[2];

/** Index of the key light among k lights' RGB irradiance (3k numbers; -1 if none). */
export function keyLightIndex(lightIrradiance, previous = -1) {
  const k = Math.floor((lightIrradiance ? lightIrradiance.length : 0) / 3);
  let best = -1, bestY = -Infinity;
  for (let i = 0; i < k; i++) {
    const y = luminance(lightIrradiance.slice(3 * i, 3 * i + 3));
    if (y > bestY) { best = i; bestY = y; }
  }
  if (previous >= 0 && previous < k && best >= 0 &&
      luminance(lightIrradiance.slice(3 * previous, 3 * previous + 3)) * (1 + KEY_HYSTERESIS) >= bestY) {
    return previous;
  }
  return best;
}

function turn(R, d) {
  return R ? [R[0] * d[0] + R[1] * d[1] + R[2] * d[2], R[3] * d[0] + R[4] * d[1] + R[5] * d[2],
              R[6] * d[0] + R[7] * d[1] + R[8] * d[2]] : [d[0], d[1], d[2]];
}

/**
 * 27 radiance coefficients less a directional light's projection E·Y(d) (contract §1 basis),
 * into `out` (27 numbers; a new Float32Array by default; `coefficients` itself works: in place).
 */
export function withoutLight(coefficients, d, e, out = new Float32Array(27)) {
  const [x, y, z] = d;
  const Y = [0.282095, 0.488603 * y, 0.488603 * z, 0.488603 * x, 1.092548 * x * y, 1.092548 * y * z,
             0.315392 * (3 * z * z - 1), 1.092548 * x * z, 0.546274 * (x * x - y * y)];
  if (out !== coefficients) for (let i = 0; i < 27; i++) out[i] = coefficients[i];
  for (let i = 0; i < 9; i++) for (let c = 0; c < 3; c++) out[3 * i + c] -= e[c] * Y[i];
  return out;
}

// The lights of a Lighting (client.js decodeLighting) or an "sh9" message: { message, count,
// directions (3·count, provider frame, as sent), irradiance (3·count, RGB), radii (count
// angular radii, degrees ≥ 0: 0, a point light, where the provider sends none or a bad one) };
// count 0 where it has no lights or its arrays disagree with its `lights`.
function messageLights(lighting) {
  const m = (lighting && lighting.message ? lighting.message : lighting) || null;
  const k = m && Number.isInteger(m.lights) ? m.lights : 0;
  const dirs = m && m.light_directions, irr = m && m.light_irradiance;
  if (!(k > 0) || !dirs || !irr || dirs.length !== 3 * k || irr.length !== 3 * k) {
    return { message: m, count: 0, directions: [], irradiance: [], radii: [] };
  }
  const r = m.light_angular_radius_deg;
  const radii = Array.isArray(r) && r.length === k ? r.map((v) => (Number.isFinite(+v) ? Math.max(0, +v) : 0))
    : new Array(k).fill(0);
  return { message: m, count: k, directions: dirs, irradiance: irr, radii };
}

// The indices of the lights other than the key one, at most 3 (the shaders' other-light slots),
// in order: those a catcher shadows past its occluder's sphere.
function otherLightIndices(count, key) {
  const out = [];
  for (let i = 0; i < count && out.length < 3; i++) if (i !== key) out.push(i);
  return out;
}

// The ambient irradiance matrices of an "sh9" message: its ambient_matrices, else built from
// its ambient (else full) coefficients.
function ambientMatricesOf(m) {
  return m.ambient_matrices && m.ambient_matrices.length === 48 ? m.ambient_matrices
    : matricesFromCoefficients(m.ambient_coefficients && m.ambient_coefficients.length === 27
      ? m.ambient_coefficients : m.coefficients);
}

// What a surface of normal n (provider frame) receives: the ambient E(n) clamped at 0 per
// colour, each light's Rec. 709 luminance × max(0, n·d), and their total (luminance).
function floorIrradiance(ambient, n, dirs, irr) {
  const a = irradiance(ambient, n).map((e) => Math.max(0, e));
  const lights = [];
  let total = luminance(a);
  for (let i = 0; 3 * i + 2 < dirs.length; i++) {
    const d = dirs.slice(3 * i, 3 * i + 3), dl = Math.hypot(d[0], d[1], d[2]) || 1;
    const e = luminance(irr.slice(3 * i, 3 * i + 3)) * Math.max(0, (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / dl);
    lights.push(e);
    total += e;
  }
  return { ambient: a, lights, total };
}

/**
 * The key light of a Lighting (client.js decodeLighting) or an "sh9" message, or null where
 * it has no lights: { index, direction (unit, your world: rotation · the provider's),
 * irradiance [r, g, b], angularRadiusDeg (light_angular_radius_deg; 0, a hard shadow, where
 * the provider sends none), share (the key light's share of the irradiance of a surface
 * facing `up`, your world, Rec. 709 luminance: the catcher's opacity), coefficients (the
 * full SH9 less the key light, provider frame) }. `previous`: the last key light's index.
 */
export function keyLight(lighting, { rotation = null, up = [0, 1, 0], previous = -1 } = {}) {
  const { message: m, count, directions: dirs, irradiance: irr, radii } = messageLights(lighting);
  if (!count) return null;
  const index = keyLightIndex(irr, previous);
  // the floor normal in the provider's frame: Rᵀ·up
  const n = rotation ? [0, 1, 2].map((j) => rotation[j] * up[0] + rotation[3 + j] * up[1] + rotation[6 + j] * up[2]) : up;
  const { total, lights } = floorIrradiance(ambientMatricesOf(m), n, dirs, irr);
  const key = lights[index];
  const d0 = dirs.slice(3 * index, 3 * index + 3), len = Math.hypot(d0[0], d0[1], d0[2]);
  const e0 = irr.slice(3 * index, 3 * index + 3).map(Number);
  const coefficients = withoutLight(lighting.coefficients || m.coefficients, d0.map((v) => v / len), e0);
  return { index, direction: turn(rotation, d0.map((v) => v / len)), irradiance: e0,
           angularRadiusDeg: radii[index], share: total > 0 ? key / total : 0, coefficients };
}

/**
 * The lights of a Lighting or "sh9" message other than its key light (keyLight's: the brightest,
 * or `previous` within the hysteresis), at most 3: [{ direction (unit, your world: rotation · the
 * provider's), irradiance [r, g, b], angularRadiusDeg }]. What xrShadows' `otherLights` takes:
 * WebXR's estimate has one light and folds these into its SH.
 */
export function otherLights(lighting, { rotation = null, previous = -1 } = {}) {
  const { count, directions: dirs, irradiance: irr, radii } = messageLights(lighting);
  return otherLightIndices(count, count ? keyLightIndex(irr, previous) : -1).map((i) => {
    const d = dirs.slice(3 * i, 3 * i + 3), len = Math.hypot(d[0], d[1], d[2]) || 1;
    return { direction: turn(rotation, d.map((v) => v / len)), irradiance: irr.slice(3 * i, 3 * i + 3).map(Number),
             angularRadiusDeg: radii[i] };
  });
}

/**
 * shadow.radius (texels of three's PCF disc) for a light of angular radius `angularRadiusDeg`
 * seen past an edge `casterHeight` (world units, e.g. metres) above the receiver, for a
 * shadow camera `frustumWidth` wide with a `mapSize`-texel map: h·tan r·mapSize / width, ≥ 1.
 */
export function shadowRadiusTexels(angularRadiusDeg, { casterHeight = 0.5, mapSize = 1024, frustumWidth = 4 } = {}) {
  const r = (Math.max(0, +angularRadiusDeg || 0) * Math.PI) / 180;
  return Math.max(1, (casterHeight * Math.tan(r) * mapSize) / frustumWidth);
}

/**
 * Set a THREE.DirectionalLight (castShadow on) from keyLight()'s result: it shines from
 * `distance` along the key direction toward its target, colour × `intensity` = the key
 * light's irradiance, shadow.radius from the angular radius (shadowRadiusTexels, the light's
 * own shadow camera and map size). `key` null: the light is switched off (intensity 0).
 */
export function setKeyLight(light, key, { intensity = 1, distance = 5, casterHeight = 0.5 } = {}) {
  light.castShadow = true;
  if (!key) { light.intensity = 0; return light; }
  const t = light.target.position, d = key.direction;
  light.position.set(t.x + distance * d[0], t.y + distance * d[1], t.z + distance * d[2]);
  const e = key.irradiance, top = Math.max(e[0], e[1], e[2]);
  if (top > 0) light.color.setRGB(e[0] / top, e[1] / top, e[2] / top);
  light.intensity = top * intensity;
  const cam = light.shadow.camera;
  light.shadow.radius = shadowRadiusTexels(key.angularRadiusDeg, { casterHeight,
    mapSize: light.shadow.mapSize.x, frustumWidth: Math.abs(cam.right - cam.left) || 1 });
  light.updateMatrixWorld();
  return light;
}

/**
 * A shadow catcher: a horizontal square (`size` world units, facing +Y, receiveShadow) of
 * THREE.ShadowMaterial, invisible but for the darkening. Put it where the real floor (or
 * table) is; its material.opacity is kept at the key light's share by connectLightProbe's
 * `shadows`. Transparent everywhere the key light is not blocked.
 */
export function shadowCatcher(THREE, { size = 4, segments = 1 } = {}) {
  const geometry = new THREE.PlaneGeometry(size, size, segments, segments);
  geometry.rotateX(-Math.PI / 2);
  const material = new THREE.ShadowMaterial({ color: 0x000000, opacity: 0, depthWrite: false });
  const mesh = new THREE.Mesh(geometry, material);
  mesh.receiveShadow = true;
  mesh.name = "shlight shadow catcher";
  const u = {
    shIrradianceR: { value: new THREE.Matrix4().makeScale(0, 0, 0) },
    shIrradianceG: { value: new THREE.Matrix4().makeScale(0, 0, 0) },
    shIrradianceB: { value: new THREE.Matrix4().makeScale(0, 0, 0) },
    shToProvider: { value: new THREE.Matrix3() },
    shUp: { value: new THREE.Vector3(0, 1, 0) },
    shAmbientAtUp: { value: new THREE.Vector3() },
    shOccluderScale: { value: 0 },
    shOccluderSphere: { value: new THREE.Vector4(0, 0, 0, 0) },
    // the lights other than the key light (whose shadow is the shadow map's): direction toward each
    // (provider frame) and angular radius (radians), and each one's share of the floor's light
    shOtherLight: { value: [new THREE.Vector4(), new THREE.Vector4(), new THREE.Vector4()] },
    shOtherShare: { value: new THREE.Vector3() },
  };
  mesh.userData.shOccluder = u;
  // ShadowMaterial's alpha, opacity · (1 − shadow), plus the share of the floor's light that the
  // occluder's sphere hides of the ambient (shOccludedAmbientOfSphere, Rec. 709 luminance) and of
  // every other light (its share × the part of its disc the sphere hides, shSphereLightVisibility).
  material.onBeforeCompile = (shader) => {
    Object.assign(shader.uniforms, u);
    shader.vertexShader = "varying vec3 vShWorld;\n" + shader.vertexShader.replace("#include <begin_vertex>",
      "#include <begin_vertex>\n\tvShWorld = (modelMatrix * vec4(transformed, 1.0)).xyz;");
    shader.fragmentShader = OCCLUDER_GLSL + shader.fragmentShader.replace(
      "gl_FragColor = vec4( color, opacity * ( 1.0 - getShadowMask() ) );",
      "gl_FragColor = vec4( color, min( 1.0, opacity * ( 1.0 - getShadowMask() ) + shOccludedShare() + shOtherLightsShare() ) );");
  };
  material.customProgramCacheKey = () => "shlight-occluder-lights";
  return mesh;
}

// The occluder's ambient occlusion on the catcher (docs/shadows.md) and each other light's shadow
// past it: shRadianceFromMatrix, shOccludedAmbient, shOccludedAmbientOfSphere, shCapSegment,
// shCapHalfChord, shCapOverlapFraction and shSphereLightVisibility are verbatim copies of shaders/sh9_lights.glsl's
// (tests/clients/three/test_shadows_three.py checks the copy); they read the ambient matrices, in the provider's
// frame, as shIrradianceR/G/B.
const OCCLUDER_GLSL = `
uniform mat4 shIrradianceR;
uniform mat4 shIrradianceG;
uniform mat4 shIrradianceB;
uniform mat3 shToProvider;      // your world -> the provider's frame (Rᵀ of connectLightProbe's rotation)
uniform vec3 shUp;              // the catcher's normal, your world
uniform vec3 shAmbientAtUp;     // max(E_a(n), 0) at that normal, per colour
uniform float shOccluderScale;  // 1 / the floor's open irradiance (Rec. 709), 0: nothing lights it
uniform vec4 shOccluderSphere;  // the occluder's bounding sphere, your world (w <= 0: none)
uniform vec4 shOtherLight[3];   // the other lights: direction toward each (provider frame), angular radius (rad)
uniform vec3 shOtherShare;      // each one's share of the floor's open light (Rec. 709), 0: none
varying vec3 vShWorld;
float shRadianceFromMatrix(mat4 A, vec3 d) {
    vec3 m = A[3].xyz;
    float traceB = A[0][0] + A[1][1] + A[2][2];
    return (4.0 * dot(d, mat3(A) * d) + 3.0 * dot(m, d) + A[3][3] - traceB) / 3.14159265358979;
}

vec3 shOccludedAmbient(vec3 n, vec3 toOccluder, float sinHalfAngle) {
    float s = clamp(sinHalfAngle, 0.0, 1.0);
    float s2 = s * s;
    float h = clamp(dot(n, toOccluder), -1.0, 1.0);
    float cap;
    if (h * h >= s2) {
        cap = 3.14159265358979 * s2 * max(h, 0.0);
    } else {
        float sinT = sqrt(max(1.0 - h * h, 0.0));
        float x = sqrt(max(1.0 - s2, 0.0)) / max(s, 1e-30);   // cot α
        float y = clamp(-x * h / max(sinT, 1e-30), -1.0, 1.0);
        float sy = sqrt(max((s - h) * (s + h), 0.0)) / s;   // sinT·sqrt(1 − y²), accurate
        cap = max((h * acos(y) - x * sy) * s2 + atan(sy, x), 0.0);
    }
    vec3 radiance = vec3(shRadianceFromMatrix(shIrradianceR, toOccluder),
                         shRadianceFromMatrix(shIrradianceG, toOccluder),
                         shRadianceFromMatrix(shIrradianceB, toOccluder));
    return max(radiance, vec3(0.0)) * cap;
}

vec3 shOccludedAmbientOfSphere(vec3 n, vec3 p, vec4 sphere) {
    if (sphere.w <= 0.0) return vec3(0.0);
    vec3 toCentre = sphere.xyz - p;
    float dist = length(toCentre);
    vec3 d = dist > 0.0 ? toCentre / dist : n;
    return shOccludedAmbient(n, d, sphere.w / max(dist, 1e-30));
}

float shOccludedShare() {
    if (shOccluderSphere.w <= 0.0 || shOccluderScale <= 0.0) return 0.0;
    vec3 n = shToProvider * shUp;
    vec3 o = shOccludedAmbientOfSphere(n, shToProvider * vShWorld,
                                       vec4(shToProvider * shOccluderSphere.xyz, shOccluderSphere.w));
    return dot(min(o, shAmbientAtUp), vec3(0.2126, 0.7152, 0.0722)) * shOccluderScale;
}

float shCapSegment(float x, float c) {
    float s2 = sin(0.5 * x); s2 *= s2;
    if (c < 0.5) {
        float q = s2 * (1.0 - s2), cc = c * c;
        return (1.0 - s2) * (1.0 - 2.0 * s2) * cc * c * (1.0 / 3.0 - (1.0 - 12.0 * q) * cc / 60.0
               + (1.0 - 60.0 * q + 360.0 * q * q) * cc * cc / 2520.0);
    }
    float tri = s2 > 0.0 ? atan(s2 * sin(c), (1.0 - s2) + s2 * cos(c)) / s2 : sin(c);
    return 2.0 * c - 2.0 * tri;
}

float shCapHalfChord(float x, float y, float g, float gx) {
    float den = sin(x) * sin(g);
    float c = 1.0 + 2.0 * sin(0.5 * (gx + y)) * sin(0.5 * (gx - y)) / (den > 0.0 ? den : 1.0);
    return acos(clamp(c, -1.0, 1.0));
}

float shCapOverlapFraction(float a, float alpha, float g, float delta) {
    if (a <= 0.0) return delta < 0.0 ? 1.0 : 0.0;         // a point light
    if (delta >= a) return 0.0;                            // apart
    if (delta <= -a) return 1.0;                           // the disc inside the sphere
    float sa = sin(0.5 * a), sal = sin(0.5 * alpha);
    float areaRatio = (sal * sal) / (sa * sa);             // Ω(cap_α) / Ω(cap_a)
    if (g <= a - alpha) return min(areaRatio, 1.0);        // the sphere inside the disc
    float lens = shCapSegment(a, 2.0 * shCapHalfChord(a, alpha, g, delta + alpha - a))
               + areaRatio * shCapSegment(alpha, 2.0 * shCapHalfChord(alpha, a, g, delta));
    return clamp(lens / (4.0 * 3.14159265358979), 0.0, 1.0);
}

float shSphereLightVisibility(vec3 p, vec4 sphere, vec3 lightDirection, float angularRadius) {
    if (sphere.w <= 0.0) return 1.0;
    vec3 toCentre = sphere.xyz - p;
    float dist = length(toCentre);
    if (dist <= sphere.w) return 0.0;
    vec3 d = toCentre / dist;
    float sinG = length(cross(d, lightDirection)), cosG = dot(d, lightDirection);
    float sinAlpha = sphere.w / dist, cosAlpha = sqrt((dist - sphere.w) * (dist + sphere.w)) / dist;
    float delta = atan(sinG * cosAlpha - cosG * sinAlpha, cosG * cosAlpha + sinG * sinAlpha);
    return 1.0 - shCapOverlapFraction(max(angularRadius, 0.0), atan(sinAlpha, cosAlpha),
                                       atan(sinG, cosG), delta);
}

float shOtherLightsShare() {
    if (shOccluderSphere.w <= 0.0) return 0.0;
    vec3 p = shToProvider * vShWorld;
    vec4 sphere = vec4(shToProvider * shOccluderSphere.xyz, shOccluderSphere.w);
    float share = 0.0;
    for (int i = 0; i < 3; ++i) {
        if (shOtherShare[i] <= 0.0) continue;
        share += shOtherShare[i] * (1.0 - shSphereLightVisibility(p, sphere, shOtherLight[i].xyz, shOtherLight[i].w));
    }
    return share;
}
`;

/**
 * The world bounding sphere of `object` (a THREE.Sphere is returned as is): the union of its
 * meshes' geometry bounding spheres, in world space (a round hologram's own sphere, not the
 * sphere around its box). Into `target`; radius 0 when it has no geometry.
 */
export function occluderSphere(THREE, object, target = new THREE.Sphere()) {
  if (!object) return target.set(new THREE.Vector3(), 0), target;
  if (object.isSphere) return target.copy(object);
  const part = new THREE.Sphere();
  let any = false;
  object.updateWorldMatrix(true, true);
  object.traverse((o) => {
    if (!o.geometry || !o.visible) return;
    if (!o.geometry.boundingSphere) o.geometry.computeBoundingSphere();
    part.copy(o.geometry.boundingSphere).applyMatrix4(o.matrixWorld);
    if (any) target.union(part); else { target.copy(part); any = true; }
  });
  if (!any) target.set(new THREE.Vector3(), 0);
  return target;
}

/**
 * Point a catcher (shadowCatcher) at the lighting its occluder terms need: `lighting` a Lighting
 * or "sh9" message (its ambient matrices, lights and their angular radii), `rotation` (provider
 * → your world, as connectLightProbe's), `up` the catcher's normal in your world, `key` the index
 * of the light whose shadow the shadow map draws (the others, up to 3, are shadowed by the
 * occluder's sphere in the shader). `ambientCoefficients` (27, your world, e.g. an XR probe's SH ×
 * intensity) with `lights` [{direction, irradiance, angularRadiusDeg}] may stand in for `lighting`.
 */
export function setCatcherLighting(THREE, catcher, lighting, { rotation = null, up = [0, 1, 0],
                                                               ambientCoefficients = null, lights = [],
                                                               key = 0 } = {}) {
  const u = catcher && catcher.userData.shOccluder;
  if (!u) return;
  let ambient, dirs = [], irr = [], radii = [];
  if (ambientCoefficients) {
    ambient = matricesFromCoefficients(ambientCoefficients);
    rotation = null;
    for (const l of lights) { dirs.push(...l.direction); irr.push(...l.irradiance); radii.push(l.angularRadiusDeg || 0); }
  } else {
    const ml = messageLights(lighting);
    if (!ml.message) return;
    ambient = ambientMatricesOf(ml.message);
    ({ directions: dirs, irradiance: irr, radii } = ml);
  }
  const R = rotation || [1, 0, 0, 0, 1, 0, 0, 0, 1];
  u.shToProvider.value.set(R[0], R[3], R[6], R[1], R[4], R[7], R[2], R[5], R[8]);     // Rᵀ
  u.shUp.value.set(up[0], up[1], up[2]).normalize();
  const n = [0, 1, 2].map((j) => R[j] * up[0] + R[3 + j] * up[1] + R[6 + j] * up[2]);
  const len = Math.hypot(n[0], n[1], n[2]) || 1;
  const nn = n.map((v) => v / len);
  const { ambient: a, lights: shares, total } = floorIrradiance(ambient, nn, dirs, irr);
  u.shAmbientAtUp.value.set(a[0], a[1], a[2]);
  u.shOccluderScale.value = total > 0 ? 1 / total : 0;
  // the lights but the key one (up to 3), each shadowed by the occluder in the shader
  const share = [0, 0, 0];
  otherLightIndices(shares.length, key).forEach((i, slot) => {
    const d = dirs.slice(3 * i, 3 * i + 3), dl = Math.hypot(d[0], d[1], d[2]) || 1;
    u.shOtherLight.value[slot].set(d[0] / dl, d[1] / dl, d[2] / dl, (radii[i] * Math.PI) / 180);
    share[slot] = total > 0 ? shares[i] / total : 0;
  });
  u.shOtherShare.value.set(share[0], share[1], share[2]);
  [u.shIrradianceR, u.shIrradianceG, u.shIrradianceB].forEach((m, c) =>
    m.value.fromArray(ambient, 16 * c));      // symmetric: either order; no per-frame copies
}

/** Set a catcher's occluder sphere (a THREE.Sphere, your world; null or radius 0: none). */
export function setCatcherOccluder(catcher, sphere) {
  const u = catcher && catcher.userData.shOccluder;
  if (!u) return;
  if (sphere && sphere.radius > 0) u.shOccluderSphere.value.set(sphere.center.x, sphere.center.y, sphere.center.z, sphere.radius);
  else u.shOccluderSphere.value.set(0, 0, 0, 0);
}

/**
 * Shadows for three's XREstimatedLight (three/addons/webxr/XREstimatedLight.js), fed by the
 * browser's own light estimation or by the provider's polyfill (xr-lighting-polyfill.js):
 * its DirectionalLight (the estimate's primary light, shining from primaryLightDirection at
 * unit distance toward the origin) casts shadows, and a catcher's opacity is that light's
 * share of the catcher's irradiance, E_p⟨n·d⟩ / (E_probe(n) + E_p⟨n·d⟩), E_probe from the
 * estimate's SH (which holds everything but the primary light), Rec. 709 luminance.
 * Options:
 *   scene, renderer, catcher, up, casterHeight   as connectLightProbe's `shadows`
 *   size              width of the shadow camera's square (world units, default 4): what
 *                     shadows can fall on; its near/far are ±`depth` (default 10) about
 *                     the light's position, since XREstimatedLight puts it 1 unit from the origin
 *   angularRadiusDeg  the primary light's angular radius: a number, or a function returning
 *                     one (e.g. from the provider's sh9 messages, keyLight(conn.latest));
 *                     WebXR's estimate has no field for it. Default 0 (a hard shadow).
 *   occluder          the hologram (THREE.Object3D or THREE.Sphere): the catcher also darkens
 *                     by the estimate's ambient that its bounding sphere hides (as
 *                     connectLightProbe's `shadows.occluder`); settable later as `.occluder`
 *   otherLights       the lights the estimate folds into its SH (otherLights(conn.latest), your
 *                     world): an array or a function returning one. With an occluder, their SH9
 *                     projections are taken out of the estimate's SH and each casts its shadow
 *                     past the occluder's sphere (shSphereLightVisibility), as in connectLightProbe.
 * Returns { light, catcher, share, angularRadiusDeg, active, occluder, update() }: update() runs before
 * the catcher is drawn each frame (its onBeforeRender; call it yourself to read `share`
 * sooner) and does nothing while `active` is false (e.g. outside a session, where another
 * driver, connectLightProbe's `shadows`, may own the catcher).
 */
export function xrShadows(THREE, xrLight, opts = {}) {
  const light = xrLight.directionalLight, size = opts.size ?? 4, depth = opts.depth ?? 10;
  light.castShadow = true;
  setShadowCamera(light, { size, near: -depth, far: depth });
  const catcher = opts.catcher === undefined ? shadowCatcher(THREE, { size }) : opts.catcher;
  if (opts.scene && catcher) opts.scene.add(catcher);
  if (opts.renderer) {
    opts.renderer.shadowMap.enabled = true;
    opts.renderer.shadowMap.type = THREE.PCFShadowMap;
  }
  const up = new THREE.Vector3(...(opts.up || [0, 1, 0])).normalize();
  const casterHeight = opts.casterHeight ?? 0.5, e = new THREE.Vector3(), dir = new THREE.Vector3();
  const state = { light, catcher, share: 0, angularRadiusDeg: 0, active: true, update,
                  occluder: opts.occluder || null };
  const sphere = new THREE.Sphere(), ambient = new Float32Array(27);
  function update() {
    if (!state.active) return;
    // toward the primary light (three puts it at unit distance from its target); zero when unset
    dir.copy(light.position).sub(light.target.position);
    const lit = dir.lengthSq() > 0;
    if (lit) dir.normalize();
    const r = typeof opts.angularRadiusDeg === "function" ? opts.angularRadiusDeg() : opts.angularRadiusDeg;
    state.angularRadiusDeg = Number.isFinite(+r) && +r > 0 ? +r : 0;
    if (catcher && catcher.userData.shOccluder) {
      // the occluder term from the estimate: its probe (everything but the primary light, your world)
      const sh = xrLight.lightProbe.sh.coefficients, k = xrLight.lightProbe.intensity;
      for (let i = 0; i < 9; i++) { ambient[3 * i] = sh[i].x * k; ambient[3 * i + 1] = sh[i].y * k; ambient[3 * i + 2] = sh[i].z * k; }
      const lights = light.visible && lit ? [{ direction: dir.toArray(), angularRadiusDeg: state.angularRadiusDeg,
        irradiance: [light.color.r * light.intensity, light.color.g * light.intensity, light.color.b * light.intensity] }] : [];
      const others = (typeof opts.otherLights === "function" ? opts.otherLights() : opts.otherLights) || [];
      if (lights.length && state.occluder) {
        for (const l of others) { withoutLight(ambient, l.direction, l.irradiance, ambient); lights.push(l); }
      }
      setCatcherLighting(THREE, catcher, null, { up: up.toArray(), ambientCoefficients: ambient, lights, key: 0 });
      setCatcherOccluder(catcher, state.occluder ? occluderSphere(THREE, state.occluder, sphere) : null);
    }
    xrLight.lightProbe.sh.getIrradianceAt(up, e).multiplyScalar(xrLight.lightProbe.intensity);
    const probe = luminance([Math.max(0, e.x), Math.max(0, e.y), Math.max(0, e.z)]);
    const cos = lit ? Math.max(0, dir.dot(up)) : 0;
    const c = light.color, key = luminance([c.r, c.g, c.b]) * light.intensity * cos;
    state.share = probe + key > 0 ? key / (probe + key) : 0;
    if (catcher) catcher.material.opacity = light.visible ? state.share : 0;
    light.shadow.radius = shadowRadiusTexels(state.angularRadiusDeg, { casterHeight,
      mapSize: light.shadow.mapSize.x, frustumWidth: size });
  }
  if (catcher) onceAFrame(catcher, update);
  return state;
}
