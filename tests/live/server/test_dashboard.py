"""The dashboard (``GET /`` of ``shlight serve``) in a real headless Chromium.

A real ``shlight serve`` subprocess on a free loopback port, Debian's chromium driven by
Playwright: the page connects, the sphere lit by the live coefficients is drawn (brighter
on the side the light comes from), it changes when the lighting changes, the stale badge
shows while the source is lost and goes away when it returns, and the page logs no
console errors. Screenshots go to pytest's tmp dir; with ``SHLIGHT_DOCS_SCREENSHOT=1``
the demo screenshot is also written to docs/dashboard.png (for the README).
"""
from __future__ import annotations

import base64
import json
import os
import re
import time
import urllib.error
import urllib.request
from contextlib import ExitStack, contextmanager
from pathlib import Path

import cv2
import numpy as np
import pytest

from servertools import ServeProcess

from browsertools import CHROMIUM, ROOT, browser, page_of, sync_playwright  # noqa: F401

# The dashboard needs no three.js: only the browser half of browsertools.NEEDS_BROWSER.
pytestmark = [
    pytest.mark.skipif(sync_playwright is None,
                       reason="playwright is not installed (pip install playwright)"),
    pytest.mark.skipif(not os.path.exists(CHROMIUM),
                       reason=f"no {CHROMIUM} (apt-get install chromium)"),
]


# ---- a real server ------------------------------------------------------------------------------

@contextmanager
def shlight_serve(*args: str, port: int = 0):
    """Run ``shlight serve --port PORT ARGS`` (0: a free one), yield its base URL
    (http://127.0.0.1:PORT), and check that it stops cleanly."""
    with ServeProcess("--port", str(port), *args) as proc:
        yield proc.http
    assert proc.proc.returncode == 0, "shlight serve did not stop cleanly:\n" + proc.output


def write_panorama(path: Path, side: str) -> None:
    """A dark 64×32 equirect with one big white light at -X (``left``) or +X (``right``),
    written atomically (the image source re-reads the file when its mtime changes)."""
    img = np.full((32, 64, 3), 6, np.uint8)
    u0 = 0.25 if side == "left" else 0.75          # u = 0.25 looks along -X, 0.75 along +X
    c0, c1 = round((u0 - 0.1) * 64), round((u0 + 0.1) * 64)
    img[10:22, c0:c1] = 255
    tmp = path.with_name("next-" + path.name)
    assert cv2.imwrite(str(tmp), img)
    os.replace(tmp, path)
    ns = time.time_ns()
    os.utime(path, ns=(ns, ns))


# ---- the browser ------------------------------------------------------------------------------

@contextmanager
def open_dashboard(browser, url: str, tolerate: str | None = None):
    """The dashboard on ``url``, once it is live; on exit, asserts it logged no console
    errors (but those matching the regular expression ``tolerate``) and threw nothing."""
    with page_of(browser, url, tolerate, viewport=(1100, 760)) as page:
        page.wait_for_selector('#conn[data-state="live"]', timeout=15000)
        yield page


def canvas_pixels(page) -> np.ndarray:
    """The sphere canvas as an (H, W, 4) uint8 RGBA array (its own PNG, not the page)."""
    data_url = page.evaluate("document.getElementById('sphere').toDataURL('image/png')")
    png = base64.b64decode(data_url.split(",", 1)[1])
    bgra = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
    return cv2.cvtColor(bgra, cv2.COLOR_BGRA2RGBA)


def halves(rgba: np.ndarray) -> tuple[float, float]:
    """Mean brightness of the drawn sphere's left (-X) and right (+X) halves."""
    lum = rgba[..., :3].astype(np.float64).mean(axis=-1)
    drawn = rgba[..., 3] > 0
    w = rgba.shape[1]
    left, right = drawn[:, : w // 2], drawn[:, w // 2:]
    return float(lum[:, : w // 2][left].mean()), float(lum[:, w // 2:][right].mean())


def page_wait(page, expression: str, timeout: float = 30000):
    """Wait (up to ``timeout`` ms) until ``expression`` is true in the page. Playwright's
    wait_for_function compiles a string predicate with eval while it polls, which the
    dashboard's Content-Security-Policy (script-src 'self') refuses once the first look
    finds it false (a slow machine); page.evaluate is not subject to it."""
    return wait_for(lambda: page.evaluate(expression), timeout / 1000, expression)


def wait_for(predicate, timeout: float, what: str, interval: float = 0.1):
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value is not None and value is not False:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout} s waiting for {what}")
        time.sleep(interval)


def sphere_drawn(page) -> np.ndarray | None:
    rgba = canvas_pixels(page)
    drawn = rgba[..., 3] > 0
    # A disc of radius 128 covers π/4 of the 256² canvas; lit, not black.
    if drawn.mean() > 0.7 and rgba[..., :3][drawn].mean() > 20:
        return rgba
    return None


# ---- tests ------------------------------------------------------------------------------------

def test_sphere_follows_the_light_and_stale_badge(browser, tmp_path):
    pano = tmp_path / "room.png"
    write_panorama(pano, "left")
    with shlight_serve("--source", str(pano), "--fps", "10", "--stale-after", "0.5",
                       "--keepalive", "0.25", "--reconnect-max", "0.5") as base:
        with open_dashboard(browser, base + "/") as page:
            assert page.text_content("#conn") == "live"
            assert page.is_hidden("#probe-picker")              # one probe: no selector
            a = wait_for(lambda: sphere_drawn(page), 10, "the lit sphere")
            left, right = halves(a)
            assert left > 1.5 * right, f"light at -X, yet left {left:.1f} right {right:.1f}"

            # The numbers and bars are filled in.
            page_wait(
                page,
                "document.getElementById('s-compute').textContent.endsWith(' ms')")
            assert page.text_content("#s-latency").endswith("ms")
            assert page.text_content("#s-source") == "image"
            # What the numbers are: an 8-bit PNG decoded as sRGB, its patch clipped (255),
            # lights off; SH9's own error estimate is shown as a percentage.
            assert page.text_content("#s-radiometry") == "srgb-assumed"
            assert re.fullmatch(r"\d+\.\d % \(\d+\.\d % of the light\)",
                                page.text_content("#s-clipped"))
            assert page.text_content("#s-lights") == "off"
            # issue 31: no absolute scale here, so the light line says "relative" first
            assert page.text_content("#s-photometry").startswith("relative")
            page_wait(
                page,
                "document.getElementById('s-error').textContent.endsWith(' %')")
            l00 = page.eval_on_selector("#bar-0", "e => parseFloat(e.style.width)")
            assert l00 > 0
            page_wait(
                page,
                "document.getElementById('thumb').naturalWidth === 64", timeout=20000)
            assert page.is_hidden("#stale")
            page.screenshot(path=str(tmp_path / "dashboard-left.png"))

            # The light moves to +X: the sphere follows within a few frames.
            write_panorama(pano, "right")

            def lit_from_right():
                rgba = canvas_pixels(page)
                l, r = halves(rgba)
                return rgba if r > 1.5 * l else None
            b = wait_for(lit_from_right, 10, "the sphere to be lit from +X")
            diff = np.abs(a[..., :3].astype(int) - b[..., :3].astype(int)).mean()
            assert diff > 10, f"screenshots barely differ ({diff:.2f})"

            # The source is lost: the last lighting stays, marked stale with its age.
            pano.unlink()
            page.wait_for_selector("#stale", state="visible", timeout=10000)
            assert re.search(r"STALE · last frame \d+\.\d s ago", page.text_content("#stale"))
            # still connected, but not the green "live" beside the red STALE
            assert page.get_attribute("#conn", "data-state") == "connected"
            assert page.text_content("#conn") == "connected"
            c = canvas_pixels(page)
            assert halves(c)[1] > 1.5 * halves(c)[0]              # still the last lighting
            page.screenshot(path=str(tmp_path / "dashboard-stale.png"))

            # It comes back: fresh again, without reloading anything.
            write_panorama(pano, "left")
            page.wait_for_selector("#stale", state="hidden", timeout=10000)
            assert page.text_content("#conn") == "live"
            wait_for(lambda: (lambda l, r: l > 1.5 * r)(*halves(canvas_pixels(page))), 10,
                     "the sphere to be lit from -X again")


def test_demo_with_token_and_two_probes(browser, tmp_path):
    with shlight_serve("--probe", "room=demo", "--probe", "desk=demo",
                       "--token", "s3cret", "--lights", "auto") as base:
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(base + "/", timeout=5)
        assert refused.value.code == 401
        # The page passes its ?token= on to the WebSocket and the thumbnail.
        with open_dashboard(browser, base + "/?token=s3cret") as page:
            assert page.is_visible("#probe-picker")
            assert page.eval_on_selector_all("#probe option", "os => os.map(o => o.value)") \
                == ["room", "desk"]
            first = wait_for(lambda: sphere_drawn(page), 10, "the lit sphere")
            # Sky and sun above, brown ground below: the top of the sphere (+Y) is brighter.
            lum, drawn = first[..., :3].mean(axis=-1), first[..., 3] > 0
            top, bottom = lum[:128][drawn[:128]].mean(), lum[128:][drawn[128:]].mean()
            assert top > 1.1 * bottom, f"top {top:.1f}, bottom {bottom:.1f}"
            # The demo's sun becomes a light, and the page says what it bought.
            page_wait(
                page,
                "/^[1-4] · error \\d+\\.\\d % \\(SH9 alone \\d+\\.\\d %\\)$/"
                ".test(document.getElementById('s-lights').textContent)", timeout=20000)
            page_wait(
                page,
                "document.getElementById('thumb').naturalWidth > 0", timeout=20000)
            # The demo's sun circles the horizon: the sphere changes by itself.
            second = wait_for(
                lambda: (lambda s: s if np.abs(s[..., :3].astype(int) - first[..., :3]).max() > 8
                         else None)(canvas_pixels(page)), 10, "the demo lighting to change",
                interval=0.3)
            assert second is not None
            page.select_option("#probe", "desk")
            page_wait(page, "document.getElementById('s-probe').textContent === 'desk'")
            page.select_option("#probe", "room")
            page_wait(page, "document.getElementById('s-probe').textContent === 'room'")
            seq = page.text_content("#s-seq")              # a fresh message of the room's
            page_wait(page, f"document.getElementById('s-seq').textContent !== {json.dumps(seq)}")
            shot = tmp_path / "dashboard-demo.png"
            page.screenshot(path=str(shot))
            assert shot.stat().st_size > 10_000
            if os.environ.get("SHLIGHT_DOCS_SCREENSHOT"):
                (ROOT / "docs").mkdir(exist_ok=True)
                page.screenshot(path=str(ROOT / "docs" / "dashboard.png"), full_page=True)


def test_reconnects_after_a_server_restart(browser):
    with ExitStack() as first_server:
        base = first_server.enter_context(shlight_serve())
        port = int(base.rsplit(":", 1)[1])
        # While the server is away, Chromium itself logs each refused attempt, and a fetch
        # of the page's (its status poll) under way as the server closes or while it is
        # away fails with a reset or refused connection: only those are tolerated.
        refused = (r"WebSocket connection to .* failed.*ERR_CONNECTION_REFUSED"
                   r"|^Failed to load resource: net::ERR_CONNECTION_(REFUSED|RESET)$")
        with open_dashboard(browser, base + "/", tolerate=refused) as page:
            first_server.close()                                  # the server goes away
            page.wait_for_selector('#conn[data-state="down"]', timeout=20000)
            assert "retrying in" in page.text_content("#conn")
            # a refused attempt: the dashboard doubles its wait and says so
            down = page.text_content("#conn")
            page_wait(page, f"document.getElementById('conn').textContent !== {json.dumps(down)}")
            with shlight_serve(port=port):
                page.wait_for_selector('#conn[data-state="live"]', timeout=20000)
                wait_for(lambda: sphere_drawn(page), 10, "the lit sphere after reconnecting")
