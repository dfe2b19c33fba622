"""Scenes rendered into the projections, for the projection tests: a smooth analytic
environment, its lighting from a supersampled equirect panorama (tests/reference.py), and
the image a camera records of it through the light-probe formats, from each format's own
definition."""
import numpy as np

from provider.core.geometry.projections_probe import AngularMap, CubeCross

import reference as ref


LIGHT = np.array([0.4, 0.75, -0.53]) / np.linalg.norm([0.4, 0.75, -0.53])


def smooth_env(d):
    """A smooth, colourful, non-negative environment: sky gradient + a broad warm lobe."""
    lobe = np.exp(8 * (d @ LIGHT - 1))
    base = 0.5 + 0.3 * d[..., 1] + 0.1 * d[..., 0]
    return np.stack([base + 5 * lobe, base + 3 * lobe, 0.8 * base + lobe], axis=-1)


def equirect_reference(env=smooth_env, mask=None):
    img = ref.render_equirect(lambda d: env(d) * (1 if mask is None else mask(d)[..., None]),
                              1024, 512, supersample=2)
    return ref.project_equirect(img)


# Directions written again from the physics, independently of provider/: a slip in the
# projections cannot cancel out between rendering and projecting.
CROSS_FACES = {  # name: (axis, image right, image up), seen from inside the cube
    "front": ((0, 0, -1), (1, 0, 0), (0, 1, 0)), "left": ((-1, 0, 0), (0, 0, -1), (0, 1, 0)),
    "right": ((1, 0, 0), (0, 0, 1), (0, 1, 0)), "back": ((0, 0, 1), (-1, 0, 0), (0, 1, 0)),
    "up": ((0, 1, 0), (1, 0, 0), (0, 0, 1)), "down": ((0, -1, 0), (1, 0, 0), (0, 0, -1)),
    "back-under": ((0, 0, 1), (1, 0, 0), (0, -1, 0))}


CROSS_CELLS = {"horizontal": {(1, 0): "up", (0, 1): "left", (1, 1): "front", (2, 1): "right",
                              (3, 1): "back", (1, 2): "down"},
               "vertical": {(1, 0): "up", (0, 1): "left", (1, 1): "front", (2, 1): "right",
                            (1, 2): "down", (1, 3): "back-under"}}


def physical_directions(p, px, py):
    """Unit directions seen at pixel coordinates, from each format's definition."""
    if isinstance(p, CubeCross):
        n = p.face
        col, row = np.floor(px / n), np.floor(py / n)
        a, b = 2 * (px - col * n) / n - 1, 2 * (py - row * n) / n - 1
        d = np.zeros(px.shape + (3,))
        for (c, r), name in CROSS_CELLS[p.layout].items():
            f, right, up = (np.array(v, float) for v in CROSS_FACES[name])
            here = ((col == c) & (row == r))[..., None]
            d = np.where(here, f + a[..., None] * right - b[..., None] * up, d)
        return d / np.maximum(np.linalg.norm(d, axis=-1, keepdims=True), 1e-12)
    u, v = (px - p.cx) / p.r, (p.cy - py) / p.r
    if isinstance(p, AngularMap):       # Debevec: angle from the forward axis −Z = π·radius
        phi, psi = np.pi * np.hypot(u, v), np.arctan2(v, u)
        return np.stack([np.sin(phi) * np.cos(psi), np.sin(phi) * np.sin(psi), -np.cos(phi)], -1)
    if p.distance is None:              # orthographic camera looking along −Z at the ball
        view = np.array([0.0, 0.0, -1.0])
        n = np.stack([u, v, np.sqrt(np.clip(1 - u * u - v * v, 0, 1))], -1)
        return view - 2 * (n @ view)[..., None] * n
    return p.reflect(px, py)[0]         # pinhole: its tests check it with a ray tracer


def render_averaged(projection, env=smooth_env, k=4):
    """Radiance of ``env`` averaged over the seen part of each pixel (k×k samples): the
    image a camera records of a scene that is constant over no pixel."""
    h, w = projection.height, projection.width
    off = (np.arange(k) + 0.5) / k
    py, px = np.mgrid[0:h, 0:w].astype(np.float64)
    total = np.zeros((h, w, 3))
    count = np.zeros((h, w))
    for oy in off:
        for ox in off:
            _, valid = projection.pixel_to_direction(px + ox, py + oy)
            d = physical_directions(projection, px + ox, py + oy)
            total += np.where(valid[..., None], env(np.where(valid[..., None], d, 0)), 0)
            count += valid
    return (total / np.maximum(count, 1)[..., None]).astype(np.float32)
