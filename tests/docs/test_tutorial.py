"""docs/tutorial.md as a user follows it: step 1's addresses answer on a real demo server, and
step 2's page, exactly as the tutorial prints it (only the server's port changed), lights
its sphere in headless Chromium from the side the room's light is on.

Step 2 runs against a file source instead of the animated demo, so that the test knows
where the light is (a hemisphere lit on +X); the page and the command line are the
tutorial's. Steps 3 and 4 need a camera and Unity: their commands and options are checked
by the CLI tests and test_unity*.py.
"""
from __future__ import annotations

import json
import re

import numpy as np

import provider
from provider.core.geometry import sh

from browsertools import (NEEDS_BROWSER, ROOT, PageHost, browser, canvas_rgba, page_of,  # noqa: F401
                          srgb8, write_hemisphere)
from servertools import PATIENCE, ServeProcess, connect, http_get, poll

TUTORIAL = (ROOT / "docs" / "tutorial.md").read_text()
PORT = "127.0.0.1:8765"


def _block(language: str) -> str:
    blocks = re.findall(rf"```{language}\n(.*?)```", TUTORIAL, re.S)
    assert len(blocks) == 1, f"the tutorial should hold one {language} block, not {len(blocks)}"
    return blocks[0]


def test_step_1_every_address_answers_on_the_demo():
    addresses = sorted(set(re.findall(rf"<http://{re.escape(PORT)}(/[^>]*)>", TUTORIAL)))
    assert {"/", "/healthz", "/latest.json"} <= set(addresses), addresses
    with ServeProcess() as proc:                      # the built-in demo source
        # The first frame is a moment after the port opens (/latest.json is 503 until then).
        poll(lambda: http_get(proc.http + "/latest.json")[0] == 200, 20 * PATIENCE,
             what="the demo's first message")
        for path in addresses:
            status, headers, body = http_get(proc.http + path)
            assert status == 200, (path, status)
        health = json.loads(http_get(proc.http + "/healthz")[2])
        assert health["status"] == "ok", health
        latest = json.loads(http_get(proc.http + "/latest.json")[2])
        assert len(latest["coefficients"]) == 27
        assert np.asarray(latest["matrices"]).size == 48


def _needs_browser(test):
    for mark in NEEDS_BROWSER:      # skipped with the reason where Chromium or three.js is not
        test = mark(test)
    return test


@_needs_browser
def test_step_2_the_page_lights_its_sphere_from_the_room(browser, tmp_path):  # noqa: F811
    """The tutorial's page on another origin, the server started with that origin allowed
    (as step 2 says): the LightProbe holds the server's coefficients, and the white matte
    sphere is bright on the lit +X side, dark on the other, ρE/π facing the camera."""
    pano = tmp_path / "room.hdr"
    write_hemisphere(pano, "right")
    ours = provider.compute_sh9(str(pano))
    assert "--allow-origin http://127.0.0.1:8000" in TUTORIAL
    host = PageHost("")
    try:
        with ServeProcess("--source", str(pano), "--allow-origin", host.origin) as proc:
            host.page = _block("html").replace(PORT, proc.http.split("//", 1)[1])
            with page_of(browser, host.origin + "/sphere.html", viewport=(400, 400)) as page:
                page.wait_for_function("""() => window.tutorial
                    && window.tutorial.connection.state === 'live'
                    && window.tutorial.connection.latest !== null""", timeout=20000)
                held = page.evaluate("""() => window.tutorial.probe.sh.coefficients
                                          .flatMap(v => [v.x, v.y, v.z])""")
                # float32 in the page: the server's float64 numbers rounded once.
                np.testing.assert_allclose(held, ours.coefficients.reshape(-1),
                                           rtol=1e-6, atol=1e-7)
                page.evaluate("window.tutorial.connection.close()")   # hold the light still
                rgba = canvas_rgba(page, holder="tutorial")
            left, right, centre = _sphere_row(rgba)         # normals near −X, +X, +Z
            assert right > 200 and left < 0.4 * right, (left, right)
            e_front = float(sh.irradiance_from_matrices(ours.matrices,
                                                        np.array([[0, 0, 1.0]])).mean())
            # 8-bit output of the sRGB-encoded ρE/π (ρ = 1): a code or two of rasterising.
            assert abs(centre - srgb8(e_front / np.pi)) < 4, (centre, srgb8(e_front / np.pi))

            # Without --allow-origin, the page's origin is refused (why step 2 restarts it).
        with ServeProcess("--source", str(pano)) as proc:
            try:
                with connect(proc.url, origin=host.origin):
                    raise AssertionError("a page from another origin was admitted")
            except Exception as exc:  # noqa: BLE001 - websockets' InvalidStatus
                assert "403" in str(exc), exc
    finally:
        host.close()


def _sphere_row(rgba: np.ndarray) -> tuple[float, float, float]:
    """(−X edge, +X edge, centre) brightness of the page's sphere on the middle row. Its
    canvas is opaque (no alpha to find the sphere by): the unit sphere 4 m from a 35° camera
    spans asin(1/4) / tan(17.5°) of the half-width, ±164 px of 400; the edges are read
    5-15 px inside it."""
    h, w = rgba.shape[:2]
    half = w / 2 * np.tan(np.arcsin(0.25)) / np.tan(np.radians(17.5))
    row = rgba[h // 2, :, :3].astype(float)
    lo, hi = int(w / 2 - half), int(w / 2 + half)
    left, right = row[lo + 5: lo + 15].mean(), row[hi - 15: hi - 5].mean()
    centre = rgba[h // 2 - 2: h // 2 + 3, w // 2 - 2: w // 2 + 3, :3].astype(float).mean()
    return left, right, centre
