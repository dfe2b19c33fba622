"""The passthrough consumers' references, written from docs/contract.md §15 (tests only).

* :func:`display_lut`: the 256-entry display lookup a consumer renders a hologram through, from a
  camera.json table (the contract's definition, written again so that a slip in the C# cannot
  cancel out).
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

LUT_SIZE = 256
MAX_RANGE_STOPS = 24.0


def display_lut(table) -> tuple[float, float, np.ndarray]:
    """(log2_lo, log2_hi, lut (256, 3)) of an inverse response table g (codes, 3): entry j,
    channel c is g_c⁻¹(2^(lo + (hi − lo)·j/255)) / (codes − 1), g made non-decreasing;
    hi = log2 max_c g_c(last), lo = log2 min_c g_c(0), at most 24 stops below hi."""
    g = np.maximum.accumulate(np.asarray(table, np.float64), axis=0)
    n = g.shape[0]
    hi = math.log2(g[-1].max())
    bottom = g[0].min()
    lo = max(math.log2(bottom), hi - MAX_RANGE_STOPS) if bottom > 0 else hi - MAX_RANGE_STOPS
    x = 2.0 ** (lo + (hi - lo) * np.arange(LUT_SIZE) / (LUT_SIZE - 1))
    codes = np.arange(n, dtype=np.float64)
    lut = np.stack([np.interp(x, g[:, c], codes) for c in range(3)], -1) / (n - 1)
    return lo, hi, lut


def lut_display(lo, hi, lut, x) -> np.ndarray:
    """The lookup at sensor exposures x (..., 3): t = clamp((log2 x − lo)/(hi − lo)), entries
    at t·255 linearly interpolated (what the shaders' bilinear 256-texel texture gives)."""
    t = np.clip((np.log2(np.maximum(np.asarray(x, np.float64), 1e-30)) - lo) / (hi - lo), 0, 1)
    t = t * (LUT_SIZE - 1)
    return np.stack([np.interp(t[..., c], np.arange(LUT_SIZE), lut[:, c]) for c in range(3)], -1)


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
