"""What ``shlight serve`` shows over plain HTTP: the dashboard's files and panorama
thumbnails (/healthz and /metrics: :mod:`provider.live.server.status`).

The server routes requests here (see :mod:`provider.live.server.service`); nothing in this module
touches the network.
"""
from __future__ import annotations

import math
from importlib import resources

import cv2
import numpy as np

CONTENT_TYPES = {".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8",
                 ".css": "text/css; charset=utf-8", ".svg": "image/svg+xml",
                 ".png": "image/png", ".ico": "image/x-icon", ".json": "application/json"}

#: Content-Security-Policy of the dashboard: its own files only (no CDN), its own
#: WebSocket, thumbnails from itself.
DASHBOARD_CSP = ("default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data: blob:; "
                 "connect-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'")


#: Public files served at the top level without a token (the browser client, its three.js
#: adapter, the WebXR lighting-estimation polyfill, the WebXR example page, the passthrough tone
#: mapping and camera sender), and the origins
#: that may import them: any (they hold no secret; ES modules are fetched with CORS).
PUBLIC_FILES = {"/client.js": "client.js", "/client-three.js": "client-three.js",
                "/xr-lighting-polyfill.js": "xr-lighting-polyfill.js", "/xr.html": "xr.html",
                "/passthrough.js": "passthrough.js", "/probe-grid-three.js": "probe-grid-three.js"}
PUBLIC_HEADERS = [("Access-Control-Allow-Origin", "*")]


def static_file(name: str) -> tuple[bytes, str] | None:
    """(body, content type) of a file of provider/live/server/static, or None.

    Only plain file names listed in the package directory are served: no paths, so no
    traversal.
    """
    if not name or "/" in name or "\\" in name or name.startswith("."):
        return None
    ext = "." + name.rsplit(".", 1)[-1].lower() if "." in name else ""
    if ext not in CONTENT_TYPES:
        return None
    entry = resources.files("provider.live.server").joinpath("static", name)
    if not entry.is_file():
        return None
    return entry.read_bytes(), CONTENT_TYPES[ext]


def tone_map(image: np.ndarray) -> np.ndarray:
    """An 8-bit sRGB picture of a frame: integer frames as they are; float (HDR) frames
    exposed so that the mean luminance lands at mid-grey, then ``1 − e^(−x)`` and the
    sRGB curve."""
    if image.dtype == np.uint8:
        return image
    if image.dtype == np.uint16:
        return (image >> 8).astype(np.uint8)
    x = np.nan_to_num(image.astype(np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    x = np.maximum(x, 0)
    lum = float(np.mean(x @ np.float32([0.2126, 0.7152, 0.0722]))) if x.size else 0.0
    x *= 0.5 / lum if lum > 0 and math.isfinite(lum) else 1.0
    x = 1.0 - np.exp(-x)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return np.clip(srgb * 255 + 0.5, 0, 255).astype(np.uint8)


def thumbnail_jpeg(image: np.ndarray, width: int = 512, quality: int = 80) -> bytes:
    """A JPEG of an RGB frame at most ``width`` pixels wide (tone-mapped if HDR)."""
    h, w = image.shape[:2]
    if w > width:
        image = cv2.resize(image, (width, max(1, round(h * width / w))),
                           interpolation=cv2.INTER_AREA)
    rgb = tone_map(image)
    ok, buf = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR),
                           [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:  # pragma: no cover - OpenCV always encodes JPEG
        raise RuntimeError("JPEG encoding failed")
    return buf.tobytes()
