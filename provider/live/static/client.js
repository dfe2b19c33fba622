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
// The wire protocol is the module docstring of provider/live/server.py; the message is
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
    /** is the lighting stale now (server says so, silence, or no connection)? */
    get stale() {
      return !conn.hello || lightingStale();
    },
    /** change the subscription ({type: "subscribe"}; fields left out keep their value) */
    subscribe(probe, maxHz) {
      if (probe !== undefined) opts.probe = probe;
      if (maxHz !== undefined) opts.maxHz = maxHz;
      send({ type: "subscribe", probe: opts.probe || "*", max_hz: +opts.maxHz || 0,
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
    socket.onmessage = (ev) => {
      let msg;
      try { msg = JSON.parse(ev.data); } catch (err) { return; }
      if (msg && typeof msg === "object") onMessage(msg);
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
      if (opts.subscribe) conn.subscribe();
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
