"""The tests' own renderer: printed markers composited into the shared panoramas at known poses.

Independent of the code under test (provider.core.geometry.sphere_views, provider.core.registration.pose):
the scene is resampled into a projection through the projection's forward map only
(``pixel_to_direction``, what the engine itself trusts), and the marker is ray-traced: each
pixel's sub-pixel directions are intersected with the marker's plane and look up the printed
pattern (white paper with a quiet zone, ink reflecting 5 %), averaged over the pixel
(anti-aliased, as a camera's pixel integrates light).
"""
from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from provider.core.radiometry.images import read_image

HDRI = Path(__file__).resolve().parent / "data" / "hdri"


def equirect_lookup(pano: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Bilinear samples of an equirect panorama (contract §1) along unit directions d (..., 3)."""
    h, w = pano.shape[:2]
    theta = np.arccos(np.clip(d[..., 1], -1, 1))
    phi = np.arctan2(d[..., 0], -d[..., 2])
    u = (phi / (2 * np.pi) + 0.5) * w - 0.5
    v = theta / np.pi * h - 0.5
    src = cv2.copyMakeBorder(pano, 2, 2, 2, 2, cv2.BORDER_WRAP)
    return cv2.remap(src, np.mod(u, w).astype(np.float32) + 2, v.astype(np.float32) + 2,
                     cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def scene(name: str, projection) -> np.ndarray:
    """The shared panorama ``name`` (float RGB, linear) as seen through ``projection``."""
    pano = read_image(HDRI / f"{name}.exr")
    py, px = np.mgrid[0:projection.height, 0:projection.width] + 0.5
    d, valid = projection.pixel_to_direction(px, py)
    out = equirect_lookup(pano, np.where(valid[..., None], d, [0, 0, -1.0]))
    return np.where(valid[..., None], out, 0).astype(np.float32)


def marker_grid(dictionary: str = "DICT_4X4_50", marker_id: int = 7) -> np.ndarray:
    d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, dictionary))
    return cv2.aruco.generateImageMarker(d, marker_id, d.markerSize + 2, borderBits=1)


def qr_grid(text: str) -> np.ndarray:
    """A QR code's modules, one pixel each (0 black), without the quiet zone."""
    img = cv2.QRCodeEncoder.create().encode(text)
    img = img[np.any(img == 0, axis=1)][:, np.any(img == 0, axis=0)]
    return np.where(img > 127, 255, 0).astype(np.uint8)


def random_pose(rng, distance=(0.8, 2.0), max_tilt_deg=60.0, around=None, max_off_deg=180.0):
    """(R, t): R's columns are the marker's x, y, z in the camera frame, t its centre (m).
    The marker faces the camera, tilted up to ``max_tilt_deg`` from facing it squarely."""
    while True:
        c = rng.normal(size=3)
        c /= np.linalg.norm(c)
        if around is None or math.degrees(math.acos(np.clip(c @ around, -1, 1))) <= max_off_deg:
            break
    t = c * rng.uniform(*distance)
    z = -c
    axis = np.cross(z, rng.normal(size=3))
    axis /= np.linalg.norm(axis)
    z = cv2.Rodrigues(axis * math.radians(rng.uniform(0, max_tilt_deg)))[0] @ z
    a = np.cross(z, rng.normal(size=3))
    x = a / np.linalg.norm(a)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1), t


def composite(image, projection, grid, R, t, size, *, quiet=1.0, white=None, ink=0.05,
              samples=4) -> np.ndarray:
    """``image`` (H, W, 3 float, linear) with a printed ``grid`` (cells, 0 black) of side
    ``size`` m at pose (R, t): the paper (quiet zone ``quiet`` cells around) has radiance
    ``white`` (default: 0.8 × the scene's mean), the ink ``ink`` × that."""
    out = np.array(image, np.float32, copy=True)
    if white is None:
        white = 0.8 * out.reshape(-1, 3).mean(0)
    white = np.broadcast_to(np.asarray(white, np.float32), (3,))
    cells = grid.shape[0]
    cell = size / cells
    half = size / 2 + quiet * cell
    R, t = np.asarray(R, float), np.asarray(t, float)
    n = R[:, 2]
    centre = t / np.linalg.norm(t)
    reach = math.asin(min(1.0, half * math.sqrt(2) / np.linalg.norm(t))) + 0.02
    h, w = out.shape[:2]
    offsets = (np.arange(samples) + 0.5) / samples
    for r0 in range(0, h, 64):
        py, px = np.mgrid[r0:min(h, r0 + 64), 0:w] + 0.5
        d, valid = projection.pixel_to_direction(px, py)
        near = valid & (d @ centre > math.cos(reach))
        if not near.any():
            continue
        qx, qy = px[near] - 0.5, py[near] - 0.5
        cover = np.zeros(qx.shape)
        paper = np.zeros(qx.shape)
        for oy in offsets:
            for ox in offsets:
                ds, ok = projection.pixel_to_direction(qx + ox, qy + oy)
                denom = ds @ n
                lam = np.where(np.abs(denom) > 1e-9, (t @ n) / np.where(denom == 0, 1, denom), -1)
                local = (ds * lam[:, None] - t) @ R
                inside = ok & (lam > 0) & (np.abs(local[:, 0]) < half) & (np.abs(local[:, 1]) < half)
                col = np.floor((local[:, 0] + size / 2) / cell).astype(int)
                row = np.floor((size / 2 - local[:, 1]) / cell).astype(int)
                on_grid = (col >= 0) & (col < cells) & (row >= 0) & (row < cells)
                value = np.ones(qx.shape)
                value[on_grid] = np.where(grid[row[on_grid], col[on_grid]] > 127, 1.0, ink)
                cover += inside
                paper += inside * value
        cover /= samples * samples
        paper /= samples * samples
        block = out[r0:r0 + px.shape[0]]
        sel = block[near]
        block[near] = sel * (1 - cover[:, None]) + paper[:, None] * white[None]
    return out


def to_srgb8(image: np.ndarray, white: float) -> np.ndarray:
    """8-bit sRGB encoding of linear ``image`` with ``white`` at 0.8 of full scale (a JPEG
    still, exposed for the paper)."""
    c = np.clip(np.asarray(image, np.float64) * (0.8 / white), 0, 1)
    e = np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)
    return (e * 255 + 0.5).astype(np.uint8)


def rotation_error_deg(R_est, R_true) -> float:
    c = (np.trace(np.asarray(R_est).T @ np.asarray(R_true)) - 1) / 2
    return math.degrees(math.acos(np.clip(c, -1, 1)))
