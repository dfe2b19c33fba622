// shlight WebXR lighting-estimation polyfill: where a browser's XR session has no
// "light-estimation" feature, XRSession.requestLightProbe() and XRFrame.getLightEstimate()
// answer from `shlight serve`, so three.js's own XREstimatedLight works unchanged.
// Served by the provider at /xr-lighting-polyfill.js (no build step; it imports ./client.js):
//
//   import { installLightEstimationPolyfill } from "https://HOST:8765/xr-lighting-polyfill.js";
//   const polyfill = installLightEstimationPolyfill({ token: "SECRET", probe: "room", yaw: 0 });
//   const xrLight = new XREstimatedLight(renderer, false);   // three/addons/webxr/
//   scene.add(xrLight);                                      // at the origin, unscaled
//
// What it patches (prototypes, so every session and frame of the page is covered):
//   XRSession.prototype.requestLightProbe(init): the browser's own where the session has
//     light estimation enabled (session.enabledFeatures has "light-estimation"; where a browser
//     does not say, the native call is tried first), else (or with `force`) a probe of ours.
//   XRFrame.prototype.getLightEstimate(probe): for a probe of ours, the provider's newest
//     lighting as an XRLightEstimate (null until the first arrives), else the native call.
//   XRWebGLBinding.prototype.getReflectionCubeMap(probe): for a probe of ours, a WebGL cube
//     texture of the binding's context holding the provider's reflection cube (shlight serve
//     --environment; docs/contract.md §12) turned into the reference space like the SH (null
//     until the first cube, or where the provider makes none), else the native call. Faces
//     GL_TEXTURE_CUBE_MAP_POSITIVE_X + f, so textureCube(cube, d) is the radiance toward d
//     of the reference space; level 0 only (radiance, as the WebXR Lighting Estimation
//     spec's cube map; the provider's prefiltered mips stay with client-three.js), LINEAR.
//     Format: RGBA16F (HDR, in the units of the SH) where the context can sample it (WebGL 2;
//     WebGL 1 with OES_texture_half_float(_linear)); else SRGB8_ALPHA8 (EXT_sRGB), the
//     spec's "srgba8" (radiance clipped to 1, sRGB-encoded). handle.cubeFormat says which.
//     Every new cube (and setYaw/setRotation) fires 'reflectionchange' on our probes; three's
//     XREstimatedLight(renderer, true) then puts the cube into xrLight.environment
//     (XREstimatedLight.js updateReflection: __webglTexture, needsPMREMUpdate). The binding's
//     context is recorded at construction: the polyfill replaces the global XRWebGLBinding by
//     a Proxy of it (instanceof and statics unchanged; handle.XRWebGLBinding is that class).
//   XRSession.prototype.preferredReflectionFormat: "srgba8" where the browser has none.
//   navigator.xr.requestSession: "light-estimation" moves from requiredFeatures to
//     optionalFeatures (dropped with `force`), so that a session that needs it still starts.
//
// The estimate is the provider's `webxr` export (provider/core/conventions/formats.py `_webxr`, the
// format three.js's XREstimatedLight reads; docs/engines.md): subscribed over the
// WebSocket with {"type": "subscribe", "to": "webxr"} through client.js.
//   sphericalHarmonicsCoefficients  Float32Array(27): raw radiance SH9, no Condon-Shortley
//       phase, our basis and order (three's SphericalHarmonics3.fromArray reads them as they
//       are, XREstimatedLight.js:97), without the primary light;
//   primaryLightDirection  DOMPointReadOnly, toward the light, w = 0 (default 0, 1, 0);
//   primaryLightIntensity  DOMPointReadOnly, RGB irradiance on a surface facing it, w = 1
//       (default 0, 0, 0: no light), as XREstimatedLight.js:102-112 uses it;
//   shlight  (not in the spec) {probe, seq, time, stale, convention: "webxr-threejs"}.
// Babylon.js reads the same array with Condon-Shortley signs as irradiance ÷ π: it would
// show these numbers lit from the wrong side (docs/browsers.md, the WebXR polyfill).
//
// Frame: three.js never reads probe.probeSpace (XREstimatedLight.js:93-112 use the numbers
// as they are, in the world it renders: renderer.xr.getReferenceSpace(), "local-floor" by
// default, WebXRManager.js:44), so the polyfill hands out lighting already turned into that
// space: the provider's frame (the camera's) turned by `yaw` degrees about +Y, or by
// `rotation`. A "local"/"local-floor" space faces where the headset looked when the session
// began; yaw = how far the headset then faced to the right (clockwise seen from above) of
// the camera's forward direction (the centre of its panorama, −Z). probeSpace is the session's "local"
// space (null where it has none), as Chromium does for ARCore (xr_light_probe.cc:50-56).
//
// Stale lighting: while the provider's source is lost, or the provider is unreachable, the
// last lighting stays (estimate.shlight.stale is true); one console warning per outage.
import { connect, registrationRotation, resampleCube, rotateCoefficients } from "./client.js";
import { passthroughToneMapping, startCameraSender } from "./passthrough.js";

export const FEATURE = "light-estimation";
/** The `convention` of the estimates: the webxr export's (three.js's reading). */
export const CONVENTION = "webxr-threejs";

/**
 * The webxr-format Lighting of an "export" message with format "webxr" (null for anything
 * else, e.g. the "sh9" messages sent before the subscription takes effect): the decode
 * this module hands to client.js's connect().
 */
export function decodeEstimate(msg) {
  if (!msg || msg.type !== "export" || msg.format !== "webxr") return null;
  const c = msg.sphericalHarmonicsCoefficients;
  const d = msg.primaryLightDirection, e = msg.primaryLightIntensity;
  if (!Array.isArray(c) || c.length !== 27 || !d || !e) return null;
  const coefficients = Float32Array.from(c);
  const direction = Float32Array.of(d.x, d.y, d.z);
  const intensity = Float32Array.of(e.x, e.y, e.z);
  for (const a of [coefficients, direction, intensity]) {
    if (!a.every(Number.isFinite)) return null;
  }
  return {
    probe: String(msg.probe), seq: +msg.seq, time: +msg.time, stale: msg.stale === true,
    ageS: +msg.age_s || 0, coefficients, direction, intensity, message: msg,
    receivedAt: typeof performance !== "undefined" ? performance.now() : Date.now(),
  };
}

/** Row-major 3×3 rotation about +Y by `degrees` (a direction d appears at R·d). */
export function yawRotation(degrees) {
  const a = (degrees * Math.PI) / 180, c = Math.cos(a), s = Math.sin(a);
  return [c, 0, s, 0, 1, 0, -s, 0, c];
}

function checkRotation(R) {
  if (R === null || R === undefined) return null;
  const m = Array.from(R, Number);
  if (m.length !== 9 || !m.every(Number.isFinite)) {
    throw new TypeError("shlight polyfill: rotation must be 9 finite numbers (row-major 3×3)");
  }
  for (let i = 0; i < 3; i++) {               // R Rᵀ = I: a rotation, not any matrix
    for (let j = 0; j < 3; j++) {
      const dot = m[3 * i] * m[3 * j] + m[3 * i + 1] * m[3 * j + 1] + m[3 * i + 2] * m[3 * j + 2];
      if (Math.abs(dot - (i === j ? 1 : 0)) > 1e-4) {
        throw new RangeError("shlight polyfill: rotation must be orthonormal (a rotation)");
      }
    }
  }
  return m;
}

/** The lighting turned into the reference space (`R` null: as it is), its SH × shScale. */
function turned(lighting, R, shScale) {
  let { coefficients, direction } = lighting;
  if (R) {
    const d = direction;
    direction = Float32Array.of(
      R[0] * d[0] + R[1] * d[1] + R[2] * d[2],
      R[3] * d[0] + R[4] * d[1] + R[5] * d[2],
      R[6] * d[0] + R[7] * d[1] + R[8] * d[2]);
    coefficients = rotateCoefficients(coefficients, R);
  }
  if (shScale !== 1) coefficients = coefficients.map((c) => c * shScale);
  return { ...lighting, coefficients, direction };
}

function checkScale(shScale) {
  if (!(Number.isFinite(shScale) && shScale >= 0)) {
    throw new RangeError("shlight polyfill: shScale must be a finite number >= 0");
  }
  return shScale;
}

function point(x, y, z, w) {
  return typeof DOMPointReadOnly === "function" ? new DOMPointReadOnly(x, y, z, w)
    : Object.freeze({ x, y, z, w });
}

/**
 * The XRLightEstimate of a webxr Lighting (decodeEstimate) turned by `rotation` (row-major
 * 3×3, the provider's frame → the reference space; null: as it is), its SH × `shScale`:
 * what getLightEstimate hands out.
 */
export function lightEstimate(lighting, { rotation = null, shScale = 1 } = {}) {
  return new ShlightLightEstimate(turned(lighting, checkRotation(rotation), checkScale(shScale)),
                                  lighting.stale);
}

/** What XRFrame.getLightEstimate returns for a probe of ours (XRLightEstimate's members). */
class ShlightLightEstimate {
  constructor(view, stale) {
    this.sphericalHarmonicsCoefficients = new Float32Array(view.coefficients);
    const [dx, dy, dz] = view.direction, [ex, ey, ez] = view.intensity;
    this.primaryLightDirection = point(dx, dy, dz, 0);
    this.primaryLightIntensity = point(ex, ey, ez, 1);
    this.shlight = Object.freeze({ probe: view.probe, seq: view.seq, time: view.time,
                                   stale, convention: CONVENTION });
  }
}

/**
 * Install the polyfill. Options (all optional):
 *   url      the provider ("wss://HOST:8765/"; default: the server this module came from)
 *   probe    the provider's probe (default: its first); token: its --token
 *   yaw      degrees about +Y from the provider's frame to the XR reference space (above);
 *   rotation 9 numbers, row-major: the same as any rotation (instead of yaw)
 *   force    answer from the provider even where the browser has light estimation
 *   shScale  multiplies the SH (default 1: as three's XREstimatedLight reads them; 1/π for
 *            A-Frame 1.8's reflection component, which sets its probe's intensity to 3.14)
 *   maxHz    cap on lighting messages per second (0: none); onState(state, detail),
 *            onLighting(lighting): as client.js's connect()
 *   environment  ask the provider for its reflection cube (default true; only where a probe
 *            makes cubes), for getReflectionCubeMap
 *   gl       the WebGL context for the cube maps of bindings made before install (else the
 *            one each XRWebGLBinding was made with)
 *   passthrough  on a video see-through headset, tone-map the renderer as its camera renders
 *            the room (passthrough.js, docs/passthrough.md): { THREE, renderer, send, hz,
 *            maxWidth, camera, exposure, wbGains } (or a passthroughToneMapping controller).
 *            send: true (off by default) asks each session for 'camera-access' (optional) and,
 *            where the browser has WebXR Raw Camera Access, sends its camera views to the
 *            provider's /capture (startCameraSender, poses turned back by yaw/rotation);
 *            the answers drive the tone mapping. handle.passthrough, handle.sender.
 *   XRSession, XRFrame, XRWebGLBinding, xr, WebSocket: what to patch / use (default: the
 *            browser's; a stand-in where there is no XR device, as the tests do)
 * Returns a handle: installed, state, stale, latest, connection, estimate(), setYaw(degrees),
 * setRotation(R), connect(), sendCamera(session), uninstall(). The provider is connected at the first probe of
 * ours (or at connect()), and stays connected (reconnecting by itself) until uninstall().
 */
export function installLightEstimationPolyfill(options = {}) {
  const opts = { url: null, probe: null, token: null, yaw: 0, rotation: null, force: false,
                 shScale: 1, maxHz: 0, onState: null, onLighting: null, environment: true,
                 ...options };
  const g = globalThis;
  const SessionClass = "XRSession" in options ? options.XRSession : g.XRSession;
  const FrameClass = "XRFrame" in options ? options.XRFrame : g.XRFrame;
  const BindingClass = "XRWebGLBinding" in options ? options.XRWebGLBinding : g.XRWebGLBinding;
  const xr = "xr" in options ? options.xr : g.navigator && g.navigator.xr;
  const url = opts.url || new URL("/", import.meta.url).href;
  if (!Number.isFinite(+opts.yaw)) throw new TypeError("shlight polyfill: yaw must be a number (degrees)");
  let rotation = opts.rotation ? checkRotation(opts.rotation)
    : +opts.yaw ? checkRotation(yawRotation(+opts.yaw)) : null;
  const shScale = checkScale(+opts.shScale);

  let conn = null, chosenProbe = opts.probe, view = null, warned = false;
  let cubeVersion = 0;                      // bumped by each new cube and each new rotation
  const glOf = new WeakMap();               // binding -> its WebGL context
  const cubeOf = new WeakMap();             // binding -> { texture, version, format }
  const probes = new Set();                 // our live probes, to tell of new lighting
  const sessionOf = new WeakMap();          // probe -> its session
  const watched = new WeakSet();            // sessions whose "end" we listen to
  const restore = [];                       // how to undo each patch
  const pt = opts.passthrough || null;
  const passthrough = !pt ? null : typeof pt.handle === "function" ? pt : passthroughToneMapping(pt.THREE, pt.renderer, pt);
  let sender = null;

  const handle = {
    installed: false,
    /** why nothing was installed (no XRSession in this browser), else "" */
    reason: "",
    /** "idle" (not connected yet) | client.js's "connecting" | "live" | "stale" | "down" | "closed" */
    get state() { return conn ? conn.state : "idle"; },
    /** is the lighting stale (or absent)? */
    get stale() { return !conn || conn.stale; },
    /** the newest webxr lighting, in the provider's frame (decodeEstimate), or null */
    get latest() { return conn ? conn.latest : null; },
    /** the client.js connection (null until the first probe of ours, or connect()) */
    get connection() { return conn; },
    /** the newest reflection cube (client.js EnvironmentCube, the provider's frame) or null */
    get cube() { return conn ? conn.environment : null; },
    /** "rgba16f" | "srgba8": the format of the last cube handed out (null before) */
    cubeFormat: null,
    /** the XRWebGLBinding class whose bindings the polyfill can fill (a Proxy of the browser's) */
    XRWebGLBinding: null,
    /** the rotation in use (row-major 3×3) or null */
    get rotation() { return rotation ? rotation.slice() : null; },
    /** the estimate getLightEstimate hands out now (in the reference space), or null */
    estimate() { return current() && new ShlightLightEstimate(current(), conn.stale); },
    setYaw(degrees) {
      if (!Number.isFinite(+degrees)) throw new TypeError("shlight polyfill: yaw must be a number");
      handle.setRotation(+degrees ? yawRotation(+degrees) : null);
    },
    setRotation(R) {
      rotation = checkRotation(R);
      if (sender) sender.rotation = rotation;
      view = null;
      cubeVersion++;
      tellProbes();
    },
    /**
     * Registration (docs/contract.md §13): the rotation from the headset tracker's pose of the
     * printed marker (an XRRigidTransform, its matrix, a quaternion or 9 numbers: client.js
     * rotationOf) and the provider's `registration` (the sh9 message's, or its 9-number
     * rotation): R_world←camera = R_world←marker · R_camera←markerᵀ. markerAxes: the
     * tracker's marker axes (client.js MARKER_AXES: "aruco", "y-normal", or 9 numbers).
     */
    setMarkerPose(worldFromMarker, registration, { markerAxes = "aruco" } = {}) {
      handle.setRotation(registrationRotation(worldFromMarker, registration, { markerAxes }));
    },
    /** connect to the provider now (e.g. to have lighting before the session starts) */
    connect() { return ensureConnected(); },
    /** the passthrough tone mapping (options.passthrough) or null */
    passthrough,
    /** the camera sender of the newest session (options.passthrough.send) or null */
    get sender() { return sender; },
    /** send `session`'s camera views to /capture now (what passthrough.send does at each session) */
    sendCamera(session) {
      if (!passthrough) throw new TypeError("shlight polyfill: sendCamera needs options.passthrough");
      if (sender) sender.close();
      sender = startCameraSender(url, { ...pt, session, renderer: pt.renderer, probe: chosenProbe, token: opts.token,
        rotation, ...(opts.WebSocket ? { WebSocket: opts.WebSocket } : {}),
        ...(BindingClass ? { XRWebGLBinding: BindingClass } : {}) });
      if (sender.socket) sender.socket.addEventListener("message", (e) => { if (typeof e.data === "string") passthrough.handle(e.data); });
      return sender;
    },
    uninstall() {
      for (const undo of restore.splice(0).reverse()) undo();
      if (sender) sender.close();
      if (passthrough && passthrough !== pt) passthrough.dispose();
      if (conn) conn.close();
      probes.clear();
      handle.installed = false;
    },
  };

  if (typeof SessionClass !== "function" || typeof FrameClass !== "function") {
    handle.reason = "no WebXR (XRSession, XRFrame) in this browser: nothing to polyfill";
    return handle;
  }
  const sessionProto = SessionClass.prototype, frameProto = FrameClass.prototype;
  if (sessionProto.requestLightProbe && sessionProto.requestLightProbe.shlightPolyfill) {
    throw new Error("shlight polyfill: already installed on this XRSession; uninstall() it first");
  }
  const nativeRequest = sessionProto.requestLightProbe;
  const nativeEstimate = frameProto.getLightEstimate;

  function current() {
    const l = conn && conn.latest;
    if (!l) return null;
    if (!view || view.source !== l) view = { ...turned(l, rotation, shScale), source: l };
    return view;
  }

  function tell(probe) {
    const ev = new Event("reflectionchange");
    probe.dispatchEvent(ev);
    if (typeof probe.onreflectionchange === "function") probe.onreflectionchange(ev);
  }

  function tellProbes() {
    for (const probe of probes) tell(probe);
  }

  function ensureConnected() {
    if (conn) return conn;
    let previous = null;
    conn = connect(url, {
      probe: chosenProbe || "*", token: opts.token, maxHz: opts.maxHz,
      ...(opts.WebSocket ? { WebSocket: opts.WebSocket } : {}),
      subscribe: { to: "webxr" }, decode: decodeEstimate, environment: opts.environment,
      onEnvironment: () => { cubeVersion++; tellProbes(); },
      onMessage: (msg, c) => {
        // No probe named: the provider's first (as /latest.json), not every probe by turns.
        if (msg.type === "hello" && !chosenProbe && Array.isArray(msg.probes) && msg.probes.length) {
          chosenProbe = String(msg.probes[0]);
          c.subscribe(chosenProbe);
        }
      },
      onLighting: (lighting, c) => {
        const same = previous && previous.stale === lighting.stale &&
          ["coefficients", "direction", "intensity"].every((k) =>
            previous[k].every((v, i) => v === lighting[k][i]));
        previous = lighting;
        if (!same) tellProbes();
        if (opts.onLighting) opts.onLighting(lighting, c);
      },
      onState: (state, detail, c) => {
        if (state === "live") warned = false;
        if (state === "down" && !warned) {
          warned = true;
          console.warn(`shlight polyfill: cannot reach the lighting provider at ${c.url.replace(/token=[^&]*/, "token=…")}` +
            ` (${detail}); XRFrame.getLightEstimate keeps the last lighting` +
            " (null before the first) until it is back");
        }
        if (opts.onState) opts.onState(state, detail, c);
      },
    });
    return conn;
  }

  function nativeLightEstimation(session) {
    if (typeof nativeRequest !== "function") return "no";
    const features = session.enabledFeatures;
    if (features && typeof features.includes === "function") return features.includes(FEATURE) ? "yes" : "no";
    return "unknown";                        // an older browser: try the native call first
  }

  async function ourProbe(session, init) {
    const format = (init && init.reflectionFormat) || "srgba8";
    if (format !== "srgba8" && format !== session.preferredReflectionFormat) {
      // as the spec's requestLightProbe (index.bs:224-244)
      throw new DOMException(`reflectionFormat ${format} is not supported`, "NotSupportedError");
    }
    ensureConnected();
    let space = null;
    if (typeof session.requestReferenceSpace === "function") {
      space = await session.requestReferenceSpace("local").catch(() => null);
    }
    const probe = new ShlightLightProbe(space);
    sessionOf.set(probe, session);
    probes.add(probe);
    // A cube that came before this probe: say so once it is handed out (three.js listens to
    // 'reflectionchange' only, XREstimatedLight.js:44-50).
    if (conn.environment) setTimeout(() => { if (probes.has(probe)) tell(probe); }, 0);
    if (!watched.has(session) && typeof session.addEventListener === "function") {
      watched.add(session);
      session.addEventListener("end", () => {
        for (const p of probes) if (sessionOf.get(p) === session) probes.delete(p);
      });
    }
    return probe;
  }

  function requestLightProbe(init = {}) {
    const native = opts.force ? "no" : nativeLightEstimation(this);
    if (native === "yes") return nativeRequest.call(this, init);
    if (native === "unknown") return nativeRequest.call(this, init).catch(() => ourProbe(this, init));
    return ourProbe(this, init);
  }
  requestLightProbe.shlightPolyfill = true;

  function getLightEstimate(probe) {
    if (!(probe instanceof ShlightLightProbe)) {
      if (typeof nativeEstimate === "function") return nativeEstimate.call(this, probe);
      throw new TypeError("getLightEstimate: the argument is not an XRLightProbe");
    }
    if (sessionOf.get(probe) !== this.session) {
      throw new DOMException("the probe belongs to another session", "InvalidStateError");
    }
    return handle.estimate();                // null until the provider's first lighting
  }

  function patch(proto, name, value) {
    const own = Object.getOwnPropertyDescriptor(proto, name);
    Object.defineProperty(proto, name, { value, writable: true, configurable: true, enumerable: false });
    restore.push(() => (own ? Object.defineProperty(proto, name, own) : delete proto[name]));
  }

  patch(sessionProto, "requestLightProbe", requestLightProbe);
  patch(frameProto, "getLightEstimate", getLightEstimate);
  if (!("preferredReflectionFormat" in sessionProto)) {
    Object.defineProperty(sessionProto, "preferredReflectionFormat",
      { get: () => "srgba8", configurable: true, enumerable: false });
    restore.push(() => delete sessionProto.preferredReflectionFormat);
  }
  if (typeof BindingClass === "function") {
    // XREstimatedLight(renderer, true) asks for a cube map at each 'reflectionchange'
    // (XREstimatedLight.js:44-50, 66): the provider's cube for our probes.
    const nativeCube = BindingClass.prototype.getReflectionCubeMap;
    patch(BindingClass.prototype, "getReflectionCubeMap", function (probe) {
      if (probe instanceof ShlightLightProbe) return reflectionCubeMap(this);
      return nativeCube.call(this, probe);
    });
    handle.XRWebGLBinding = new Proxy(BindingClass, {
      construct(target, args, newTarget) {
        const binding = Reflect.construct(target, args, newTarget === handle.XRWebGLBinding ? target : newTarget);
        if (args[1]) glOf.set(binding, args[1]);
        return binding;
      },
    });
    if (g.XRWebGLBinding === BindingClass) {
      g.XRWebGLBinding = handle.XRWebGLBinding;
      restore.push(() => { if (g.XRWebGLBinding === handle.XRWebGLBinding) g.XRWebGLBinding = BindingClass; });
    }
  }

  /** The binding's cube texture, filled with the newest cube (in the reference space). */
  function reflectionCubeMap(binding) {
    const cube = conn && conn.environment, gl = glOf.get(binding) || opts.gl;
    if (!cube || !gl) return null;
    let held = cubeOf.get(binding);
    if (held && held.version === cubeVersion && held.cube === cube) return held.texture;
    if (!held) { held = { texture: gl.createTexture(), version: -1, cube: null }; cubeOf.set(binding, held); }
    const faces = rotation ? resampleCube(cube, cube.size, { rotation: transpose(rotation) }) : cube.floatFaces(0);
    handle.cubeFormat = uploadCube(gl, held.texture, cube.size, faces);
    held.version = cubeVersion;
    held.cube = cube;
    return held.texture;
  }
  if (xr && typeof xr.requestSession === "function") {
    const nativeSession = xr.requestSession;
    const own = Object.prototype.hasOwnProperty.call(xr, "requestSession");
    const send = Boolean(pt && pt.send);
    xr.requestSession = function (mode, init) {
      const started = nativeSession.call(this, mode, relaxFeatures(init, opts.force, send));
      return send ? started.then((session) => { handle.sendCamera(session); return session; }) : started;
    };
    restore.push(() => (own ? (xr.requestSession = nativeSession) : delete xr.requestSession));
  }
  handle.installed = true;
  return handle;
}

function transpose(R) {
  return [R[0], R[3], R[6], R[1], R[4], R[7], R[2], R[5], R[8]];
}

/** float32 → IEEE half (uint16), round to nearest even; beyond ±65504: ±65504. */
function toHalf(v) {
  const f = new Float32Array(1), u = new Uint32Array(f.buffer);
  f[0] = Math.max(-65504, Math.min(65504, v));
  const x = u[0], sign = (x >>> 16) & 0x8000, e = ((x >>> 23) & 0xff) - 127 + 15;
  let m = x & 0x7fffff;
  if (e <= 0) {                               // subnormal half (or 0)
    if (e < -10) return sign;
    m = (m | 0x800000) >>> (1 - e);
    return sign | ((m + 0xfff + ((m >>> 13) & 1)) >>> 13);
  }
  const h = (e << 10) | (m >>> 13), rest = m & 0x1fff;
  return sign | (h + (rest > 0x1000 || (rest === 0x1000 && (h & 1)) ? 1 : 0));
}

/**
 * Upload a cube's level 0 (6 Float32Array RGBA, face f at TEXTURE_CUBE_MAP_POSITIVE_X + f, row 0
 * first, no flip) into `texture` of `gl`, leaving the context's bindings and unpack state as
 * they were (three.js caches them). Returns the format used: "rgba16f" or "srgba8".
 */
function uploadCube(gl, texture, n, faces) {
  const webgl2 = typeof WebGL2RenderingContext !== "undefined" && gl instanceof WebGL2RenderingContext;
  const half = !webgl2 && gl.getExtension("OES_texture_half_float");
  if (!webgl2 && half) gl.getExtension("OES_texture_half_float_linear");
  const srgb = !webgl2 && !half && gl.getExtension("EXT_sRGB");
  const saved = { binding: gl.getParameter(gl.TEXTURE_BINDING_CUBE_MAP),
                  flip: gl.getParameter(gl.UNPACK_FLIP_Y_WEBGL), premultiply: gl.getParameter(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL),
                  alignment: gl.getParameter(gl.UNPACK_ALIGNMENT), colorspace: gl.getParameter(gl.UNPACK_COLORSPACE_CONVERSION_WEBGL) };
  const buffer = webgl2 && gl.getParameter(gl.PIXEL_UNPACK_BUFFER_BINDING);
  if (buffer) gl.bindBuffer(gl.PIXEL_UNPACK_BUFFER, null);
  gl.bindTexture(gl.TEXTURE_CUBE_MAP, texture);
  gl.pixelStorei(gl.UNPACK_FLIP_Y_WEBGL, false);
  gl.pixelStorei(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL, false);
  gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
  gl.pixelStorei(gl.UNPACK_COLORSPACE_CONVERSION_WEBGL, gl.NONE);
  let format = "rgba16f";
  for (let f = 0; f < 6; f++) {
    const target = gl.TEXTURE_CUBE_MAP_POSITIVE_X + f;
    if (webgl2) {
      gl.texImage2D(target, 0, gl.RGBA16F, n, n, 0, gl.RGBA, gl.FLOAT, faces[f]);
    } else if (half) {
      gl.texImage2D(target, 0, gl.RGBA, n, n, 0, gl.RGBA, half.HALF_FLOAT_OES, Uint16Array.from(faces[f], toHalf));
    } else {
      format = "srgba8";
      const enc = (v) => { v = Math.min(Math.max(v, 0), 1); return Math.round(255 * (v <= 0.0031308 ? 12.92 * v : 1.055 * v ** (1 / 2.4) - 0.055)); };
      const bytes = Uint8Array.from(faces[f], (v, i) => (i % 4 === 3 ? 255 : enc(v)));
      const fmt = srgb ? srgb.SRGB_ALPHA_EXT : gl.RGBA;
      gl.texImage2D(target, 0, fmt, n, n, 0, fmt, gl.UNSIGNED_BYTE, bytes);
    }
  }
  gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
  gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
  gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
  gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
  if (webgl2) gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_MAX_LEVEL, 0);
  gl.bindTexture(gl.TEXTURE_CUBE_MAP, saved.binding);
  gl.pixelStorei(gl.UNPACK_FLIP_Y_WEBGL, saved.flip);
  gl.pixelStorei(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL, saved.premultiply);
  gl.pixelStorei(gl.UNPACK_ALIGNMENT, saved.alignment);
  gl.pixelStorei(gl.UNPACK_COLORSPACE_CONVERSION_WEBGL, saved.colorspace);
  if (buffer) gl.bindBuffer(gl.PIXEL_UNPACK_BUFFER, buffer);
  return format;
}

/** A session init where "light-estimation" no longer stops the session from starting (and,
 *  with `camera`, that asks for raw camera access where the browser has it). */
function relaxFeatures(init, force, camera = false) {
  if (camera) {
    const listed = [...((init && init.requiredFeatures) || []), ...((init && init.optionalFeatures) || [])];
    if (!listed.includes("camera-access")) {
      init = { ...init, optionalFeatures: [...((init && init.optionalFeatures) || []), "camera-access"] };
    }
  }
  const required = (init && init.requiredFeatures) || [];
  const optional = (init && init.optionalFeatures) || [];
  const has = (list) => Array.from(list).includes(FEATURE);
  if (!(has(required) || (force && has(optional)))) return init;
  const drop = (list) => Array.from(list).filter((f) => f !== FEATURE);
  // force: the provider answers anyway, so the device need not estimate at all
  return { ...init, requiredFeatures: drop(required),
           optionalFeatures: force ? drop(optional) : [...drop(optional), FEATURE] };
}

/**
 * The XRLightProbe of a session answered by the polyfill. Not thenable (it resolves a
 * Promise: three.js's requestLightProbe().then(probe => ...) at XREstimatedLight.js:191-195).
 */
class ShlightLightProbe extends EventTarget {
  constructor(probeSpace) {
    super();
    /** the session's "local" space (null where it has none); the lighting is turned into
     * the reference space by yaw/rotation (module comment) */
    this.probeSpace = probeSpace;
    this.onreflectionchange = null;
  }
}
