"""The real replica of a hologram, for the three.js passthrough tests (issue 42's seed test).

A grey Lambertian sphere of albedo ρ stands in the room; the headset's camera records, at a
pixel that sees its surface of normal n, the code of its radiance ρ/π · E(n), E the irradiance
of the *true* panorama (a cosine-weighted integral over every pixel of it, not its SH9), through
the simulated headset's true curve, that view's true exposure and white balance and no
vignetting (the sphere is at the centre of the view). A hologram of the same sphere, lit by the
provider's SH9 and rendered through the fitted model, should show the same codes.
"""
from __future__ import annotations

import math

import cv2
import numpy as np


def pano_directions(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions (h, w, 3) of an equirect's pixel centres (docs/contract.md §1) and each
    pixel's solid angle (h, w)."""
    ys, xs = np.mgrid[0:h, 0:w]
    theta = math.pi * (ys + 0.5) / h
    phi = 2 * math.pi * ((xs + 0.5) / w - 0.5)
    d = np.stack([np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)], -1)
    return d, (2 * math.pi / w) * (math.pi / h) * np.sin(theta)


def irradiance(pano: np.ndarray, normals: np.ndarray, rows: int = 64) -> np.ndarray:
    """E(n) (n, 3) of an equirect panorama at unit normals (n, 3): Σ L · max(0, n·ω) dΩ over
    the panorama area-averaged to ``rows`` × 2·rows (the cosine lobe is smooth: a 2.8° pixel
    changes it by well under 1 %)."""
    small = cv2.resize(np.asarray(pano, np.float32), (2 * rows, rows),
                       interpolation=cv2.INTER_AREA).astype(np.float64)
    d, omega = pano_directions(rows, 2 * rows)
    weighted = (small * omega[..., None]).reshape(-1, 3)
    d = d.reshape(-1, 3)
    out = np.empty((len(normals), 3))
    for i in range(0, len(normals), 4096):
        cos = np.maximum(normals[i:i + 4096] @ d.T, 0.0)
        out[i:i + 4096] = cos @ weighted
    return out


def sphere_pixels(size: int, extent: float = 1.05, inner: float = 0.95):
    """An orthographic view of a unit sphere at the origin from +Z (+X right, +Y up), framed
    by ±``extent`` in ``size`` × ``size`` pixels, rows from the top: the mask of the pixels
    whose centre lies within ``inner`` of the sphere's radius (the rim, where a pixel mixes
    the sphere and the background, left out) and their normals (n, 3)."""
    c = (np.arange(size) + 0.5) / size * 2 * extent - extent
    x, y = np.meshgrid(c, -c)
    r2 = x * x + y * y
    mask = r2 < inner * inner
    normals = np.stack([x[mask], y[mask], np.sqrt(1 - r2[mask])], -1)
    return mask, normals


def replica_codes(camera, radiance: np.ndarray, exposure: float, wb) -> np.ndarray:
    """Continuous codes (n, 3) in [0, 255] the simulated headset's camera (a
    :class:`~provider.bench.camera_sim.CameraSim`) records of ``radiance`` (n, 3) at the view's
    true exposure and white balance, no vignetting, before rounding."""
    x = np.asarray(radiance, np.float64) * exposure * np.asarray(wb, np.float64) * camera.gain
    return 255.0 * camera.tone(x)


def stops(camera, codes: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """log2 of the light the *true* curve reads from ``codes`` over that of ``reference``
    (both (n, 3) codes): the issue's error in stops, per channel."""
    g = camera.true_response().table
    grid = np.arange(256, dtype=np.float64)
    return np.stack([np.log2(np.interp(codes[:, c], grid, g[:, c])
                             / np.interp(reference[:, c], grid, g[:, c])) for c in range(3)], -1)
