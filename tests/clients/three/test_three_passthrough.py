"""three.js on a video see-through headset (issue 42, item 4 for the browser): /passthrough.js
tone-maps the renderer as the headset's camera renders the room, and sends a WebXR camera's
views to ``shlight serve --passthrough``. Real headless Chromium, three.js r187's own shaders
(tests/node/node_modules), a real server; only the XR device is stood in (headless Chromium has
no WebXR Raw Camera Access): XRView-shaped objects whose camera image is a real WebGL texture.

A simulated headset (provider/bench/headset_sim.py: a filmic curve that is not sRGB, a lagging
auto exposure, a drifting white balance, vignetting, JPEG, 1° pose error) looks around a room
none of the shared nine is. Checked: the page's lookup is the fit's inverse response; three's
shader draws exactly the codes the model predicts; the sender's intrinsics and pose are the
view's, and its views, fitted live, meet the issue's done-when; and the seed paper's test: a
grey sphere lit by the provider's SH9 and drawn by three.js through the fitted model shows the
codes the headset records of the same real sphere.
"""
from __future__ import annotations

import base64
import json

import numpy as np
import pytest

from provider import compute_sh9
from provider.bench.headset_sim import HeadsetSim, perturb_panorama, score
from provider.core.passthrough import display_codes, display_lookup, fit_views
from provider.core.geometry import sh
from provider.core.passthrough.fit import codes_of
from provider.core.radiometry.response import CameraResponse

from browsertools import NEEDS_BROWSER, browser, page_of, three_version  # noqa: F401
from conftest import load_hdri
from envtools import THREE_URL, png_of
from replica_three import irradiance, replica_codes, sphere_pixels, stops
from servertools import ServeProcess

pytestmark = NEEDS_BROWSER

#: The issue's done-when (stops): median view bias, 90th-percentile view bias, pixels' p90.
DONE_WHEN = {"median_view_bias": 0.10, "p90_view_bias": 0.20, "pixel_p90": 0.45}
ROOM, ROOM_SEED = "venice", 13
N_VIEWS, W, H = 24, 160, 120
#: Each view's answer may take seconds on a loaded 2-core machine (a warm solve of all views).
ANSWER_MS = 60000
YAW = 30.0          # the XR reference space is the provider's frame turned by this about +Y
ALBEDO = 0.5
#: The sphere's pixels (rows from the top, orthographic, ±1.05 framed in S × S).
S = 192


def yaw_rotation(degrees: float) -> np.ndarray:
    """As client-three.js yawRotation: a direction d of the provider's frame appears at R·d."""
    a = np.radians(degrees)
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


@pytest.fixture(scope="module")
def room():
    return perturb_panorama(load_hdri(ROOM), seed=ROOM_SEED)


@pytest.fixture(scope="module")
def headset(room, tmp_path_factory):
    """The simulated headset's views of the room, no exposure metadata: (doc, truth)."""
    folder = tmp_path_factory.mktemp("headset")
    truth = HeadsetSim(n_views=N_VIEWS, width=W, height=H, seed=5).render(room, str(folder))
    return json.loads((folder / "transforms.json").read_text()), truth


@pytest.fixture(scope="module")
def fitted(room, headset):
    """The offline fit of the views (what `shlight passthrough` prints)."""
    _, truth = headset
    return fit_views(room, truth.views, truth.codes)


@pytest.fixture(scope="module")
def server(room, tmp_path_factory):
    """`shlight serve --passthrough` with the room as its 360° camera (an EXR)."""
    import OpenEXR
    path = tmp_path_factory.mktemp("sphere") / "room.exr"
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": np.ascontiguousarray(room, np.float32)}) as f:
        f.write(str(path))
    with ServeProcess("--source", str(path), "--fps", "5", "--passthrough",
                      "--passthrough-hz", "0") as proc:
        yield proc


IMPORTS = """async ([base, threeUrl]) => {
  window.THREE = await import(threeUrl);
  window.pt = await import(base + "/passthrough.js");
  window.three = await import(base + "/client-three.js");
  return true;
}"""


def _page(browser, server):
    ctx = page_of(browser, server.http + "/healthz")
    page = ctx.__enter__()
    page.evaluate(IMPORTS, [server.http, THREE_URL.format(version=three_version())])
    return ctx, page


# ---- (a) the lookup and three's shader -----------------------------------------------------

PATCHES = """async ([camera, gain, colours]) => {
  // one flat patch per colour (MeshBasicMaterial: its colour is the linear light the tone
  // mapping gets), side by side in a row, 4 × 4 pixels each
  const { THREE, pt } = window, n = colours.length, P = 4;
  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  renderer.setSize(n * P, P, false);
  const tm = pt.passthroughToneMapping(THREE, renderer, { camera });
  tm.setView({ exposure: gain[1], wb_gains: [gain[0] / gain[1], 1, gain[2] / gain[1]] });
  const scene = new THREE.Scene();
  const cam = new THREE.OrthographicCamera(0, n, 1, 0, -1, 1);
  colours.forEach((c, i) => {
    const m = new THREE.Mesh(new THREE.PlaneGeometry(1, 1), new THREE.MeshBasicMaterial({ color: new THREE.Color(...c) }));
    m.position.set(i + 0.5, 0.5, 0);
    scene.add(m);
  });
  renderer.render(scene, cam);
  const png = renderer.domElement.toDataURL("image/png");
  renderer.outputColorSpace = THREE.LinearSRGBColorSpace;     // the same codes through a linear output
  renderer.render(scene, cam);
  const out = { png, linear: renderer.domElement.toDataURL("image/png"),
                cpu: colours.map((c) => tm.codes(c)), lut: Array.from(tm.lut.data), range: tm.lut.range,
                toneMapping: renderer.toneMapping === THREE.CustomToneMapping };
  tm.dispose();
  out.restored = renderer.toneMapping === THREE.NoToneMapping
    && !THREE.ShaderChunk.tonemapping_pars_fragment.includes("shPassthrough");
  return out;
}"""


def test_the_lookup_is_the_fits_inverse_response_and_three_draws_its_codes(
        browser, server, fitted):
    """The page's 256-entry lookup is the contract's (the library's display_lookup of the fitted
    camera.json: g⁻¹ at log-spaced exposures from code 1 to the top); lookupCodes reads it as
    display_codes does, the linear toe under the first entry included; three's CustomToneMapping
    shader (the lookup on the GPU) draws the code the model predicts for a view's exposure and
    white balance, to the framebuffer's rounding, and on the toe the code display_codes gives."""
    camera = fitted.response.to_dict()
    table = fitted.response.table
    lookup = display_lookup(fitted.response)
    view = len(fitted.exposure) // 2
    gain = fitted.exposure[view] * fitted.wb_gains[view]
    rng = np.random.default_rng(1)
    # linear colours whose codes span the curve: toe, mid-tones, shoulder, clipped, black
    x = np.exp(rng.uniform(np.log(table[2].min()), np.log(table[255].max() * 1.5), (60, 3)))
    # and under the lookup's first entry (a hologram in the dark): its linear toe to code 0
    toe = 2.0 ** lookup.lo * np.array([[0.05, 0.3, 0.7], [0.7, 0.05, 0.3], [0.3, 0.7, 0.05], [0.9, 0.9, 0.9]])
    colours = np.vstack([x / gain, toe / gain, [[0, 0, 0]]])
    ctx, page = _page(browser, server)
    try:
        got = page.evaluate(PATCHES, [camera, gain.tolist(), colours.tolist()])
    finally:
        ctx.__exit__(None, None, None)
    assert got["toneMapping"] and got["restored"]
    lo, hi = got["range"]
    assert lo == pytest.approx(lookup.lo, abs=1e-12) and hi == pytest.approx(lookup.hi, abs=1e-12)
    lut = np.asarray(got["lut"]).reshape(256, 4)
    # float32 texels of the same interpolation
    np.testing.assert_allclose(lut[:, :3], lookup.table, atol=1e-6)
    assert (lut[:, 3] == 1).all()
    # the shader's reading on the CPU (lookupCodes): the library's reading of the same lookup
    # (float32 texels: 1e-5 of a code), and against the table read directly from the first
    # entry up: the lookup's linear steps of ~0.05 stop cost under a tenth of a code
    reading = 255 * display_codes(lookup, colours * gain)
    model = codes_of(table, colours * gain)
    cpu = 255 * np.asarray(got["cpu"])
    assert np.abs(cpu - reading).max() < 1e-3, np.abs(cpu - reading).max()
    n = len(x)
    assert np.abs(cpu[:n] - model[:n]).max() < 0.1, np.abs(cpu[:n] - model[:n]).max()
    assert (reading[n:n + len(toe)] < 255 * lookup.table[0] + 1e-9).all()
    # three's shader: the framebuffer holds the code, rounded (an sRGB output decoded and
    # encoded back in float32, a linear one as it is: a code within 0.5 + float rounding)
    for key in ("png", "linear"):
        drawn = png_of(got[key])[2, 2::4, :3].astype(np.float64)
        assert drawn.shape == reading.shape
        assert np.abs(drawn - reading).max() <= 0.6, (key, np.abs(drawn - reading).max())
        assert np.abs(drawn[:n] - model[:n]).max() <= 0.6, (key, np.abs(drawn[:n] - model[:n]).max())
        assert (drawn[-1] == 0).all()


# ---- (b) the sender: intrinsics, pose, a real /capture --------------------------------------

FRUSTUM = """([frustums, w, h]) => frustums.map(([l, r, t, b, n, f]) => {
  const P = new window.THREE.Matrix4().makePerspective(l, r, t, b, n, f).elements;
  return window.pt.projectionIntrinsics(P, w, h);
})"""


def test_intrinsics_from_a_projection_matrix_are_the_frustums(browser, server):
    """projectionIntrinsics of a projection matrix made by three.js (Matrix4.makePerspective,
    off-centre frusta as a headset's cameras have): a point at X̂ = x/(−z) on the near plane's
    left edge is column 0, on its right edge column w; the top edge is row 0."""
    rng = np.random.default_rng(3)
    frustums = []
    for _ in range(8):
        n = rng.uniform(0.05, 0.5)
        l, r = -n * rng.uniform(0.5, 1.5), n * rng.uniform(0.5, 1.5)
        b, t = -n * rng.uniform(0.4, 1.2), n * rng.uniform(0.4, 1.2)
        frustums.append([l, r, t, b, n, 100.0])
    ctx, page = _page(browser, server)
    try:
        got = page.evaluate(FRUSTUM, [frustums, 640, 480])
    finally:
        ctx.__exit__(None, None, None)
    for (l, r, t, b, n, _), k in zip(frustums, got):
        assert k["fl_x"] == pytest.approx(640 * n / (r - l), rel=1e-6)
        assert k["fl_y"] == pytest.approx(480 * n / (t - b), rel=1e-6)
        assert k["cx"] == pytest.approx(-640 * l / (r - l), abs=1e-3)
        assert k["cy"] == pytest.approx(480 * t / (t - b), abs=1e-3)
        assert abs(k["skew"]) < 1e-9 and (k["w"], k["h"]) == (640, 480)


SENDER = """async ([base, R]) => {
  const { THREE, pt, three } = window;
  const canvas = document.createElement("canvas");
  const renderer = new THREE.WebGLRenderer({ canvas });
  const gl = renderer.getContext();
  window.answers = []; window.cameras = 0;
  // The XR device stood in: a binding whose camera image is the texture the test uploads.
  const sender = pt.startCameraSender(base + "/", { gl, renderer, loop: false, hz: 1e6, rotation: R,
    referenceSpace: {}, binding: { getCameraImage: (camera) => camera.texture },
    XRWebGLBinding: class { getCameraImage() {} }, XRView: class { get camera() { return null; } },
    onMessage: (m) => { if (m.type === "passthrough_camera") window.cameras++; else window.answers.push(m); } });
  // connectLightProbe renders through the sender's answers
  const conn = three.connectLightProbe(base + "/", new THREE.LightProbe(),
    { passthrough: { THREE, renderer, socket: sender.socket } });
  const until = (ok, what) => new Promise((resolve, reject) => {
    const t0 = performance.now();
    const poll = () => ok() ? resolve() : performance.now() - t0 > %d ? reject(new Error(what)) : setTimeout(poll, 5);
    poll();
  });
  await until(() => sender.state === "live", "the /capture socket");
  window.sendView = async ([b64, w, h, P, M, now]) => {
    const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
    const tex = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, tex);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGB8, w, h, 0, gl.RGB, gl.UNSIGNED_BYTE, bytes);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    renderer.resetState();
    const view = { projectionMatrix: Float32Array.from(P), transform: { matrix: Float32Array.from(M) },
                   camera: { width: w, height: h, texture: tex } };
    const before = window.answers.length;
    if (!sender.capture({ getViewerPose: () => ({ views: [view] }) }, now)) throw new Error("not captured");
    await until(() => window.answers.length > before, "an answer to the view");
    gl.deleteTexture(tex);
    return { answer: window.answers[window.answers.length - 1], sent: sender.lastView };
  };
  window.conn = conn;
  window.sender = sender;
  return sender.available;
}""" % ANSWER_MS


def test_the_sender_sends_views_the_server_fits_and_the_tone_mapping_follows(
        browser, server, headset):
    """Each simulated view, as a WebXR view (its projection matrix, its pose in a reference
    space turned by a yaw, its image a WebGL texture rows from the bottom as GL holds a camera
    image) goes through startCameraSender: read back, JPEG-encoded in the page, sent to a real
    /capture with the view message. The message holds the view's intrinsics and its pose in the
    provider's frame; every view is answered; the second pass of the views, scored by the
    issue's done-when, is as good as views sent by any headset (a flipped image or a wrong
    pose would not fit); connectLightProbe's tone mapping holds the last answer."""
    doc, truth = headset
    R = yaw_rotation(YAW)
    fl, cx, cy = doc["fl_x"], doc["cx"], doc["cy"]
    n, f = 0.1, 100.0
    P = np.array([[2 * fl / W, 0, 1 - 2 * cx / W, 0], [0, 2 * fl / H, 2 * cy / H - 1, 0],
                  [0, 0, -(f + n) / (f - n), -2 * f * n / (f - n)], [0, 0, -1, 0]])
    ctx, page = _page(browser, server)
    try:
        assert page.evaluate(SENDER, [server.http, R.ravel().tolist()]) is True
        answers, now = [], 0.0
        for _ in range(2):
            answers = []
            for frame, codes in zip(doc["frames"], truth.codes):
                m = np.asarray(frame["transform_matrix"], np.float64)
                world = np.eye(4)
                world[:3, :3], world[:3, 3] = R @ m[:3, :3], R @ m[:3, 3]
                image = base64.b64encode(np.ascontiguousarray(codes[::-1]).tobytes()).decode()
                now += 1000.0
                got = page.evaluate("(a) => window.sendView(a)", [
                    image, W, H, P.T.ravel().tolist(), world.T.ravel().tolist(), now])
                sent, answer = got["sent"], got["answer"]
                assert sent["w"] == W and sent["h"] == H
                for key, want in (("fl_x", fl), ("fl_y", fl), ("cx", cx), ("cy", cy)):
                    assert sent[key] == pytest.approx(want, abs=1e-3), key
                np.testing.assert_allclose(np.reshape(sent["transform_matrix"], (4, 4)), m,
                                           atol=2e-5)
                assert answer["type"] == "passthrough" and not answer.get("dropped"), answer
                answers.append(answer)
        held = page.evaluate("""() => ({ exposure: window.conn.passthrough.exposure,
            wb: window.conn.passthrough.wbGains, camera: window.conn.passthrough.camera,
            cameras: window.cameras, sent: window.sender.sent })""")
    finally:
        ctx.__exit__(None, None, None)
    assert held["sent"] == 2 * N_VIEWS and held["cameras"] >= 1
    assert held["exposure"] == answers[-1]["exposure"] and held["wb"] == answers[-1]["wb_gains"]
    response = CameraResponse.from_dict(held["camera"])
    vig = response.params["vignetting"]

    def predict(i, radiance, rho2):
        a = answers[i]
        x = radiance * a["exposure"] * np.asarray(a["wb_gains"])
        x = x * np.exp(vig["v1"] * rho2 + vig["v2"] * rho2 ** 2)[..., None]
        return codes_of(response.table, x)
    got = score(truth, predict)
    print("views sent by the page, second pass:", got)
    for key, limit in DONE_WHEN.items():
        assert got[key] <= limit, (key, got)


POLYFILL = """async ([base, image, w, h, P, M]) => {
  const { THREE } = window;
  const poly = await import(base + "/xr-lighting-polyfill.js");
  const renderer = new THREE.WebGLRenderer({ canvas: document.createElement("canvas") });
  const gl = renderer.getContext();
  // the XR device stood in: a session with 'camera-access', a binding whose camera image is a texture
  class Session extends EventTarget {
    constructor(init) { super(); this.enabledFeatures = ["local-floor", ...(init.optionalFeatures || [])]; }
    requestAnimationFrame() { return 0; }
  }
  class Frame {}
  class Binding { getCameraImage(camera) { return camera.texture; } }
  let asked = null;
  const xr = { requestSession: async (mode, init) => { asked = init; return new Session(init); } };
  const answers = [];
  const handle = poly.installLightEstimationPolyfill({ url: base + "/", yaw: %s, XRSession: Session,
    XRFrame: Frame, XRWebGLBinding: Binding, xr, passthrough: { THREE, renderer, send: true, hz: 1e6, maxWidth: w / 2,
      referenceSpace: {}, XRView: class { get camera() { return null; } },
      onMessage: (m) => { if (m.type === "passthrough") answers.push(m); } } });
  const session = await xr.requestSession("immersive-ar", { requiredFeatures: ["local-floor"] });
  const sender = handle.sender;
  const until = (ok, what) => new Promise((resolve, reject) => {
    const t0 = performance.now();
    const poll = () => ok() ? resolve() : performance.now() - t0 > %d ? reject(new Error(what)) : setTimeout(poll, 5);
    poll();
  });
  await until(() => sender.state === "live", "the /capture socket");
  const bytes = Uint8Array.from(atob(image), (c) => c.charCodeAt(0));
  const tex = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, tex);
  gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGB8, w, h, 0, gl.RGB, gl.UNSIGNED_BYTE, bytes);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
  renderer.resetState();
  const view = { projectionMatrix: Float32Array.from(P), transform: { matrix: Float32Array.from(M) },
                 camera: { width: w, height: h, texture: tex } };
  if (!sender.capture({ getViewerPose: () => ({ views: [view] }) }, 1000)) throw new Error("not captured");
  await until(() => answers.length === 1, "an answer");
  const out = { asked, sent: sender.lastView, answer: answers[0],
                exposure: handle.passthrough.exposure, wb: handle.passthrough.wbGains,
                toneMapping: renderer.toneMapping === THREE.CustomToneMapping };
  handle.uninstall();
  await until(() => sender.state === "closed", "the sender closed");
  out.restored = renderer.toneMapping !== THREE.CustomToneMapping
    && !THREE.ShaderChunk.tonemapping_pars_fragment.includes("shPassthrough");
  return out;
}""" % (YAW, ANSWER_MS)


def test_the_polyfill_asks_for_the_camera_sends_its_views_and_tone_maps(
        browser, server, headset):
    """installLightEstimationPolyfill({passthrough: {send: true}}): a session is asked for
    'camera-access' (optional: it still starts without), its camera's views go to /capture
    with the pose taken back out of the polyfill's yaw, at half the camera image's size
    (area-averaged, the intrinsics of the image sent), and the answers drive the renderer's
    tone mapping; uninstall() closes the sender and gives three its tone mapping back."""
    doc, truth = headset
    R = yaw_rotation(YAW)
    fl, cx, cy = doc["fl_x"], doc["cx"], doc["cy"]
    P = np.array([[2 * fl / W, 0, 1 - 2 * cx / W, 0], [0, 2 * fl / H, 2 * cy / H - 1, 0],
                  [0, 0, -1.002, -0.2002], [0, 0, -1, 0]])
    m = np.asarray(doc["frames"][0]["transform_matrix"], np.float64)
    world = np.eye(4)
    world[:3, :3], world[:3, 3] = R @ m[:3, :3], R @ m[:3, 3]
    image = base64.b64encode(np.ascontiguousarray(truth.codes[0][::-1]).tobytes()).decode()
    ctx, page = _page(browser, server)
    try:
        got = page.evaluate(POLYFILL, [server.http, image, W, H, P.T.ravel().tolist(),
                                       world.T.ravel().tolist()])
    finally:
        ctx.__exit__(None, None, None)
    assert "camera-access" in got["asked"]["optionalFeatures"]
    assert "camera-access" not in got["asked"].get("requiredFeatures", [])
    np.testing.assert_allclose(np.reshape(got["sent"]["transform_matrix"], (4, 4)), m, atol=2e-5)
    # sent at half the camera image's size (maxWidth): the intrinsics of the image sent
    assert (got["sent"]["w"], got["sent"]["h"]) == (W // 2, H // 2)
    for key, want in (("fl_x", fl / 2), ("fl_y", fl / 2), ("cx", cx / 2), ("cy", cy / 2)):
        assert got["sent"][key] == pytest.approx(want, abs=1e-3), key
    assert got["answer"]["type"] == "passthrough" and got["answer"]["exposure"] > 0
    assert got["exposure"] == got["answer"]["exposure"] and got["wb"] == got["answer"]["wb_gains"]
    assert got["toneMapping"] and got["restored"]


def test_without_raw_camera_access_the_sender_says_why_once(browser, server):
    """Where the browser has no raw camera access (no XRWebGLBinding.getCameraImage), or the
    session was started without 'camera-access', the sender opens nothing, sends nothing and
    says why in one console line each."""
    console: list = []
    ctx = page_of(browser, server.http + "/healthz", console=console)
    page = ctx.__enter__()
    try:
        page.evaluate(IMPORTS, [server.http, THREE_URL.format(version=three_version())])
        got = page.evaluate("""() => {
          const gl = document.createElement("canvas").getContext("webgl2");
          const session = { enabledFeatures: ["local"], addEventListener() {}, requestAnimationFrame() {} };
          return [window.pt.startCameraSender(location.origin + "/", { gl, XRWebGLBinding: undefined }),
                  window.pt.startCameraSender(location.origin + "/", { gl, session,
                    XRWebGLBinding: class { getCameraImage() {} }, XRView: class { get camera() { return null; } } })]
            .map((s) => ({ available: s.available, reason: s.reason, socket: s.socket }));
        }""")
    finally:
        ctx.__exit__(None, None, None)
    assert all(s["available"] is False and s["socket"] is None for s in got)
    assert "no WebXR Raw Camera Access" in got[0]["reason"]
    assert "'camera-access'" in got[1]["reason"]
    warnings = [t for k, t in console if k == "warning" and "shlight passthrough" in t]
    assert len(warnings) == 2 and all("no camera views sent" in w for w in warnings)


# ---- (c) the grey sphere beside its real replica ---------------------------------------------

GREY_SPHERE = """async ([base, camera, views, albedo, S]) => {
  const { THREE, three } = window;
  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  renderer.setSize(S, S, false);
  const scene = new THREE.Scene();
  const probe = new THREE.LightProbe();
  scene.add(probe);
  const sphere = new THREE.Mesh(new THREE.SphereGeometry(1, 256, 128),
    new THREE.MeshLambertMaterial({ color: new THREE.Color(albedo, albedo, albedo) }));
  scene.add(sphere);
  const cam = new THREE.OrthographicCamera(-1.05, 1.05, 1.05, -1.05, 0.1, 10);
  cam.position.set(0, 0, 5);
  // the provider's live SH9 of the room, the hologram rendered through the fitted model
  const conn = three.connectLightProbe(base + "/", probe, { passthrough: { THREE, renderer, camera } });
  await new Promise((resolve, reject) => {
    const t0 = performance.now();
    const poll = () => conn.latest ? resolve() : performance.now() - t0 > 30000 ? reject(new Error("no lighting")) : setTimeout(poll, 10);
    poll();
  });
  const out = { coefficients: Array.from(conn.latest.coefficients), pictures: [] };
  for (const v of views) {
    conn.passthrough.setView(v);
    renderer.render(scene, cam);
    out.pictures.push(renderer.domElement.toDataURL("image/png"));
  }
  conn.close();
  return out;
}"""


def test_a_grey_sphere_renders_as_its_real_replica(browser, server, room, headset, fitted):
    """The seed paper's test: a grey Lambertian sphere (albedo 0.5) lit by the provider's SH9
    of the room, drawn by three.js through the fitted model (the offline fit's camera.json and
    each view's exposure and white balance), against the codes the simulated headset records of
    the same real sphere in that view (radiance ρ/π · E(n), E from the true panorama, through
    the true curve, exposure and white balance): within 0.1 stop, the median over the sphere's
    pixels of the worst channel, in views from the darkest to the brightest exposure."""
    _, truth = headset
    out = fitted.to_json()
    order = np.argsort(truth.exposure)
    picks = [int(order[k]) for k in (2, len(order) // 2, len(order) - 3)]
    views = [{"exposure": out["views"][i]["exposure"], "wb_gains": out["views"][i]["wb_gains"]}
             for i in picks]
    ctx, page = _page(browser, server)
    try:
        got = page.evaluate(GREY_SPHERE, [server.http, out["camera"], views, ALBEDO, S])
    finally:
        ctx.__exit__(None, None, None)
    # the probe's lighting is the room's (the provider read the same EXR)
    np.testing.assert_allclose(got["coefficients"],
                               compute_sh9(room).coefficients.reshape(-1), rtol=1e-4, atol=1e-6)
    mask, normals = sphere_pixels(S)
    radiance = ALBEDO / np.pi * irradiance(room, normals)
    hologram = ALBEDO / np.pi * sh.irradiance(np.reshape(got["coefficients"], (9, 3)), normals)
    for i, png in zip(picks, got["pictures"]):
        drawn = png_of(png)[..., :3][mask].astype(np.float64)
        real = replica_codes(truth.camera, radiance, truth.exposure[i], truth.wb_gains[i])
        ok = ((real >= 1) & (real <= 254)).all(-1)
        assert ok.mean() > 0.9, f"view {i}: the real sphere clips or is black"
        err = stops(truth.camera, drawn[ok], real[ok])
        bias = np.abs(np.median(err, axis=0)).max()
        # three draws the model's codes (its SH9 shading, the lookup): what is left is the fit's
        model = fitted.predict_codes(hologram, i)
        drawn_vs_model = np.abs(np.median(stops(truth.camera, drawn[ok], model[ok]), axis=0)).max()
        print(f"view {i} (exposure {truth.exposure[i]:.3g}): grey sphere {bias:.3f} stop "
              f"(median, worst channel), pixels' p90 {np.percentile(np.abs(err).max(-1), 90):.3f}; "
              f"three against the model {drawn_vs_model:.4f}")
        assert bias <= 0.1, (i, np.median(err, axis=0))
        # the 8-bit framebuffer's rounding, and float32 shading: a hundredth of a stop
        assert drawn_vs_model <= 0.01, (i, drawn_vs_model)
