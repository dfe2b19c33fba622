"""The browser client (/client.js), the three.js adapter (/client-three.js) and the WebXR
example page (/xr.html) in a real headless Chromium against a live ``shlight serve``.

three.js is the npm package installed by scripts/test.sh into tests/node/node_modules (not
committed); the example page's CDN address for it is answered from that folder, so the
test needs no network. Checked: what the page holds equals what the server sent; the
client's maths (matrices, E(n), rotation) equals provider.core.sh; stale, reconnection;
and three.js's own SphericalHarmonics3.getIrradianceAt and its shader, fed through the
adapter, light a surface from the side the light is on, with the magnitude ρE/π.
"""
from __future__ import annotations

import base64
import json
import os
import re
import threading
from contextlib import contextmanager
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import cv2
import numpy as np
import pytest

import provider
from provider.core import sh

from servertools import ServeProcess, http_get

ROOT = Path(__file__).resolve().parent.parent
THREE_DIR = ROOT / "tests" / "node" / "node_modules" / "three"
CHROMIUM = "/usr/bin/chromium"
BRIDGE = str(ROOT / "tests" / "data" / "hdri" / "bridge.exr")

try:
    from playwright.sync_api import sync_playwright
except ImportError:  # pragma: no cover
    sync_playwright = None

pytestmark = [
    pytest.mark.skipif(sync_playwright is None, reason="playwright is not installed"),
    pytest.mark.skipif(not os.path.exists(CHROMIUM), reason=f"no {CHROMIUM}"),
    pytest.mark.skipif(not (THREE_DIR / "build" / "three.module.js").exists(),
                       reason="three.js not installed: npm ci --prefix tests/node"),
]

ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--no-first-run", "--disable-quic"]


def three_version() -> str:
    return json.loads((THREE_DIR / "package.json").read_text())["version"]


@pytest.fixture(scope="module")
def browser():
    with sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        try:
            yield b
        finally:
            b.close()


@contextmanager
def page_of(browser, url: str, tolerate: str | None = None):
    """A page on ``url`` whose CDN requests for three.js are answered from tests/node; on
    exit, asserts it logged no errors (but those matching ``tolerate``)."""
    page = browser.new_page(viewport={"width": 400, "height": 400})
    problems: list[str] = []
    page.on("console", lambda m: m.type == "error" and not (
        tolerate and re.search(tolerate, m.text)) and problems.append(m.text))
    page.on("pageerror", lambda e: problems.append(f"page error: {e}"))

    def three(route):
        name = route.request.url.rsplit("/", 1)[1]
        path = THREE_DIR / "build" / name
        if path.is_file():
            route.fulfill(path=str(path), content_type="text/javascript",
                          headers={"Access-Control-Allow-Origin": "*"})
        else:
            route.fulfill(status=404, body="not in the test fixture")
    page.route(re.compile(r"https://cdn\.jsdelivr\.net/npm/three@.*"), three)
    try:
        page.goto(url)
        yield page
        assert problems == [], "\n".join(problems)
    finally:
        page.close()


class PageHost:
    """A plain web page on another origin (another port) that imports the provider's
    client: the cross-origin case of an app hosted elsewhere."""

    PAGE = """<!doctype html><meta charset="utf-8"><title>host</title>
<script type="module">
const q = new URLSearchParams(location.search);
const m = await import(q.get("provider") + "/client.js");
window.m = m;
window.states = [];
window.count = 0;
window.conn = m.connect(q.get("provider") + "/", {
  probe: q.get("probe") || "*", token: q.get("token"), retryMax: 1,
  onState: (s, d) => window.states.push(s + (d ? " " + d : "")),
  onLighting: () => { window.count++; } });
</script>"""

    def __init__(self):
        body = self.PAGE.encode()

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *a):
                pass

            def do_GET(self):
                self.send_response(200)
                self.send_header("Content-Type", "text/html; charset=utf-8")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)
        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.origin = f"http://127.0.0.1:{self.httpd.server_address[1]}"
        threading.Thread(target=self.httpd.serve_forever, daemon=True).start()

    def close(self):
        self.httpd.shutdown()
        self.httpd.server_close()


def f32(values) -> np.ndarray:
    return np.asarray(values, np.float32).astype(np.float64)


def write_hemisphere(path: Path, side: str) -> None:
    """A 64×32 float panorama: radiance 1 on the +X (``right``) or −X hemisphere, 0
    elsewhere (u = 0.75 looks along +X, DESIGN.md §1)."""
    img = np.zeros((32, 64, 3), np.float32)
    if side == "right":
        img[:, 32:] = 1.0
    else:
        img[:, :32] = 1.0
    tmp = path.with_name("next-" + path.name)
    assert cv2.imwrite(str(tmp), img)
    os.replace(tmp, path)


def test_client_module_from_another_origin(browser, tmp_path):
    pano = tmp_path / "room.hdr"
    write_hemisphere(pano, "right")
    host = PageHost()
    try:
        with ServeProcess("--source", str(pano), "--keepalive", "60", "--stale-after", "0.5",
                          "--reconnect-max", "0.5", "--token", "s3cret",
                          "--allow-origin", host.origin) as proc:
            provider_url = proc.http
            status, headers, _ = http_get(provider_url + "/client.js")
            assert status == 200 and headers["Access-Control-Allow-Origin"] == "*"
            assert headers["Content-Type"].startswith("text/javascript")
            refused = r"WebSocket connection to .* failed"
            url = f"{host.origin}/?provider={provider_url}&probe=default&token=s3cret"
            with page_of(browser, url, tolerate=refused) as page:
                page.wait_for_function("window.conn && window.conn.state === 'live' "
                                       "&& window.conn.latest !== null", timeout=20000)
                held = page.evaluate("""() => { const l = window.conn.latest; return {
                    f32: l.coefficients instanceof Float32Array
                         && l.matrices instanceof Float32Array,
                    seq: l.seq, probe: l.probe, stale: window.conn.stale,
                    coefficients: Array.from(l.coefficients),
                    matrices: Array.from(l.matrices),
                    fromCoefficients: Array.from(window.m.matricesFromCoefficients(l.coefficients)),
                    e: [[1,0,0],[-1,0,0],[0,1,0],[0,0,-1],[0.6,0.48,0.64]].map(
                        n => window.m.irradiance(l.matrices, n)),
                    rotated: Array.from(window.m.rotateCoefficients(l.coefficients,
                        [0, 0, 1, 0, 1, 0, -1, 0, 0])),
                    hello: window.conn.hello.probes }; }""")
                status, _, body = http_get(provider_url + "/latest.json?token=s3cret")
                latest = json.loads(body)
                # What the page holds is what the server sent (as float32).
                assert held["f32"] and held["probe"] == "default" and held["seq"] == latest["seq"]
                assert held["stale"] is False and held["hello"] == ["default"]
                np.testing.assert_array_equal(held["coefficients"], f32(latest["coefficients"]))
                np.testing.assert_array_equal(held["matrices"], f32(latest["matrices"]))
                # The client's maths is the provider's: matrices, E(n), rotation.
                L = np.asarray(latest["coefficients"]).reshape(9, 3)
                M = np.asarray(latest["matrices"]).reshape(3, 4, 4)
                np.testing.assert_allclose(held["fromCoefficients"], M.reshape(-1),
                                           rtol=1e-5, atol=1e-6)
                normals = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, 0, -1],
                                    [0.6, 0.48, 0.64]])
                np.testing.assert_allclose(held["e"], sh.irradiance_from_matrices(M, normals),
                                           rtol=1e-5, atol=1e-5)
                assert held["e"][0][0] > 2.5 and abs(held["e"][1][0]) < 0.1   # lit at +X only
                R = np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]], float)     # +X → −Z
                np.testing.assert_allclose(np.reshape(held["rotated"], (9, 3)),
                                           sh.rotate_coefficients(L, R), rtol=1e-4, atol=1e-5)
                assert page.evaluate("window.conn.ping().then(p => p.rttMs >= 0)")

                # The source is lost: stale, the last lighting kept; it returns: live.
                pano.unlink()
                page.wait_for_function("window.conn.state === 'stale' && window.conn.stale",
                                       timeout=15000)
                assert page.evaluate("window.conn.latest.stale") is True
                write_hemisphere(pano, "left")
                page.wait_for_function("window.conn.state === 'live' && "
                                       "window.conn.latest.coefficients[9] < 0", timeout=15000)
            port = proc.port
        # The server goes away and comes back on the same port: the client reconnects.
        with ServeProcess("--source", str(pano), "--port", str(port), "--token", "s3cret",
                          "--allow-origin", host.origin) as proc:
            url = f"{host.origin}/?provider={proc.http}&token=s3cret"
            with page_of(browser, url, tolerate=refused) as page:
                page.wait_for_function("window.conn.state === 'live'", timeout=20000)
                proc.stop()
                page.wait_for_function("window.conn.state === 'down'", timeout=15000)
                assert "retrying in" in page.evaluate("window.conn.detail")
                assert page.evaluate("window.conn.stale") is True
                with ServeProcess("--source", str(pano), "--port", str(port), "--token",
                                  "s3cret", "--allow-origin", host.origin):
                    page.wait_for_function("window.conn.state === 'live' && "
                                           "window.states.filter(s => s === 'live').length >= 2",
                                           timeout=30000)
                page.evaluate("window.conn.close()")
                assert page.evaluate("window.conn.state") == "closed"
    finally:
        host.close()


def canvas_rgba(page) -> np.ndarray:
    png = base64.b64decode(page.evaluate("""() => { const s = window.shlight;
        s.renderer.render(s.scene, s.camera);
        return s.renderer.domElement.toDataURL('image/png'); }""").split(",", 1)[1])
    bgra = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
    return cv2.cvtColor(bgra, cv2.COLOR_BGRA2RGBA)


def srgb8(linear: float) -> float:
    v = min(max(linear, 0.0), 1.0)
    return 255 * (12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055)


def test_three_light_probe_one_sided_light(browser, tmp_path):
    """Radiance 1 on the +X hemisphere only: three.js's own getIrradianceAt gives our E(n)
    (π facing the light, 0 facing away), and its shader shows a white Lambertian sphere
    at ρE/π: lit on the +X side, dark on the −X side, 0.5 (sRGB 188) facing +Z."""
    pano = tmp_path / "half.hdr"
    write_hemisphere(pano, "right")
    ours = provider.compute_sh9(str(pano))
    with ServeProcess("--source", str(pano), "--keepalive", "60") as proc:
        with page_of(browser, proc.http + "/xr.html") as page:
            page.wait_for_function("window.shlight && window.shlight.conn.state === 'live' "
                                   "&& window.shlight.conn.latest !== null", timeout=20000)
            assert page.text_content("#status") == "live"
            # What the LightProbe holds equals the server's coefficients.
            held = page.evaluate("""() => window.shlight.lightProbe.sh.coefficients
                                      .flatMap(v => [v.x, v.y, v.z])""")
            status, _, body = http_get(proc.http + "/latest.json")
            latest = json.loads(body)
            np.testing.assert_array_equal(held, f32(latest["coefficients"]))
            assert page.evaluate("window.shlight.lightProbe.intensity") == 1
            np.testing.assert_allclose(latest["coefficients"], ours.coefficients.reshape(-1),
                                       rtol=1e-9, atol=1e-12)

            normals = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1],
                                [0, 0, -1], [0.6, 0.48, 0.64], [-0.36, 0.8, -0.48]])
            three_e = np.array(page.evaluate("""(normals) => {
                const { THREE, lightProbe } = window.shlight;
                return normals.map(n => { const e = lightProbe.sh.getIrradianceAt(
                    new THREE.Vector3(...n), new THREE.Vector3()); return [e.x, e.y, e.z]; }); }""",
                normals.tolist()))
            expected = sh.irradiance_from_matrices(ours.matrices, normals)
            np.testing.assert_allclose(three_e, expected, rtol=1e-5, atol=1e-5)
            assert three_e[0].min() > 0.95 * np.pi          # facing the lit hemisphere: ≈ π
            assert np.abs(three_e[1]).max() < 0.05 * np.pi  # facing away: ≈ 0

            # The shader: a white Lambertian sphere seen from +Z.
            page.evaluate("window.shlight.conn.close()")     # keep this lighting still
            rgba = canvas_rgba(page)
            h, w = rgba.shape[:2]
            row = rgba[h // 2]
            cols = np.flatnonzero(row[:, 3] > 0)                # the sphere on the middle row
            assert cols.size > w // 2
            edge = max(3, cols.size // 20)
            left = row[cols[:edge], :3].astype(float).mean()     # normals near −X
            right = row[cols[-edge:], :3].astype(float).mean()   # normals near +X
            assert right > 200 and left < 0.4 * right, (left, right)
            centre = rgba[h // 2 - 2: h // 2 + 3, w // 2 - 2: w // 2 + 3, :3].astype(float).mean()
            e_front = float(sh.irradiance_from_matrices(ours.matrices, np.array([[0, 0, 1.0]]))
                            .mean())
            assert abs(centre - srgb8(e_front / np.pi)) < 4, (centre, srgb8(e_front / np.pi))
            if os.environ.get("SHLIGHT_DOCS_SCREENSHOT"):
                cv2.imwrite(str(ROOT / "docs" / "xr_preview.png"),
                            cv2.cvtColor(rgba, cv2.COLOR_RGBA2BGRA))

            # The adapter's rotation: the room's +X light turned 90° (+X → −Z).
            turned = np.array(page.evaluate("""() => {
                const { THREE, lightProbe, conn } = window.shlight;
                return import('/client-three.js').then(a => {
                    a.setLightProbe(lightProbe, conn.latest, { rotation: [0,0,1, 0,1,0, -1,0,0] });
                    return [[0,0,-1],[0,0,1],[1,0,0]].map(n => { const e = lightProbe.sh
                        .getIrradianceAt(new THREE.Vector3(...n), new THREE.Vector3());
                        return e.x; }); }); }"""))
            assert turned[0] > 0.95 * np.pi and abs(turned[1]) < 0.05 * np.pi
            assert abs(turned[2] - expected[4].mean()) < 1e-3      # +X now sees what +Z saw


def test_fixture_three_version_matches_the_example_page():
    """The page loads three.js r187 from a CDN; the test fixture pins the same version."""
    page = (ROOT / "provider" / "live" / "static" / "xr.js").read_text()
    pinned = json.loads((ROOT / "tests" / "node" / "package.json").read_text())
    assert f'THREE_VERSION = "{pinned["dependencies"]["three"]}"' in page
    assert three_version() == pinned["dependencies"]["three"]
