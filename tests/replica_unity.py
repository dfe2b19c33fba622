"""The Unity passthrough tests' real replica, written from docs/contract.md §15 (tests only; the display
lookup's reference is the library's, provider/core/passthrough/display.py).

* The hologram beside its real replica: a grey Lambertian sphere of known albedo at the centre
  of a simulated headset's view (provider/bench/headset_sim.py). :func:`sphere_pixels` gives its
  visible pixels' normals (world frame) and their distance from the principal point;
  :func:`replica_codes` the codes the headset records for the *real* sphere: radiance
  albedo/π · E(n), E integrated straight from the true panorama's pixels (no SH), through the
  simulation's true exposure, white balance, vignetting and curve, 8-bit.
* :func:`stops_apart`: the issue's error in stops between two codes, both turned into light by
  the headset's *true* curve, per channel.
"""
from __future__ import annotations

import math

import numpy as np

from reference import brute_irradiance


def sphere_pixels(view, rotation, radius: float = 0.1, step_px: float = 2.0):
    """The visible pixels of a sphere centred in ``view`` (its disc's radius ``radius`` of the
    half-diagonal), seen along the camera's true ``rotation`` (camera-to-world, OpenGL axes):
    (normals (n, 3) world frame, rho2 (n,)). A small sphere far off: seen orthographically."""
    half_diag = 0.5 * math.hypot(view.w, view.h)
    r_px = radius * half_diag
    k = np.arange(-r_px, r_px + step_px, step_px)
    dx, dy = np.meshgrid(k, k)
    u, v = dx / r_px, -dy / r_px                     # image y down, the sphere's v up
    inside = u * u + v * v < 0.98                    # not the grazing rim
    u, v = u[inside], v[inside]
    w = np.sqrt(1 - u * u - v * v)
    right, up, back = rotation[:, 0], rotation[:, 1], rotation[:, 2]
    normals = u[:, None] * right + v[:, None] * up + w[:, None] * back
    rho2 = (dx[inside] ** 2 + dy[inside] ** 2) / half_diag ** 2
    return normals, rho2


def true_irradiance(panorama, normals) -> np.ndarray:
    """E(n) (n, 3) summed straight from the panorama's pixels (no SH)."""
    return np.concatenate([brute_irradiance(panorama, normals[i:i + 64])
                           for i in range(0, len(normals), 64)])


def replica_codes(truth, view: int, irradiance, rho2, albedo: float,
                  vignetting: float = 0.35) -> np.ndarray:
    """The 8-bit codes (n, 3) the simulated headset records in view ``view`` for the real
    grey sphere whose pixels see ``irradiance`` (:func:`true_irradiance`) (module doc)."""
    radiance = albedo / math.pi * np.asarray(irradiance, np.float64)
    x = radiance * truth.exposure[view] * truth.wb_gains[view] * (1 - vignetting * rho2)[:, None]
    return truth.camera.capture(x[None], 1.0)[0].astype(np.float64)


def stops_apart(truth, codes_a, codes_b) -> np.ndarray:
    """log2(g(a) / g(b)) per channel, g the headset's true curve (the issue's score)."""
    g = truth.camera.true_response().table
    k = np.arange(g.shape[0], dtype=np.float64)
    return np.stack([np.log2(np.interp(codes_a[..., c], k, g[:, c])
                             / np.interp(codes_b[..., c], k, g[:, c])) for c in range(3)], -1)
