"""three.js's LightProbeGrid filled from the server's grid (/probe-grid-three.js; docs/probes.md
"In the engines"), in a real headless Chromium against a live ``shlight serve`` with the eight
positioned probes of the analytic room (provider/bench/room.py) and ``--room``:

* the grid's atlas texture holds the server's SH9, packed as three r187's LightProbeGridWebGL
  packs its own bake, and lights the box half a step beyond the first and last points;
* a grey Lambertian sphere at a point, lit by the grid alone, shows ρE/π of the grid's light
  where three samples it, and ``shlight interpolate``'s light at the point within the grid's
  half-cell offset;
* connectPointLight follows the light at an object's position over the WebSocket.
"""
from __future__ import annotations

import json

import numpy as np

from browsertools import (NEEDS_BROWSER, PageHost, browser, canvas_rgba, f32, page_of,  # noqa: F401
                          srgb8, three_version)
from provider.core.geometry import sh
from roomtools import TOKEN, interpolate, serve_args
from servertools import ServerThread, http_get, poll

pytestmark = NEEDS_BROWSER

AT = np.array([3.0, 1.2, 1.2])            # the light changes slowly here: <1 % over 7 cm
STEP = 0.1
LO, HI = AT - 0.2, AT + 0.2                 # 5 × 5 × 5 points around the point
RADIUS, HALF_VIEW = 0.02, 0.025            # the sphere, and the orthographic camera's half width
SIZE = 400                                 # canvas pixels
ALBEDO = 0.1                               # the room's panels make E/π up to ~7: kept below 1

PAGE = """<!doctype html><meta charset="utf-8"><body style="margin:0">
<script type="importmap">{"imports": {
  "three": "https://cdn.jsdelivr.net/npm/three@%(v)s/build/three.module.js",
  "three/addons/": "https://cdn.jsdelivr.net/npm/three@%(v)s/examples/jsm/"}}</script>
<script type="module">
import * as THREE from "three";
import { LightProbeGridWebGL } from "three/addons/lighting/LightProbeGridWebGL.js";
import * as g from "/probe-grid-three.js";
const q = JSON.parse(decodeURIComponent(location.hash.slice(1)));
const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
renderer.setSize(q.size, q.size);
renderer.toneMapping = THREE.NoToneMapping;
document.body.appendChild(renderer.domElement);
const scene = new THREE.Scene();
const h = q.half;
const camera = new THREE.OrthographicCamera(-h, h, h, -h, 0.01, 10);
camera.position.set(q.at[0], q.at[1], q.at[2] + 1);    // seen from +Z: +X right
const sphere = new THREE.Mesh(new THREE.SphereGeometry(q.radius, 128, 64),
                              new THREE.MeshLambertMaterial({
  color: new THREE.Color().setRGB(q.albedo, q.albedo, q.albedo, THREE.LinearSRGBColorSpace) }));
sphere.position.set(...q.at);
scene.add(sphere);
window.grid = { THREE, renderer, scene, camera, sphere, g };
window.conn = g.connectProbeGrid(location.origin + "/", { THREE, scene, LightProbeGrid: LightProbeGridWebGL,
  min: q.min, max: q.max, step: q.step, token: q.token, refreshSeconds: 60 });
</script>"""


def _pack(grid):
    """Three r187's atlas (LightProbeGridWebGL.js): 7 sub-volumes of nz + 2 slices along z."""
    nx, ny, nz = grid["counts"]
    c = np.reshape(grid["coefficients"], (nz, ny, nx, 27))
    floats = np.concatenate([c, np.zeros((nz, ny, nx, 1))], -1)         # 28: c8 then a 0
    starts = [0, 4, 8, 12, 16, 20, 24]
    vols = []
    for s in starts:
        v = floats[..., s:s + 4]
        vols.append(np.concatenate([v[:1], v, v[-1:]]))                 # edge slices copied
    return np.concatenate(vols).reshape(-1)


def _trilinear(grid, p):
    """The grid's SH9 at ``p`` as a trilinear 3D texture gives it (clamped to the points)."""
    nx, ny, nz = grid["counts"]
    c = np.reshape(grid["coefficients"], (nz, ny, nx, 9, 3))
    f = np.clip((np.asarray(p) - grid["min"]) / grid["step"], 0, [nx - 1, ny - 1, nz - 1])
    i0 = np.minimum(np.floor(f).astype(int), [nx - 2, ny - 2, nz - 2])
    t = f - i0
    out = np.zeros((9, 3))
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                w = ((t[0] if dx else 1 - t[0]) * (t[1] if dy else 1 - t[1])
                     * (t[2] if dz else 1 - t[2]))
                out += w * c[i0[2] + dz, i0[1] + dy, i0[0] + dx]
    return out


def _linear(v8):
    v = v8 / 255
    return v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4


def test_a_sphere_in_the_grid_shows_the_light_at_its_point(browser, room_probes):
    page_html = PAGE % {"v": three_version()}
    with ServerThread(*serve_args(room_probes)) as srv:
        query = {"at": AT.tolist(), "min": LO.tolist(), "max": HI.tolist(), "step": STEP,
                 "token": TOKEN, "radius": RADIUS, "albedo": ALBEDO, "half": HALF_VIEW, "size": SIZE}
        url = f"{srv.http}/grid-test.html#" + json.dumps(query)
        grid_url = (f"{srv.http}/probe-grid.json?min={','.join(map(str, LO))}"
                    f"&max={','.join(map(str, HI))}&step={STEP}&token={TOKEN}")
        # the server answers 503 until every probe has its frame: the page comes after
        status, _, body = poll(lambda: (lambda r: r if r[0] != 503 else None)(http_get(grid_url)),
                               timeout=60, what="every probe's frame")
        assert status == 200, body
        with page_of(browser, "about:blank", viewport=(SIZE, SIZE)) as page:
            # the test page on the server's own origin (the grid is fetched from it)
            page.route(f"{srv.http}/grid-test.html", lambda route: route.fulfill(
                body=page_html, content_type="text/html"))
            page.goto(url)
            page.wait_for_function("window.conn && window.conn.latest !== null", timeout=90000,
                                   polling=500)
            held = page.evaluate("""() => { const p = window.conn.probeGrid; return {
                data: Array.from(p.texture.image.data), size: [p.texture.image.width,
                p.texture.image.height, p.texture.image.depth], res: p.resolution.toArray(),
                min: p.boundingBox.min.toArray(), max: p.boundingBox.max.toArray(),
                grid: window.conn.latest }; }""")
            rgba = canvas_rgba(page, holder="grid")
        grid = held["grid"]
        # the same frames, the same grid (a file source re-sends its frame)
        assert json.loads(body)["coefficients"] == grid["coefficients"]
    # the atlas: the server's numbers (as float32) where three's own bake puts them
    assert grid["counts"] == [5, 5, 5] and held["res"] == [5, 5, 5]
    assert held["size"] == [5, 5, 7 * (5 + 2)]
    np.testing.assert_array_equal(held["data"], f32(_pack(grid)))
    # the box it lights: the points are cell centres
    assert np.allclose(held["min"], LO - STEP / 2) and np.allclose(held["max"], HI + STEP / 2)

    # the sphere: pixels on its middle row at x = 0, ±0.8 r (normals +Z, (±0.8, 0, 0.6))
    # the server's grid points re-project 32-row panoramas (provider/live/probe/points.py GRID_ROWS)
    cli = np.reshape(interpolate(room_probes, AT, "--rows", "32")["coefficients"], (9, 3))
    row = rgba[SIZE // 2 - 1: SIZE // 2 + 1]
    for nx_ in (-0.8, 0.0, 0.8):
        n = np.array([nx_, 0.0, np.sqrt(1 - nx_ ** 2)])
        col = (nx_ * RADIUS / HALF_VIEW + 1) * SIZE / 2
        shown = row[:, int(col) - 1: int(col) + 2, :3].astype(float).mean(axis=(0, 1))
        # three samples the grid half a cell out along the normal (lightprobes_pars_fragment)
        sample = AT + n * RADIUS + n * STEP / 2
        e_grid = ALBEDO * sh.irradiance(_trilinear(grid, sample), n[None])[0] / np.pi
        # 8-bit sRGB output, the mean of a few pixels whose normals differ by a degree: 2 levels
        assert np.all(np.abs(shown - [srgb8(v) for v in e_grid]) <= 2.5), (nx_, shown, e_grid)
        # the light at the point itself (shlight interpolate): the grid's point there is the
        # command's (32 rows); three samples 7 cm away (radius + half a step), 8-bit sRGB: 4 %
        e_point = ALBEDO * sh.irradiance(cli, n[None])[0] / np.pi
        lin = np.array([_linear(v) for v in shown])
        print(f"n {n.round(2)}: shown {shown.round(1)}, grid {np.round([srgb8(v) for v in e_grid], 1)}"
              f", vs the point {np.round(lin / e_point - 1, 4)}")
        assert np.all(np.abs(lin / e_point - 1) < 0.04), (nx_, lin, e_point)


POINT_PAGE = """<!doctype html><meta charset="utf-8">
<script type="importmap">{"imports": {
  "three": "https://cdn.jsdelivr.net/npm/three@%(v)s/build/three.module.js"}}</script>
<script type="module">
import * as THREE from "three";
const q = JSON.parse(decodeURIComponent(location.hash.slice(1)));
const { connectPointLight } = await import(q.provider + "/probe-grid-three.js");
const scene = new THREE.Scene();
const holder = new THREE.Group();
holder.position.set(1, 0, 0);                  // the object's world position is what counts
const hologram = new THREE.Object3D();
hologram.position.set(q.at[0] - 1, q.at[1], q.at[2]);
holder.add(hologram);
scene.add(holder);
window.pt = { THREE, hologram, conn: connectPointLight(q.provider + "/", hologram,
                                                       { THREE, token: q.token }) };
</script>"""


def test_a_point_light_follows_an_object(browser, room_probes):
    at, moved = [3.0, 1.2, 1.2], [4.0, 1.0, 2.5]
    # an app's page on its own origin (a page the server answers through a test route is
    # "public" to Chromium, which then refuses it a loopback WebSocket)
    host = PageHost(POINT_PAGE % {"v": three_version()})
    try:
        with ServerThread(*serve_args(room_probes), "--allow-origin", host.origin) as srv:
            def light_at(p):
                status, _, body = poll(lambda: (lambda r: r if r[0] == 200 else None)(http_get(
                    f"{srv.http}/latest.json?at={','.join(map(str, p))}&token={TOKEN}")),
                    timeout=60, what="the light at the point")
                return json.loads(body)
            expected, expected_moved = light_at(at), light_at(moved)
            query = json.dumps({"at": at, "token": TOKEN, "provider": srv.http})
            with page_of(browser, f"{host.origin}/#{query}") as page:
                page.wait_for_function("window.pt && window.pt.conn.latest !== null",
                                       timeout=60000)
                held = page.evaluate("""() => ({ at: window.pt.conn.latest.position,
                    sh: window.pt.conn.lightProbe.sh.coefficients.flatMap(v => [v.x, v.y, v.z]),
                    inScene: window.pt.conn.lightProbe.parent !== null })""")
                # the object moves: after update() the probe holds the light where it is now
                page.evaluate(f"""() => {{ window.pt.hologram.position.set({moved[0] - 1},
                    {moved[1]}, {moved[2]}); window.pt.hologram.updateMatrixWorld();
                    window.pt.conn.update(); }}""")
                page.wait_for_function(f"window.pt.conn.latest.position[0] === {moved[0]}",
                                       timeout=60000)
                held_moved = page.evaluate("""() => window.pt.conn.lightProbe.sh.coefficients
                                              .flatMap(v => [v.x, v.y, v.z])""")
                page.evaluate("() => window.pt.conn.close()")
    finally:
        host.close()
    assert held["at"] == at and held["inScene"]
    # three's SphericalHarmonics3 holds the wire's coefficients (tests/clients/three/test_js_client.py), as
    # /latest.json?at= gives them for the point (JavaScript numbers: float64, unchanged)
    np.testing.assert_array_equal(held["sh"], expected["coefficients"])
    np.testing.assert_array_equal(held_moved, expected_moved["coefficients"])
