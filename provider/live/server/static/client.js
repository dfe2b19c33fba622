// shlight browser client: live SH9 lighting from `shlight serve`, as an ES module.
// Served by the provider at /client.js (no build step, no dependencies):
//
//   import { connect } from "http://HOST:8765/client.js";
//   const conn = connect("ws://HOST:8765/", {
//     probe: "room", token: "SECRET", maxHz: 30,
//     onLighting: (lighting, conn) => { ... lighting.matrices, lighting.coefficients ... },
//     onState: (state, detail) => { ... "connecting" | "live" | "stale" | "down" | "closed" },
//   });
//   conn.latest;  conn.state;  conn.close();
//
// The wire protocol is the module docstring of provider/live/server/service.py; the message is
// docs/contract.md §3. Frame: right-handed, +Y up (as three.js and WebXR). A `Lighting` holds
//   coefficients  Float32Array(27): raw radiance SH, L00.rgb, L1-1.rgb, L10, L11, L2-2, L2-1,
//                 L20, L21, L22 (not convolved, not divided by π)
//   matrices      Float32Array(48): M_red, M_green, M_blue, 4×4 row-major (symmetric):
//                 irradiance E(n) = [n,1]ᵀ M [n,1]; a surface of albedo ρ shows ρE/π
//   probe, seq, time (unix s of the frame), stale, message (the JSON as received),
//   receivedAt (performance.now() on arrival).
//
// Extension points (for format conversions and polyfills built on top):
//   options.subscribe: extra fields merged into the subscribe message sent after each
//                      hello (e.g. {to: "webxr"}: another engine's layout);
//   options.decode(msg): turn an "sh9" or "export" message into the Lighting handed out,
//                      or null to skip it (default decodeLighting: "sh9" only; it needs
//                      probe, stale and receivedAt); options.onMessage(msg): every message, raw;
//   options.WebSocket: the WebSocket class (default: the browser's).
//
// Reflection cubes (`shlight serve --environment`, docs/contract.md §12): with
// options.environment = true the client subscribes with {"environment": true}; each cube
// (an `environment` JSON message, then its KTX2 file as one binary frame) becomes an
// `EnvironmentCube` (parseEnvironmentKtx2) handed to options.onEnvironment(cube, conn) and
// kept in conn.environment (the subscribed probe's newest) and conn.environments (per probe):
//   size, mipCount, roughness[k] (= k/(mipCount−1)), frame "rh-y-up", probe, seq, sh9Seq, time,
//   units, exposure (the KTX2 key/values), keyValues (all of them), message (the JSON),
//   mips[k] = { size: n, faces: [6 × Uint16Array(n·n·4)] }: half floats, R G B A, faces
//     +X −X +Y −Y +Z −Z, rows from t = 0, uploadable as they are (TEXTURE_CUBE_MAP_POSITIVE_X + f,
//     level k, RGBA16F, HALF_FLOAT, no flip);
//   floatFaces(k) → [6 × Float32Array(n·n·4)] (the same texels as float32).
// Registration (docs/contract.md §13): registrationRotation(worldFromMarker, cameraFromMarker)
// composes R_world←camera = R_world←marker · R_camera←markerᵀ for rotateCoefficients.

export const FRAME = "rh-y-up";

// docs/contract.md §2 constants of the irradiance matrix.
const C1 = 0.429043, C2 = 0.511664, C3 = 0.743125, C4 = 0.886227, C5 = 0.247708;

/** A Lighting from an "sh9" wire message (null if it is not a valid one). */
export function decodeLighting(msg) {
  if (!msg || msg.type !== "sh9" || !Array.isArray(msg.coefficients) ||
      msg.coefficients.length !== 27 || !Array.isArray(msg.matrices) ||
      msg.matrices.length !== 48) return null;
  const coefficients = Float32Array.from(msg.coefficients);
  const matrices = Float32Array.from(msg.matrices);
  if (!coefficients.every(Number.isFinite) || !matrices.every(Number.isFinite)) return null;
  return {
    probe: String(msg.probe), seq: +msg.seq, time: +msg.time, stale: msg.stale === true,
    ageS: +msg.age_s || 0, coefficients, matrices, message: msg,
    receivedAt: typeof performance !== "undefined" ? performance.now() : Date.now(),
  };
}

/** The three 4×4 irradiance matrices (Float32Array(48)) of 27 radiance coefficients. */
export function matricesFromCoefficients(coefficients) {
  const out = new Float32Array(48);
  for (let c = 0; c < 3; c++) {
    const L = (k) => coefficients[3 * k + c];
    const m = [
      C1 * L(8), C1 * L(4), C1 * L(7), C2 * L(3),
      C1 * L(4), -C1 * L(8), C1 * L(5), C2 * L(1),
      C1 * L(7), C1 * L(5), C3 * L(6), C2 * L(2),
      C2 * L(3), C2 * L(1), C2 * L(2), C4 * L(0) - C5 * L(6)];
    out.set(m, 16 * c);
  }
  return out;
}

/** Irradiance [r, g, b] at unit normal n = [x, y, z]: E(n) = ñᵀMñ (not clamped). */
export function irradiance(matrices, n) {
  const v = [n[0], n[1], n[2], 1];
  const out = [0, 0, 0];
  for (let c = 0; c < 3; c++) {
    let e = 0;
    for (let i = 0; i < 4; i++) {
      for (let j = 0; j < 4; j++) e += v[i] * matrices[16 * c + 4 * i + j] * v[j];
    }
    out[c] = e;
  }
  return out;
}

/**
 * The coefficients of the environment turned by the rotation R (9 numbers, row-major
 * 3×3: a direction d of the provider's frame is R·d in yours), exactly: through the
 * matrices, M' = R̃ M R̃ᵀ (docs/contract.md §2), then back to coefficients (the quadratic form on
 * the unit sphere fixes them: traceless part → band 2, trace → band 0).
 */
export function rotateCoefficients(coefficients, R) {
  const out = new Float32Array(27);
  const mats = matricesFromCoefficients(coefficients);
  for (let c = 0; c < 3; c++) {
    const M = (i, j) => mats[16 * c + 4 * i + j];
    // A' = R A Rᵀ (3×3 block), b' = R b (the linear part), m' = m.
    const A = [];
    for (let i = 0; i < 3; i++) {
      A.push([]);
      for (let j = 0; j < 3; j++) {
        let s = 0;
        for (let k = 0; k < 3; k++) {
          for (let l = 0; l < 3; l++) s += R[3 * i + k] * M(k, l) * R[3 * j + l];
        }
        A[i].push(s);
      }
    }
    const b = [0, 1, 2].map((i) => R[3 * i] * M(0, 3) + R[3 * i + 1] * M(1, 3) + R[3 * i + 2] * M(2, 3));
    const trace3 = (A[0][0] + A[1][1] + A[2][2]) / 3;
    const T = (i, j) => A[i][j] - (i === j ? trace3 : 0);      // traceless part
    const L = new Array(9);
    L[6] = 1.5 * T(2, 2) / C3;                                  // L20
    L[8] = (T(0, 0) - T(1, 1)) / (2 * C1);                      // L22
    L[4] = T(0, 1) / C1; L[7] = T(0, 2) / C1; L[5] = T(1, 2) / C1;
    L[3] = b[0] / C2; L[1] = b[1] / C2; L[2] = b[2] / C2;
    L[0] = (M(3, 3) + trace3) / C4;              // c3/3 = c5: band 0 keeps the trace
    for (let k = 0; k < 9; k++) out[3 * k + c] = L[k];
  }
  return out;
}

/** Is this lighting stale now? (The server says so, or nothing came for too long.) */
function silentTooLong(lighting, hello, now) {
  const keepalive = +(hello && hello.keepalive_s) || 1.0;
  const staleAfter = +(hello && hello.stale_after_s) || 2.0;
  return now - lighting.receivedAt > 1000 * (2 * keepalive + staleAfter);
}

/**
 * Connect to a provider. `url`: "ws://HOST:8765/" or "wss://..." (http(s):// is accepted
 * and turned into ws(s)://). Returns a connection that reconnects by itself (backoff from
 * retryMin to retryMax seconds) until close().
 */
export function connect(url, options = {}) {
  const opts = {
    probe: "*", token: null, maxHz: 0, retryMin: 0.5, retryMax: 10,
    onLighting: null, onState: null, onMessage: null, subscribe: null,
    environment: false, onEnvironment: null,
    decode: decodeLighting, WebSocket: globalThis.WebSocket, ...options,
  };
  const target = new URL(url, typeof location !== "undefined" ? location.href : undefined);
  if (target.protocol === "http:") target.protocol = "ws:";
  if (target.protocol === "https:") target.protocol = "wss:";
  if (opts.probe && opts.probe !== "*") target.searchParams.set("probe", opts.probe);
  if (opts.maxHz > 0) target.searchParams.set("max_hz", String(opts.maxHz));
  if (opts.token) target.searchParams.set("token", opts.token);

  let ws = null, retry = opts.retryMin, retryTimer = null, staleTimer = null, closed = false;
  let pingId = 0;
  const pings = new Map();

  const conn = {
    url: target.href,
    /** "connecting" | "live" | "stale" | "down" | "closed" */
    state: "connecting",
    /** the detail of the state ("retrying in 2 s", "close 1008", ...) */
    detail: "",
    /** the hello message of the current connection (probes, keepalive_s, ...) */
    hello: null,
    /** the newest Lighting of the subscribed probe (with "*": of any probe) */
    latest: null,
    /** probe name → its newest Lighting */
    probes: new Map(),
    /** the newest EnvironmentCube of the subscribed probe (options.environment), or null */
    environment: null,
    /** probe name → its newest EnvironmentCube */
    environments: new Map(),
    /** is the lighting stale now (server says so, silence, or no connection)? */
    get stale() {
      return !conn.hello || lightingStale();
    },
    /** change the subscription ({type: "subscribe"}; fields left out keep their value) */
    subscribe(probe, maxHz) {
      if (probe !== undefined) opts.probe = probe;
      if (maxHz !== undefined) opts.maxHz = maxHz;
      send({ type: "subscribe", probe: opts.probe || "*", max_hz: +opts.maxHz || 0,
             ...(opts.environment && hasCubes() ? { environment: true } : {}),
             ...(opts.subscribe || {}) });
    },
    /** round trip to the server in ms (resolves on the pong) */
    ping() {
      return new Promise((resolve, reject) => {
        const id = ++pingId;
        const t0 = performance.now();
        pings.set(id, (pong) => resolve({ rttMs: performance.now() - t0, serverTime: pong.time }));
        if (!send({ type: "ping", id })) { pings.delete(id); reject(new Error("not connected")); }
      });
    },
    close() {
      closed = true;
      clearTimeout(retryTimer);
      clearInterval(staleTimer);
      if (ws) ws.close(1000, "client closed");
      ws = null;
      setState("closed", "");
    },
  };

  // Cubes are asked for only where a probe makes them (hello lists them), so that a provider
  // without --environment answers no `environment_off` error.
  function hasCubes() {
    const list = conn.hello && conn.hello.environment;
    return Array.isArray(list) && list.length > 0;
  }

  function setState(state, detail) {
    if (state === conn.state && detail === conn.detail) return;
    conn.state = state;
    conn.detail = detail;
    if (opts.onState) opts.onState(state, detail, conn);
  }

  function send(obj) {
    if (ws && ws.readyState === 1) { ws.send(JSON.stringify(obj)); return true; }
    return false;
  }

  function open() {
    if (closed) return;
    setState("connecting", "");
    let socket;
    try {
      socket = new opts.WebSocket(target.href);
    } catch (err) {
      scheduleReconnect(String(err));
      return;
    }
    ws = socket;
    socket.binaryType = "arraybuffer";
    let announced = null;                    // the `environment` message of the next binary frame
    socket.onmessage = (ev) => {
      if (typeof ev.data !== "string") {
        const header = announced;
        announced = null;
        if (header && ev.data instanceof ArrayBuffer) onCube(header, ev.data);
        return;
      }
      let msg;
      try { msg = JSON.parse(ev.data); } catch (err) { return; }
      if (msg && typeof msg === "object") {
        if (msg.type === "environment") announced = msg;
        onMessage(msg);
      }
    };
    socket.onclose = (ev) => {
      if (ws !== socket) return;
      ws = null;
      conn.hello = null;
      scheduleReconnect(ev.code && ev.code !== 1006 ? `close ${ev.code}` : "");
    };
  }

  function scheduleReconnect(why) {
    if (closed) return;
    const wait = retry;
    retry = Math.min(retry * 2, opts.retryMax);
    setState("down", `${why ? why + ", " : ""}retrying in ${wait} s`);
    retryTimer = setTimeout(open, wait * 1000);
  }

  function onMessage(msg) {
    if (opts.onMessage) opts.onMessage(msg, conn);
    if (msg.type === "hello") {
      conn.hello = msg;
      retry = opts.retryMin;
      if (opts.subscribe || opts.environment) conn.subscribe();
      setState(conn.latest && conn.latest.stale ? "stale" : "live", "");
    } else if (msg.type === "sh9" || msg.type === "export") {
      // "export": another engine's layout (subscribe {to: FORMAT}); the default decode
      // takes "sh9" only, a decode for the format (e.g. the WebXR polyfill's) the exports
      const lighting = opts.decode(msg);
      if (!lighting) return;
      conn.probes.set(lighting.probe, lighting);
      if (opts.probe && opts.probe !== "*" && lighting.probe !== opts.probe) return;
      conn.latest = lighting;
      checkStale();
      if (opts.onLighting) opts.onLighting(lighting, conn);
    } else if (msg.type === "pong") {
      const done = pings.get(msg.id);
      if (done) { pings.delete(msg.id); done(msg); }
    }
  }

  function onCube(header, buffer) {
    if (buffer.byteLength !== +header.byte_length) return;
    let cube;
    try {
      cube = parseEnvironmentKtx2(buffer, header);
    } catch (err) {
      console.warn(`shlight client: cannot read the reflection cube: ${err.message}`);
      return;
    }
    conn.environments.set(cube.probe, cube);
    if (opts.probe && opts.probe !== "*" && cube.probe !== opts.probe) return;
    conn.environment = cube;
    if (opts.onEnvironment) opts.onEnvironment(cube, conn);
  }

  function lightingStale() {
    const l = conn.latest;
    if (!l) return true;
    const now = typeof performance !== "undefined" ? performance.now() : Date.now();
    return l.stale || silentTooLong(l, conn.hello, now);
  }

  function checkStale() {
    if (!conn.hello || !conn.latest) return;   // down or connecting: that state says more
    const stale = lightingStale();
    setState(stale ? "stale" : "live",
      !stale ? "" : conn.latest.stale ? "the provider lost its source" : "no lighting lately");
  }

  staleTimer = setInterval(checkStale, 250);
  open();
  return conn;
}

// ---- reflection cubes (docs/contract.md §12, "Transport") ------------------------------

const KTX2_IDENTIFIER = [0xab, 0x4b, 0x54, 0x58, 0x20, 0x32, 0x30, 0xbb, 0x0d, 0x0a, 0x1a, 0x0a];
const VK_FORMAT_R16G16B16A16_SFLOAT = 97;

/** The float value of an IEEE 754 half float (as a uint16). */
export function halfToFloat(h) {
  const e = (h >> 10) & 0x1f, m = h & 0x3ff, sign = h & 0x8000 ? -1 : 1;
  if (e === 0) return sign * m * 2 ** -24;
  if (e === 31) return m ? NaN : sign * Infinity;
  return sign * (1 + m / 1024) * 2 ** (e - 15);
}

function keyValues(dv, offset, length) {
  const out = {};
  const bytes = new Uint8Array(dv.buffer, dv.byteOffset + offset, length);
  const text = new TextDecoder();
  let p = 0;
  while (p + 4 <= length) {
    const n = dv.getUint32(offset + p, true);
    const entry = bytes.subarray(p + 4, p + 4 + n);
    const nul = entry.indexOf(0);
    if (nul > 0) {
      let value = entry.subarray(nul + 1);
      if (value.length && value[value.length - 1] === 0) value = value.subarray(0, value.length - 1);
      out[text.decode(entry.subarray(0, nul))] = text.decode(value);
    }
    p += 4 + n + ((4 - (n % 4)) % 4);
  }
  return out;
}

/**
 * An EnvironmentCube (see the module comment) from the bytes of the provider's KTX2 file
 * (the WebSocket's binary frame, /environment.ktx2, the MQTT payload); `message`: the
 * `environment` JSON that announced it, if any. Throws an Error saying what is wrong with
 * anything but an uncompressed RGBA16F cube with its mips.
 */
export function parseEnvironmentKtx2(buffer, message = null) {
  const bytes = buffer instanceof ArrayBuffer ? buffer : buffer.buffer.slice(
    buffer.byteOffset, buffer.byteOffset + buffer.byteLength);
  if (bytes.byteLength < 80) throw new Error("not a KTX2 file (too short)");
  const dv = new DataView(bytes);
  for (let i = 0; i < 12; i++) {
    if (dv.getUint8(i) !== KTX2_IDENTIFIER[i]) throw new Error("not a KTX2 file");
  }
  const u32 = (o) => dv.getUint32(o, true), u64 = (o) => Number(dv.getBigUint64(o, true));
  const size = u32(20), faces = u32(36), levels = u32(40);
  if (u32(12) !== VK_FORMAT_R16G16B16A16_SFLOAT || u32(16) !== 2) throw new Error("not RGBA16F");
  if (faces !== 6 || u32(24) !== size || u32(28) !== 0 || u32(32) !== 0) throw new Error("not a cube");
  if (u32(44) !== 0) throw new Error("supercompressed");
  if (!(size >= 2 && (size & (size - 1)) === 0 && levels >= 1 && size >> (levels - 1) >= 1)) {
    throw new Error(`bad size ${size} or level count ${levels}`);
  }
  if (bytes.byteLength < 80 + 24 * levels) throw new Error("truncated level index");
  const mips = [];
  for (let k = 0; k < levels; k++) {
    const n = size >> k, offset = u64(80 + 24 * k), length = u64(88 + 24 * k), face = n * n * 4;
    if (length !== 6 * face * 2 || offset + length > bytes.byteLength || offset % 2) {
      throw new Error(`level ${k}: ${length} bytes at ${offset}, expected ${6 * face * 2}`);
    }
    const all = new Uint16Array(bytes, offset, 6 * face);
    mips.push({ size: n, faces: [0, 1, 2, 3, 4, 5].map((f) => all.subarray(f * face, (f + 1) * face)) });
  }
  const kv = keyValues(dv, u32(56), u32(60));
  const json = (key, fallback) => { try { return JSON.parse(kv[key]); } catch (err) { return fallback; } };
  const m = message || {};
  return {
    size, mipCount: levels, mips, keyValues: kv, message,
    roughness: Array.isArray(m.roughness) ? m.roughness.map(Number)
      : json("shlight.roughness", mips.map((_, k) => (levels > 1 ? k / (levels - 1) : 0))),
    frame: kv["shlight.frame"] || m.frame || FRAME,
    probe: String(m.probe ?? kv["shlight.probe"] ?? "default"),
    seq: +(m.seq ?? kv["shlight.seq"] ?? 0), sh9Seq: +(m.sh9_seq ?? kv["shlight.sh9_seq"] ?? 0),
    time: +(m.time ?? kv["shlight.time"] ?? 0), units: m.units ?? kv["shlight.units"] ?? null,
    exposure: json("shlight.exposure", null),
    receivedAt: typeof performance !== "undefined" ? performance.now() : Date.now(),
    /** mip k's six faces as Float32Array(n·n·4) (R G B A), decoded from the half floats */
    floatFaces(k) {
      return this.mips[k].faces.map((h) => Float32Array.from(h, halfToFloat));
    },
  };
}

// ---- sampling a cube as textureLod does (seamless bilinear, linear between mips) -------

/** Unit-less direction of face coordinates sc, tc ∈ [−1, 1] (beyond: off the face) on face f
 * (docs/contract.md §12: the OpenGL table in our frame). */
export function faceDirection(f, sc, tc) {
  switch (f) {
    case 0: return [1, -tc, -sc];
    case 1: return [-1, -tc, sc];
    case 2: return [sc, 1, tc];
    case 3: return [sc, -1, -tc];
    case 4: return [sc, -tc, 1];
    default: return [-sc, -tc, -1];
  }
}

/** [face, s, t] of a direction (s → column, t → row, in [0, 1]). */
export function directionToFace(d) {
  const ax = Math.abs(d[0]), ay = Math.abs(d[1]), az = Math.abs(d[2]);
  let f, sc, tc, ma;
  if (ax >= ay && ax >= az) { ma = ax; f = d[0] >= 0 ? 0 : 1; sc = d[0] >= 0 ? -d[2] : d[2]; tc = -d[1]; }
  else if (ay >= az) { ma = ay; f = d[1] >= 0 ? 2 : 3; sc = d[0]; tc = d[1] >= 0 ? d[2] : -d[2]; }
  else { ma = az; f = d[2] >= 0 ? 4 : 5; sc = d[2] >= 0 ? d[0] : -d[0]; tc = -d[1]; }
  return [f, (sc / ma + 1) / 2, (tc / ma + 1) / 2];
}

/** Texel (f, i, j) of an n×n mip (faces: 6 Float32Array RGBA) into out[0..3]; a texel off the
 * face's edge is the one across it (the direction of its centre, on the adjacent face). */
function texel(faces, n, f, i, j, w, out) {
  if (i < 0 || j < 0 || i >= n || j >= n) {
    const [g, s, t] = directionToFace(faceDirection(f, (2 * (j + 0.5)) / n - 1, (2 * (i + 0.5)) / n - 1));
    f = g;
    i = Math.min(n - 1, Math.max(0, Math.floor(t * n)));
    j = Math.min(n - 1, Math.max(0, Math.floor(s * n)));
  }
  const o = 4 * (i * n + j), face = faces[f];
  for (let c = 0; c < 4; c++) out[c] += w * face[o + c];
}

/** Bilinear (seamless) value of an n×n mip toward d, times w, added to out. */
export function bilinear(faces, n, d, w, out) {
  const [f, s, t] = directionToFace(d);
  const x = s * n - 0.5, y = t * n - 0.5, j0 = Math.floor(x), i0 = Math.floor(y);
  const fx = x - j0, fy = y - i0;
  texel(faces, n, f, i0, j0, w * (1 - fx) * (1 - fy), out);
  texel(faces, n, f, i0, j0 + 1, w * fx * (1 - fy), out);
  texel(faces, n, f, i0 + 1, j0, w * (1 - fx) * fy, out);
  texel(faces, n, f, i0 + 1, j0 + 1, w * fx * fy, out);
}

/**
 * A cube resampled: face size `size`, each texel the source (an EnvironmentCube) read as
 * textureLod does at `lod` toward R·d (R row-major 3×3, null: d itself), d the texel's
 * direction. Returns 6 Float32Array(size·size·4). `floats`: cube.floatFaces per mip, if at hand.
 */
export function resampleCube(cube, size, { lod = 0, rotation = null, floats = null } = {}) {
  floats = floats || cube.mips.map((_, k) => cube.floatFaces(k));
  const last = cube.mipCount - 1, R = rotation, acc = [0, 0, 0, 0];
  const k0 = Math.min(Math.floor(lod + 1e-9), last), k1 = Math.min(k0 + 1, last);
  const w = Math.min(Math.max(lod - k0, 0), 1);
  const faces = [];
  for (let f = 0; f < 6; f++) {
    const out = new Float32Array(size * size * 4);
    for (let i = 0; i < size; i++) {
      for (let j = 0; j < size; j++) {
        let d = faceDirection(f, (2 * (j + 0.5)) / size - 1, (2 * (i + 0.5)) / size - 1);
        if (R) d = [R[0] * d[0] + R[1] * d[1] + R[2] * d[2], R[3] * d[0] + R[4] * d[1] + R[5] * d[2],
                    R[6] * d[0] + R[7] * d[1] + R[8] * d[2]];
        acc.fill(0);
        bilinear(floats[k0], cube.size >> k0, d, 1 - w, acc);
        if (w > 0) bilinear(floats[k1], cube.size >> k1, d, w, acc);
        out.set(acc, 4 * (i * size + j));
      }
    }
    faces.push(out);
  }
  return faces;
}

// ---- registration (docs/contract.md §13) ---------------------------------------------

/**
 * A row-major 3×3 rotation (9 numbers) from what a tracker gives: 9 numbers (row-major),
 * 16 numbers (a column-major 4×4 pose, as XRRigidTransform.matrix, THREE.Matrix4.elements),
 * an object with `matrix` (XRRigidTransform) or `orientation` {x, y, z, w} (a unit quaternion,
 * XRRigidTransform.orientation), or a quaternion {x, y, z, w} itself.
 */
export function rotationOf(pose) {
  if (pose && pose.orientation) pose = pose.orientation;
  else if (pose && pose.matrix) pose = pose.matrix;
  if (pose && typeof pose === "object" && "w" in pose && "x" in pose) {
    let { x, y, z, w } = pose;
    const n = Math.hypot(x, y, z, w);
    if (!(n > 0)) throw new RangeError("rotationOf: a zero quaternion");
    x /= n; y /= n; z /= n; w /= n;
    return [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
            2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
            2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)];
  }
  const m = pose ? Array.from(pose, Number) : [];
  if (m.length === 9 && m.every(Number.isFinite)) return m;
  if (m.length === 16 && m.every(Number.isFinite)) {
    return [m[0], m[4], m[8], m[1], m[5], m[9], m[2], m[6], m[10]];   // column-major 4×4
  }
  throw new TypeError("rotationOf: expected 9 or 16 numbers, a quaternion or an XRRigidTransform");
}

/**
 * Marker axes of a tracker → OpenCV's ArUco axes (x printed right, y printed up, z out of the
 * printed face; docs/contract.md §13): R_trackerMarker←arucoMarker, row-major.
 *   "aruco"  the same axes (OpenCV, Vuforia-like trackers that report them so);
 *   "y-normal" a tracker whose image lies in its XZ plane, +X toward the image's right,
 *            +Z toward its bottom, so +Y out of the printed face: as OpenXR's
 *            XR_ANDROID_trackables_image documents its centerPose (XrTrackableImageANDROID);
 *            other trackers (WebXR image tracking's imageSpace, ARCore/AR Foundation images)
 *            say in their own documentation which axes they use: pass 9 numbers for others.
 */
export const MARKER_AXES = {
  aruco: [1, 0, 0, 0, 1, 0, 0, 0, 1],
  "y-normal": [1, 0, 0, 0, 0, 1, 0, -1, 0],
};

function mul3(a, b) {
  const out = new Array(9).fill(0);
  for (let i = 0; i < 3; i++) {
    for (let j = 0; j < 3; j++) {
      for (let k = 0; k < 3; k++) out[3 * i + j] += a[3 * i + k] * b[3 * k + j];
    }
  }
  return out;
}

function transpose3(a) {
  return [a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8]];
}

/**
 * R_world←camera = R_world←marker · R_camera←markerᵀ (docs/contract.md §13), row-major: the
 * rotation that turns the provider's lighting (the camera's frame) into the headset's world.
 * `worldFromMarker`: the marker's pose from the headset's tracker (anything rotationOf takes);
 * `cameraFromMarker`: the sh9 message's `registration` (or its `rotation`, 9 numbers);
 * `markerAxes`: how the tracker's marker axes relate to ArUco's (a MARKER_AXES key or 9 numbers).
 */
export function registrationRotation(worldFromMarker, cameraFromMarker, { markerAxes = "aruco" } = {}) {
  const cm = rotationOf(cameraFromMarker && cameraFromMarker.rotation ? cameraFromMarker.rotation
    : cameraFromMarker);
  const axes = typeof markerAxes === "string" ? MARKER_AXES[markerAxes] : rotationOf(markerAxes);
  if (!axes) throw new RangeError(`registrationRotation: unknown markerAxes ${markerAxes}`);
  const wm = mul3(rotationOf(worldFromMarker), axes);
  return mul3(wm, transpose3(cm));
}
