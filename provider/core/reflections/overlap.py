"""The reflection cube's overlap: where each pixel of the work image falls on the base cube
(no I/O; :class:`~provider.core.reflections.environment.EnvironmentProjector` builds its
sparse map from these sums).

Each work pixel is split into q×q sub-pixels with exact solid angles; their directions are
binned into the base cube's texels. The sums are made a few pixel rows at a time, so the
build never holds the whole frame's sub-pixel directions (3.7 M of them, hundreds of MB of
float64 temporaries, for a Theta S frame's work image).
"""
from __future__ import annotations

import math

import numpy as np

from ..geometry import cubemap
from ..geometry.projections import Equirect, Projection

#: Sub-pixels per chunk of the overlap's build: bounds its memory (~100 bytes each), not
#: its result.
OVERLAP_CHUNK = 1 << 16


def subpixel_samples(p: Projection, q: int, r0: int, r1: int):
    """Directions (P, 3), solid angles (P,) and pixel index (P,) of the q×q sub-pixels
    of pixel rows [r0, r1)."""
    if isinstance(p, Equirect):   # exact: φ uniform, ∫ sin θ dθ per sub-row
        cols = (np.arange(p.width * q) + 0.5) / (p.width * q)
        edges = np.linspace(0, math.pi, p.height * q + 1)
        band = (np.cos(edges[:-1]) - np.cos(edges[1:]))[r0 * q:r1 * q]
        rows = ((np.arange(p.height * q) + 0.5) / (p.height * q))[r0 * q:r1 * q]
        theta = rows * math.pi
        phi = 2 * math.pi * (cols - 0.5)
        st = np.sin(theta)[:, None]
        d = np.stack(np.broadcast_arrays(st * np.sin(phi), np.cos(theta)[:, None],
                                         -st * np.cos(phi)), axis=-1)
        w = np.broadcast_to(band[:, None] * (2 * math.pi / (p.width * q)), d.shape[:2])
        pix = (np.arange(r0 * q, r1 * q)[:, None] // q) * p.width + \
            np.arange(p.width * q)[None, :] // q
        return d.reshape(-1, 3), np.asarray(w).reshape(-1), pix.reshape(-1)
    sub = (np.arange(q) + 0.5) / q
    py, px = np.mgrid[r0:r1, 0:p.width].astype(np.float64)
    px = px[:, :, None, None] + sub[None, None, None, :]
    py = py[:, :, None, None] + sub[None, None, :, None]
    px, py = np.broadcast_arrays(px, py)
    d, valid = p.pixel_to_direction(px, py)
    jac = p.jacobian(px, py)
    if jac is None:
        h = 1e-3
        dxp, _ = p.pixel_to_direction(px + h, py)
        dxm, _ = p.pixel_to_direction(px - h, py)
        dyp, _ = p.pixel_to_direction(px, py + h)
        dym, _ = p.pixel_to_direction(px, py - h)
        jac = np.linalg.norm(np.cross((dxp - dxm) / (2 * h), (dyp - dym) / (2 * h)), axis=-1)
    d = np.where(valid[..., None], d, 0.0)
    w = np.where(valid & np.isfinite(jac), jac, 0.0) * p.node_factor(px, py, d) / (q * q)
    w = np.broadcast_to(w, valid.shape)
    pix = np.broadcast_to(np.arange(r0 * p.width, r1 * p.width).reshape(r1 - r0, p.width,
                                                                        1, 1), valid.shape)
    keep = w.reshape(-1) > 0
    return d.reshape(-1, 3)[keep], w.reshape(-1)[keep], pix.reshape(-1)[keep]


def overlap_sums(p: Projection, n: int, rotation, q: int) -> dict:
    """The overlap of the work image ``p``'s q×q sub-pixels with the base cube (faces n²,
    directions turned by ``rotation``), built a few
    pixel rows at a time (:data:`OVERLAP_CHUNK` sub-pixels): each pixel's sub-pixels
    fall in one chunk, so its sums are those of the whole sample set, and the build never
    holds the whole frame's sub-pixel directions (hundreds of MB at a Theta S's size)."""
    ntex, npx = 6 * n * n, p.width * p.height
    out = {"seen": np.zeros(ntex, np.int64), "covered": np.zeros(ntex),
           "omega": np.zeros(npx), "dsum": np.zeros((3, npx)), "axis": np.zeros(npx),
           "keys": [], "weights": [], "coverage": 0.0}
    lens = getattr(p, "lens", None)
    axis = None if lens is None else np.asarray(lens.frame[0], np.float64)
    if axis is not None and rotation is not None:
        axis = rotation @ axis
    step = max(1, OVERLAP_CHUNK // (p.width * q * q))
    for r0 in range(0, p.height, step):
        d, w, pix = subpixel_samples(p, q, r0, min(p.height, r0 + step))
        if rotation is not None:
            d = d @ rotation.T
        face, i, j, _, _ = cubemap.direction_to_texel(d, n)
        texel = cubemap.flat_index(face, i, j, n)
        out["seen"] += np.bincount(texel, minlength=ntex)
        out["covered"] += np.bincount(texel, weights=w, minlength=ntex)
        out["coverage"] += float(w.sum())
        uniq, inv = np.unique(pix.astype(np.int64) * ntex + texel, return_inverse=True)
        out["keys"].append(uniq)
        out["weights"].append(np.bincount(inv, weights=w))
        out["omega"] += np.bincount(pix, weights=w, minlength=npx)
        for c in range(3):
            out["dsum"][c] += np.bincount(pix, weights=w * d[:, c], minlength=npx)
        if axis is not None:          # the fill model's cosine (see _fill_model)
            out["axis"] += np.bincount(pix, weights=np.maximum(d @ axis, 0.0) * w,
                                       minlength=npx)
        del d, w, pix, face, i, j, texel, uniq, inv
    return out
