"""Helpers for the browser tests (tests/clients/three/test_js_client.py, tests/clients/three/test_xr_polyfill.py,
tests/live/server/test_dashboard.py): a
real headless Chromium driven by Playwright, three.js from tests/node/node_modules answered
in place of its CDN, a page host on another origin, and test panoramas.

three.js is the npm package installed by scripts/test.sh into tests/node/node_modules (not
committed); the pages' CDN addresses for it (build/ and examples/jsm/) are answered from
that folder, so the tests need no network.
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

ROOT = Path(__file__).resolve().parent.parent
THREE_DIR = ROOT / "tests" / "node" / "node_modules" / "three"
CHROMIUM = "/usr/bin/chromium"
CDN = re.compile(r"https://cdn\.jsdelivr\.net/npm/three@[^/]+/(.*)")

try:
    from playwright.sync_api import sync_playwright
except ImportError:  # pragma: no cover
    sync_playwright = None

#: pytestmark of a browser test module: what it needs, else skipped with the reason.
NEEDS_BROWSER = [
    pytest.mark.skipif(sync_playwright is None, reason="playwright is not installed"),
    pytest.mark.skipif(not os.path.exists(CHROMIUM), reason=f"no {CHROMIUM}"),
    pytest.mark.skipif(not (THREE_DIR / "build" / "three.module.js").exists(),
                       reason="three.js not installed: npm ci --prefix tests/node"),
]

ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--no-first-run", "--disable-quic"]

#: What Chromium logs as a console error, by itself, when a WebSocket cannot connect.
REFUSED = r"WebSocket connection to .* failed"


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
def page_of(browser, url: str, tolerate: str | None = None, console: list | None = None,
            viewport: tuple[int, int] = (400, 400)):
    """A page on ``url`` whose CDN requests for three.js are answered from tests/node; on
    exit, asserts it logged no errors and had no uncaught errors or unhandled rejections
    (but console errors matching ``tolerate``). ``console``: a list that collects
    (type, text) of every console message."""
    page = browser.new_page(viewport={"width": viewport[0], "height": viewport[1]})
    problems: list[str] = []

    def on_console(m):
        if console is not None:
            console.append((m.type, m.text))
        if m.type == "error" and not (tolerate and re.search(tolerate, m.text)):
            problems.append(m.text)
    page.on("console", on_console)
    page.on("pageerror", lambda e: problems.append(f"page error: {e}"))

    def three(route):
        rest = CDN.match(route.request.url).group(1)
        path = (THREE_DIR / rest).resolve()
        if path.is_file() and THREE_DIR.resolve() in path.parents:
            route.fulfill(path=str(path), content_type="text/javascript",
                          headers={"Access-Control-Allow-Origin": "*"})
        else:
            route.fulfill(status=404, body="not in the test fixture")
    page.route(CDN, three)
    try:
        page.goto(url)
        yield page
        assert problems == [], "\n".join(problems)
    finally:
        page.close()


class PageHost:
    """A plain web page on another origin (another port): the cross-origin case of an app
    hosted elsewhere that imports the provider's modules. ``page``: its HTML, which may be
    replaced later (``host.page = ...``: a page that names a server started after the host)."""

    def __init__(self, page: str):
        self.page = page
        host = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *a):
                pass

            def do_GET(self):
                body = host.page.encode()
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
    """``values`` rounded to float32 as a page holds them (compared as float64)."""
    return np.asarray(values, np.float32).astype(np.float64)


def write_hemisphere(path: Path, side: str) -> None:
    """A 64×32 float panorama: radiance 1 on the +X (``right``) or −X hemisphere, 0
    elsewhere (u = 0.75 looks along +X, docs/contract.md §1). Written under another name and
    renamed, so that a file source never reads half a file."""
    img = np.zeros((32, 64, 3), np.float32)
    if side == "right":
        img[:, 32:] = 1.0
    else:
        img[:, :32] = 1.0
    tmp = path.with_name("next-" + path.name)
    assert cv2.imwrite(str(tmp), img)
    os.replace(tmp, path)


def canvas_rgba(page, holder: str = "shlight") -> np.ndarray:
    """The page's canvas, rendered now, as RGBA: ``window[holder]`` holds its ``renderer``,
    ``scene`` and ``camera`` (the example page's is window.shlight)."""
    png = base64.b64decode(page.evaluate(f"""() => {{ const s = window.{holder};
        s.renderer.render(s.scene, s.camera);
        return s.renderer.domElement.toDataURL('image/png'); }}""").split(",", 1)[1])
    bgra = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
    return cv2.cvtColor(bgra, cv2.COLOR_BGRA2RGBA)


def srgb8(linear: float) -> float:
    v = min(max(linear, 0.0), 1.0)
    return 255 * (12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055)


def sphere_row(rgba: np.ndarray) -> tuple[float, float, float]:
    """(left edge, right edge, centre) brightness of the white sphere the example page
    draws at the centre of its canvas, seen from +Z: normals near −X, +X and +Z."""
    h, w = rgba.shape[:2]
    row = rgba[h // 2]
    cols = np.flatnonzero(row[:, 3] > 0)                # the sphere on the middle row
    assert cols.size > w // 2, "no sphere drawn"
    edge = max(3, cols.size // 20)
    left = row[cols[:edge], :3].astype(float).mean()
    right = row[cols[-edge:], :3].astype(float).mean()
    centre = rgba[h // 2 - 2: h // 2 + 3, w // 2 - 2: w // 2 + 3, :3].astype(float).mean()
    return left, right, centre
