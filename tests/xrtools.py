"""The WebXR polyfill tests' pages and scripts (tests/clients/three/test_xr_polyfill.py and the tests that
run the polyfill beside other clients): a real inline XRSession started as three's
WebXRManager starts one, an app page on another origin, and stand-ins shaped like Chromium's
for what needs an XR device."""
from __future__ import annotations

import json

from servertools import http_get, poll


#: Chromium's own console error when a page asks an inline session for light estimation.
INLINE_LE = r"Feature 'light-estimation' is not supported for mode: inline"


def webxr_latest(base: str, token: str | None = None) -> dict:
    """The server's latest message in the webxr layout (waiting for its first)."""
    url = base + "/latest.json?to=webxr" + (f"&token={token}" if token else "")
    status, _, body = poll(lambda: (r := http_get(url))[0] != 503 and r, what="first lighting")
    assert status == 200, body
    out = json.loads(body)
    assert out["format"] == "webxr"
    return out


START_SESSION = """async () => {
  const s = window.shlight;
  // A real XRSession: Chromium offers inline sessions with no XR device. It has no light
  // estimation (enabledFeatures ['viewer']; the browser's own requestLightProbe refuses).
  const session = await navigator.xr.requestSession("inline");
  // What three's WebXRManager.setSession does after a device made the WebGL context
  // XR-compatible (WebXRManager.js:409-532); with no device gl.makeXRCompatible() is refused,
  // so the test does the rest by hand: the session's base layer (an inline session draws
  // into the page's canvas) and the 'sessionstart' that XREstimatedLight listens to
  // (XREstimatedLight.js:185-231; WebXRManager.js:394 getSession, :532 the event).
  session.updateRenderState({ baseLayer: new XRWebGLLayer(session, s.renderer.getContext()) });
  s.renderer.xr.getSession = () => session;
  window.started = 0;
  s.xrLight.addEventListener("estimationstart", () => { window.started++; });
  s.renderer.xr.dispatchEvent({ type: "sessionstart" });
  window.session = session;
  window.probe = await session.requestLightProbe();
  window.reflections = 0;
  window.probe.addEventListener("reflectionchange", () => { window.reflections++; });
  return { features: Array.from(session.enabledFeatures), real: session instanceof XRSession,
           has: "requestLightProbe" in session, thenable: "then" in window.probe,
           isEventTarget: window.probe instanceof EventTarget,
           format: session.preferredReflectionFormat };
}"""


#: An app on another origin: imports the polyfill from the provider, three.js from its CDN.
APP_PAGE = """<!doctype html><meta charset="utf-8"><title>app</title>
<script type="importmap">{"imports": {
  "three": "https://cdn.jsdelivr.net/npm/three@VERSION/build/three.module.js",
  "three/addons/": "https://cdn.jsdelivr.net/npm/three@VERSION/examples/jsm/"}}</script>
<script type="module">
const q = new URLSearchParams(location.search);
window.m = await import(q.get("provider") + "/xr-lighting-polyfill.js");
window.THREE = await import("three");
window.XREstimatedLight = (await import("three/addons/webxr/XREstimatedLight.js")).XREstimatedLight;
window.ready = true;
</script>"""


STAND_INS = """() => {
  // A device's WebXR objects, shaped like Chromium's: a session whose light estimation the
  // browser grants or not, its frames, probes and XRWebGLBinding; a foreign probe is a
  // TypeError, as in Chromium ("parameter 1 is not of type 'XRLightProbe'").
  class NativeProbe extends EventTarget { constructor() { super(); this.probeSpace = null; } }
  const NATIVE = { sphericalHarmonicsCoefficients: new Float32Array(27).fill(0.25),
                   primaryLightDirection: new DOMPointReadOnly(0, 0, 1, 0),
                   primaryLightIntensity: new DOMPointReadOnly(2, 2, 2, 1) };
  const foreign = () => new TypeError("parameter 1 is not of type 'XRLightProbe'");
  class Session extends EventTarget {
    // features: enabledFeatures (undefined: a browser that does not say); grants: whether
    // the browser's own requestLightProbe answers
    constructor(features, grants) {
      super();
      if (features) this.enabledFeatures = Object.freeze(features);
      this.grants = grants; this.nativeCalls = 0; this.callbacks = [];
    }
    get preferredReflectionFormat() { return "srgba8"; }
    requestLightProbe(init) {
      this.nativeCalls++;
      return this.grants ? Promise.resolve(new NativeProbe()) : Promise.reject(
        new DOMException("Session does not support feature light-estimation", "NotSupportedError"));
    }
    requestReferenceSpace(type) { return Promise.resolve({ type }); }
    requestAnimationFrame(cb) { this.callbacks.push(cb); return this.callbacks.length; }
    frame() {                                   // the device's next frame
      const f = new Frame(this);
      for (const cb of this.callbacks.splice(0)) cb(performance.now(), f);
      return f;
    }
  }
  class Frame {
    constructor(session) { this.session = session; }
    getLightEstimate(probe) { if (!(probe instanceof NativeProbe)) throw foreign(); return NATIVE; }
  }
  class Binding {
    constructor(session, gl) { Binding.made++; }
    getReflectionCubeMap(probe) { if (!(probe instanceof NativeProbe)) throw foreign(); return null; }
  }
  Binding.made = 0;
  const xr = { inits: [], requestSession(mode, init) { this.inits.push(init); return Promise.resolve(new Session([], false)); } };
  const originals = [Session.prototype.requestLightProbe, Frame.prototype.getLightEstimate,
                     Binding.prototype.getReflectionCubeMap, xr.requestSession];
  // three's XREstimatedLight on a session: a real WebGLRenderer whose renderer.xr says
  // 'sessionstart' as WebXRManager.setSession does (WebXRManager.js:394, :532).
  function estimatedLight(session, environment = false) {
    const renderer = new THREE.WebGLRenderer();
    const light = new XREstimatedLight(renderer, environment);
    light.started = false;
    light.addEventListener("estimationstart", () => { light.started = true; });
    renderer.xr.getSession = () => session;
    renderer.xr.dispatchEvent({ type: "sessionstart" });
    return light;
  }
  const held = (light) => ({
    sh: light.lightProbe.sh.coefficients.flatMap((v) => [v.x, v.y, v.z]),
    light: light.directionalLight.intensity * light.directionalLight.color.r,
    position: light.directionalLight.position.toArray(), started: light.started });
  window.standIn = { Session, Frame, Binding, NativeProbe, NATIVE, xr, estimatedLight, held,
                     originals, lights: {}, sessions: {} };
}"""
