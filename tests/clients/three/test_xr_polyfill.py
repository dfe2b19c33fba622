"""The WebXR lighting-estimation polyfill (/xr-lighting-polyfill.js) in a real headless
Chromium against a live ``shlight serve``, driving three.js's own XREstimatedLight (r187,
tests/node/node_modules).

Only the XR device is stood in. Chromium offers real ``inline`` XRSessions without one, and
those have no light estimation (the browser's own requestLightProbe refuses them): the
example page's XREstimatedLight, on such a session, gets the provider's lighting through
the polyfill, and the estimate equals the server's ``webxr`` export. What needs a device
(a session with the browser's own light estimation, immersive sessions, XRWebGLBinding on
them) is a stand-in class shaped like Chromium's, patched by the polyfill as the real ones
are.
"""
from __future__ import annotations

import json
import math

import numpy as np

import provider
from provider.core.conventions import formats as cv
from provider.core.geometry import sh

from browsertools import (NEEDS_BROWSER, REFUSED, PageHost, browser, canvas_rgba, f32,  # noqa: F401
                          page_of, sphere_row, srgb8, three_version, write_hemisphere)
from servertools import ServeProcess, http_get
from xrtools import APP_PAGE, INLINE_LE, STAND_INS, START_SESSION, webxr_latest

pytestmark = NEEDS_BROWSER

WARNING = "shlight polyfill: cannot reach the lighting provider"
YAW90 = np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]], float)      # yawRotation(90)


# ---- the example page on a real inline XRSession ---------------------------------------


#: The estimate of the next XR frame of the session, and what three's XREstimatedLight holds.
ESTIMATE = """() => new Promise((resolve, reject) => window.session.requestAnimationFrame((t, frame) => {
  try {
    const e = frame.getLightEstimate(window.probe);
    const x = window.shlight.xrLight, dl = x.directionalLight;
    const p = (q) => [q.x, q.y, q.z, q.w];
    resolve({
      realFrame: frame instanceof XRFrame,
      f32: e.sphericalHarmonicsCoefficients instanceof Float32Array,
      points: e.primaryLightDirection instanceof DOMPointReadOnly
              && e.primaryLightIntensity instanceof DOMPointReadOnly,
      sh: Array.from(e.sphericalHarmonicsCoefficients),
      direction: p(e.primaryLightDirection), intensity: p(e.primaryLightIntensity),
      shlight: e.shlight,
      three: { sh: x.lightProbe.sh.coefficients.flatMap((v) => [v.x, v.y, v.z]),
               probeIntensity: x.lightProbe.intensity,
               light: [dl.color.r * dl.intensity, dl.color.g * dl.intensity, dl.color.b * dl.intensity],
               position: [dl.position.x, dl.position.y, dl.position.z] },
    });
  } catch (err) { reject(err); }
}))"""

#: three's XREstimatedLight LightProbe: getIrradianceAt(n).x for each normal n.
THREE_E = """(normals) => { const { THREE, xrLight } = window.shlight;
  return normals.map((n) => xrLight.lightProbe.sh.getIrradianceAt(
    new THREE.Vector3(...n), new THREE.Vector3()).x); }"""


def test_example_page_lights_the_scene_through_xr_estimated_light(browser, tmp_path):
    """xr.html installs the polyfill; on a real XRSession without light estimation three's
    XREstimatedLight gets exactly the server's webxr export and lights the sphere from the
    room's bright side; yaw turns it; stale, a new scene, the provider away and back."""
    pano = tmp_path / "room.hdr"
    write_hemisphere(pano, "right")                      # radiance 1 on the +X half only
    ours = provider.compute_sh9(str(pano))
    console: list = []
    with ServeProcess("--source", str(pano), "--keepalive", "60", "--stale-after", "0.5",
                      "--reconnect-max", "0.5") as proc:
        status, headers, body = http_get(proc.http + "/xr-lighting-polyfill.js")
        assert status == 200 and headers["Access-Control-Allow-Origin"] == "*"
        assert headers["Content-Type"].startswith("text/javascript")
        with page_of(browser, proc.http + "/xr.html", tolerate=f"{REFUSED}|{INLINE_LE}",
                     console=console) as page:
            page.wait_for_function("window.shlight && window.shlight.conn.state === 'live'",
                                   timeout=20000)
            polyfill = "window.shlight.polyfill"
            assert page.evaluate(f"{polyfill}.installed && {polyfill}.state") == "idle"
            started = page.evaluate(START_SESSION)
            assert started == {"features": ["viewer"], "real": True, "has": True,
                               "thenable": False, "isEventTarget": True,
                               "format": started["format"]}
            page.wait_for_function("window.started === 1 && !window.shlight.lightProbe.visible",
                                   timeout=20000)
            held = page.evaluate(ESTIMATE)
            latest = webxr_latest(proc.http)
            # The estimate in the page is the server's webxr export (float32), in its seq.
            assert held["realFrame"] and held["f32"] and held["points"]
            assert held["shlight"] == {"probe": "default", "seq": latest["seq"], "time": latest["time"],
                                       "stale": False, "convention": "webxr-threejs"}
            np.testing.assert_array_equal(held["sh"], f32(latest["sphericalHarmonicsCoefficients"]))
            d, e = latest["primaryLightDirection"], latest["primaryLightIntensity"]
            assert held["direction"] == [d["x"], d["y"], d["z"], 0] == [0, 1, 0, 0]   # no light
            assert held["intensity"] == [e["x"], e["y"], e["z"], 1] == [0, 0, 0, 1]
            # ... and it is the whole lighting of the panorama (no light split off here).
            np.testing.assert_allclose(latest["sphericalHarmonicsCoefficients"],
                                       ours.coefficients.reshape(-1), rtol=1e-9, atol=1e-12)
            # three's XREstimatedLight got it: LightProbe = the 27 numbers, intensity 1;
            # DirectionalLight = the primary light (none: irradiance 0), from +Y.
            np.testing.assert_array_equal(held["three"]["sh"], held["sh"])
            assert held["three"]["probeIntensity"] == 1
            assert held["three"]["light"] == [0, 0, 0] and held["three"]["position"] == [0, 1, 0]

            # The page's own scene, lit by XREstimatedLight alone (the preview probe hidden):
            # a white Lambertian sphere seen from +Z, bright on +X, dark on −X, ρE/π in front.
            left, right, centre = sphere_row(canvas_rgba(page))
            assert right > 200 and left < 0.4 * right, (left, right)
            e_front = float(sh.irradiance_from_matrices(ours.matrices, np.array([[0, 0, 1.0]])).mean())
            assert abs(centre - srgb8(e_front / np.pi)) < 4, (centre, srgb8(e_front / np.pi))

            # yaw 90: the room's +X light now comes from −Z of the XR space.
            page.evaluate(f"{polyfill}.setYaw(90)")
            page.wait_for_function(f"window.reflections >= 1 && ({THREE_E})([[0, 0, -1]])[0] > 3",
                                   timeout=20000)
            turned = page.evaluate(ESTIMATE)
            np.testing.assert_allclose(
                np.reshape(turned["sh"], (9, 3)),
                sh.rotate_coefficients(np.reshape(latest["sphericalHarmonicsCoefficients"], (9, 3)),
                                       YAW90), rtol=1e-5, atol=1e-6)
            e = page.evaluate(THREE_E, [[0, 0, -1], [0, 0, 1], [1, 0, 0]])
            assert e[0] > 0.95 * math.pi and abs(e[1]) < 0.05 * math.pi
            assert abs(e[2] - float(sh.irradiance(ours.coefficients, np.array([[0, 0, 1.0]]))[0, 0])) < 1e-3
            page.evaluate(f"{polyfill}.setYaw(0)")

            # The source is lost: stale, the last lighting kept (and three keeps it).
            seen = page.evaluate("window.reflections")
            pano.unlink()
            page.wait_for_function(f"{polyfill}.state === 'stale'", timeout=20000)
            stale = page.evaluate(ESTIMATE)
            assert stale["shlight"]["stale"] is True
            np.testing.assert_array_equal(stale["sh"], held["sh"])
            np.testing.assert_array_equal(stale["three"]["sh"], held["sh"])
            # A new scene (the −X half lit): the estimate and three follow, probes are told.
            write_hemisphere(pano, "left")
            page.wait_for_function(f"{polyfill}.state === 'live' && ({THREE_E})([[-1, 0, 0]])[0] > 3",
                                   timeout=20000)
            assert page.evaluate("window.reflections") > seen
            now = page.evaluate(ESTIMATE)
            assert now["shlight"]["stale"] is False and now["sh"][9] < 0     # L11.r: lit at −X

            # The provider goes away: one warning (not one per retry), the last lighting kept.
            port = proc.port
            proc.stop()
            page.wait_for_function(f"{polyfill}.state === 'down' && "
                                   f"/retrying in 2 s/.test({polyfill}.connection.detail)",
                                   timeout=20000)
            warnings = [t for kind, t in console if kind == "warning" and WARNING in t]
            assert len(warnings) == 1, warnings
            down = page.evaluate(ESTIMATE)
            assert down["shlight"]["stale"] is True and down["sh"] == now["sh"]
            # ... and comes back on the same port: reconnected, fresh again.
            with ServeProcess("--source", str(pano), "--port", str(port), "--keepalive", "60") as again:
                latest = webxr_latest(again.http)      # the new server's lighting (a new time)
                page.wait_for_function(f"{polyfill}.state === 'live' && "
                                       f"{polyfill}.latest.time === {latest['time']!r}", timeout=30000)
                back = page.evaluate(ESTIMATE)
                assert back["shlight"]["stale"] is False
                assert back["shlight"]["seq"] == latest["seq"]
                np.testing.assert_array_equal(back["sh"], f32(latest["sphericalHarmonicsCoefficients"]))

                # With the polyfill, a session that requires light estimation still starts
                # (the browser's own refuses that for an inline session).
                refused = page.evaluate("""() => XRSystem.prototype.requestSession.call(
                    navigator.xr, "inline", { requiredFeatures: ["light-estimation"] })
                    .then(() => "started", (err) => err.name)""")
                assert refused == "NotSupportedError"
                assert page.evaluate("""() => navigator.xr.requestSession("inline",
                    { requiredFeatures: ["light-estimation"] }).then((s) => s.requestLightProbe())
                    .then((p) => p.constructor.name)""") == "ShlightLightProbe"
                assert [t for kind, t in console if kind == "warning" and WARNING in t] == warnings


# ---- stand-ins for what needs a device: the browser's own light estimation ---------------


#: Until three's light has an estimate: run the session's frames (as a device would).
RUN_UNTIL_STARTED = """(name) => { const s = window.standIn;
  s.sessions[name].frame(); return s.lights[name].started; }"""


def test_native_light_estimation_is_left_alone_unless_forced(browser, tmp_path):
    pano = tmp_path / "room.hdr"
    write_hemisphere(pano, "right")
    host = PageHost(APP_PAGE.replace("VERSION", three_version()))
    try:
        with ServeProcess("--source", str(pano), "--keepalive", "60", "--token", "s3cret",
                          "--allow-origin", host.origin) as proc:
            url = f"{host.origin}/?provider={proc.http}"
            with page_of(browser, url) as page:
                page.wait_for_function("window.ready === true", timeout=20000)
                page.evaluate(STAND_INS)
                install = """(force) => { const s = window.standIn;
                  window.polyfill = m.installLightEstimationPolyfill({
                    url: "%s", token: "s3cret", force, XRSession: s.Session, XRFrame: s.Frame,
                    XRWebGLBinding: s.Binding, xr: s.xr }); return window.polyfill.installed; }""" % proc.http
                assert page.evaluate(install, False) is True
                # Sessions: with the browser's own light estimation, without it, and two from
                # a browser that does not list its features (its own call answers or refuses).
                page.evaluate("""() => { const s = window.standIn;
                  s.sessions = { native: new s.Session(["viewer", "local", "light-estimation"], true),
                                 none: new s.Session(["viewer", "local"], false),
                                 unknownYes: new s.Session(undefined, true),
                                 unknownNo: new s.Session(undefined, false) };
                  for (const name in s.sessions) s.lights[name] = s.estimatedLight(s.sessions[name]); }""")
                for name in ("native", "none", "unknownYes", "unknownNo"):
                    page.wait_for_function(RUN_UNTIL_STARTED, arg=name, timeout=20000)
                got = page.evaluate("""() => { const s = window.standIn; const out = {};
                  for (const name in s.sessions) out[name] = { ...s.held(s.lights[name]),
                    nativeCalls: s.sessions[name].nativeCalls }; return out; }""")
                latest = webxr_latest(proc.http, "s3cret")
                ours = f32(latest["sphericalHarmonicsCoefficients"]).tolist()
                native = {"sh": [0.25] * 27, "light": 2, "position": [0, 0, 1], "started": True}
                # The browser's own estimation is used where the session has it ...
                assert got["native"] == {**native, "nativeCalls": 1}
                assert got["unknownYes"] == {**native, "nativeCalls": 1}
                # ... and the provider's where it has not (not asked again when it says so).
                provided = {"sh": ours, "light": 0, "position": [0, 1, 0], "started": True}
                assert got["none"] == {**provided, "nativeCalls": 0}
                assert got["unknownNo"] == {**provided, "nativeCalls": 1}

                # A session that requires light estimation still starts: the feature is made
                # optional (the browser's own where it grants it).
                inits = page.evaluate("""async () => { const xr = window.standIn.xr;
                  await xr.requestSession("immersive-ar", { requiredFeatures: ["local", "light-estimation"],
                                                            optionalFeatures: ["hit-test"] });
                  await xr.requestSession("immersive-ar", { optionalFeatures: ["light-estimation"] });
                  await xr.requestSession("inline");
                  return xr.inits; }""")
                assert inits == [{"requiredFeatures": ["local"],
                                  "optionalFeatures": ["hit-test", "light-estimation"]},
                                 {"optionalFeatures": ["light-estimation"]}, None]

                # What the spec asks of requestLightProbe / getLightEstimate, for our probes.
                errors = page.evaluate("""async () => { const s = window.standIn;
                  const a = s.sessions.none, b = new s.Session([], false);
                  const probe = await a.requestLightProbe();
                  const out = {};
                  try { new s.Frame(b).getLightEstimate(probe); } catch (e) { out.otherSession = e.name; }
                  out.format = await a.requestLightProbe({ reflectionFormat: "rgba16f" })
                    .then(() => "resolved", (e) => e.name);
                  try { new s.Frame(a).getLightEstimate({}); } catch (e) { out.notAProbe = e.name; }
                  const binding = new s.Binding(a, null);
                  out.cubeMap = binding.getReflectionCubeMap(probe);
                  out.nativeCubeMap = binding.getReflectionCubeMap(new s.NativeProbe());
                  // a session that ended: its probes are told nothing more (and let go)
                  const ending = new s.Session([], false), q = await ending.requestLightProbe();
                  out.told = 0;
                  q.onreflectionchange = () => { out.told++; };
                  window.polyfill.setYaw(5);
                  ending.dispatchEvent(new Event("end"));
                  window.polyfill.setYaw(0);
                  return out; }""")
                assert errors == {"otherSession": "InvalidStateError", "format": "NotSupportedError",
                                  "notAProbe": "TypeError", "cubeMap": None, "nativeCubeMap": None,
                                  "told": 1}

                # XREstimatedLight(renderer, true) asks the binding for a cube map at each
                # 'reflectionchange' (XREstimatedLight.js:44-50, 66): none for our probes,
                # and no error (the page fails on any uncaught error or rejection).
                asked = page.evaluate("""async () => { const s = window.standIn;
                  const calls = [];
                  const patched = s.Binding.prototype.getReflectionCubeMap;
                  s.Binding.prototype.getReflectionCubeMap = function (p) {
                    const r = patched.call(this, p); calls.push(r); return r; };
                  window.XRWebGLBinding = s.Binding;     // three reads the global (XREstimatedLight.js:23, 44)
                  s.Binding.made = 0;
                  const session = new s.Session([], false);
                  s.sessions.env = session;
                  s.lights.env = s.estimatedLight(session, true);
                  while (!session.callbacks.length) await new Promise((r) => setTimeout(r, 10));
                  session.frame();
                  window.polyfill.setYaw(30);            // new lighting for the probes
                  window.polyfill.setYaw(0);
                  return { calls, made: s.Binding.made,
                           environment: s.lights.env.environment !== null }; }""")
                assert asked == {"calls": [None, None], "made": 1, "environment": True}

                # uninstall() puts back what it patched.
                assert page.evaluate("""() => { const s = window.standIn; window.polyfill.uninstall();
                  const now = [s.Session.prototype.requestLightProbe, s.Frame.prototype.getLightEstimate,
                               s.Binding.prototype.getReflectionCubeMap, s.xr.requestSession];
                  return [now.every((f, i) => f === s.originals[i]), window.polyfill.state]; }""") == [True, "closed"]

                # force: the provider answers even where the browser has light estimation,
                # and the device is not asked to estimate.
                assert page.evaluate(install, True) is True
                page.evaluate("""() => { const s = window.standIn;
                  s.sessions.forced = new s.Session(["viewer", "local", "light-estimation"], true);
                  s.lights.forced = s.estimatedLight(s.sessions.forced); }""")
                page.wait_for_function(RUN_UNTIL_STARTED, arg="forced", timeout=20000)
                forced = page.evaluate("""() => { const s = window.standIn;
                  return { ...s.held(s.lights.forced), nativeCalls: s.sessions.forced.nativeCalls }; }""")
                assert forced == {**provided, "nativeCalls": 0}
                inits = page.evaluate("""async () => { const xr = window.standIn.xr; xr.inits = [];
                  await xr.requestSession("immersive-ar", { requiredFeatures: ["light-estimation"],
                                                            optionalFeatures: ["light-estimation", "hit-test"] });
                  return xr.inits; }""")
                assert inits == [{"requiredFeatures": [], "optionalFeatures": ["hit-test"]}]
                assert page.evaluate("window.polyfill.uninstall(), true")
    finally:
        host.close()


def test_estimate_of_a_primary_light_turned_into_the_reference_space(browser, tmp_path):
    """The live provider sends no lights yet (docs/contract.md §10 is the engine's next step), so
    the webxr export of a scene with one (made by the server's own export code) is decoded
    in the page: the light leaves the SH as XREstimatedLight expects, and a rotation turns
    the SH and the direction alike."""
    pano = tmp_path / "room.hdr"
    write_hemisphere(pano, "right")
    d = np.array([0.48, 0.6, -0.64])
    e_perp = np.array([4.0, 2.0, 1.0])
    L = provider.compute_sh9(str(pano)).coefficients + cv.light_sh(d, e_perp)
    message = {"type": "sh9", "probe": "default", "seq": 7, "time": 1.5, "stale": False,
               "age_s": 0.0, "coefficients": L.reshape(-1).tolist(), "lights": 1,
               "light_directions": d.tolist(), "light_irradiance": e_perp.tolist()}
    from provider.live.wire.export import export_message
    export = json.loads(json.dumps(export_message(message, "webxr")))
    R = sh.rotation_from_euler(yaw_deg=50, pitch_deg=-20, roll_deg=10)
    with ServeProcess("--source", str(pano)) as proc:
        # any page of the provider's origin will do: the module is imported by its path
        with page_of(browser, proc.http + "/healthz") as page:
            got = page.evaluate("""async ([msg, R]) => {
              const m = await import("/xr-lighting-polyfill.js");
              const p = (q) => [q.x, q.y, q.z, q.w];
              const out = {};
              for (const [name, opts] of [["plain", undefined], ["turned", { rotation: R }],
                                          ["aframe", { rotation: R, shScale: 1 / Math.PI }]]) {
                const e = m.lightEstimate(m.decodeEstimate(msg), opts);
                out[name] = { sh: Array.from(e.sphericalHarmonicsCoefficients),
                              direction: p(e.primaryLightDirection), intensity: p(e.primaryLightIntensity),
                              shlight: e.shlight };
              }
              out.sh9 = m.decodeEstimate({ ...msg, type: "sh9" });
              out.bad = m.decodeEstimate({ ...msg, sphericalHarmonicsCoefficients: [1, 2] });
              return out; }""", [export, R.reshape(-1).tolist()])
    ambient = L - cv.light_sh(d, e_perp)
    np.testing.assert_array_equal(got["plain"]["sh"], f32(export["sphericalHarmonicsCoefficients"]))
    np.testing.assert_allclose(np.reshape(got["plain"]["sh"], (9, 3)), ambient, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(got["plain"]["direction"], [*d, 0], rtol=1e-6)
    assert got["plain"]["intensity"] == [4, 2, 1, 1]
    assert got["plain"]["shlight"] == {"probe": "default", "seq": 7, "time": 1.5, "stale": False,
                                       "convention": "webxr-threejs"}
    np.testing.assert_allclose(np.reshape(got["turned"]["sh"], (9, 3)),
                               sh.rotate_coefficients(ambient, R), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(got["turned"]["direction"], [*(R @ d), 0], atol=1e-6)
    assert got["turned"]["intensity"] == [4, 2, 1, 1]
    # shScale (1/π for A-Frame's reflection component) scales the SH only
    np.testing.assert_allclose(np.reshape(got["aframe"]["sh"], (9, 3)),
                               sh.rotate_coefficients(ambient, R) / np.pi, rtol=1e-5, atol=1e-5)
    assert got["aframe"]["direction"] == got["turned"]["direction"]
    assert got["aframe"]["intensity"] == [4, 2, 1, 1]
    assert got["sh9"] is None and got["bad"] is None
