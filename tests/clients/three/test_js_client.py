"""The browser client (/client.js), the three.js adapter (/client-three.js) and the WebXR
example page (/xr.html) in a real headless Chromium against a live ``shlight serve``.

three.js is the npm package installed by scripts/test.sh into tests/node/node_modules (not
committed); the example page's CDN address for it is answered from that folder, so the
test needs no network. Checked: what the page holds equals what the server sent; the
client's maths (matrices, E(n), rotation) equals provider.core.geometry.sh; stale, reconnection;
and three.js's own SphericalHarmonics3.getIrradianceAt and its shader, fed through the
adapter, light a surface from the side the light is on, with the magnitude ρE/π.
"""
from __future__ import annotations

import json
import os

import cv2
import numpy as np

import provider
from provider.core.geometry import sh

from browsertools import (NEEDS_BROWSER, REFUSED, ROOT, PageHost, browser, canvas_rgba, f32,  # noqa: F401
                          page_of, sphere_row, srgb8, three_version, write_hemisphere)
from servertools import ServeProcess, http_get

pytestmark = NEEDS_BROWSER

#: A page on another origin that imports the provider's client (browsertools.PageHost).
CLIENT_PAGE = """<!doctype html><meta charset="utf-8"><title>host</title>
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


def test_client_module_from_another_origin(browser, tmp_path):
    pano = tmp_path / "room.hdr"
    write_hemisphere(pano, "right")
    host = PageHost(CLIENT_PAGE)
    try:
        with ServeProcess("--source", str(pano), "--keepalive", "60", "--stale-after", "0.5",
                          "--reconnect-max", "0.5", "--token", "s3cret",
                          "--allow-origin", host.origin) as proc:
            provider_url = proc.http
            status, headers, _ = http_get(provider_url + "/client.js")
            assert status == 200 and headers["Access-Control-Allow-Origin"] == "*"
            assert headers["Content-Type"].startswith("text/javascript")
            refused = REFUSED
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
                page.wait_for_function("window.conn && window.conn.state === 'live'", timeout=20000)
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
            left, right, centre = sphere_row(rgba)              # normals near −X, +X, +Z
            assert right > 200 and left < 0.4 * right, (left, right)
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
    page = (ROOT / "provider" / "live" / "server" / "static" / "xr.html").read_text()
    pinned = json.loads((ROOT / "tests" / "node" / "package.json").read_text())
    assert f'THREE_VERSION = "{pinned["dependencies"]["three"]}"' in page
    assert three_version() == pinned["dependencies"]["three"]
