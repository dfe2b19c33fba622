"""GGX prefiltering of a radiance cube as a fixed sparse linear operator (no pixels, no I/O).

Definition (Karis's split sum with n = v = r, docs/contract.md §12): the prefiltered radiance
toward ``r`` at roughness ``ρ`` (α = ρ²) is

    PF(r) = ∫ L(l) D(h) ⟨r·l⟩ dl / ∫ D(h) ⟨r·l⟩ dl,   h = (r + l)/|r + l|,

D the GGX (Trowbridge-Reitz) distribution. It depends on pixels only through L, so the whole
filter is built once: a sparse matrix from a radiance pyramid (the base cube and its
solid-angle-exact 2×2 pools, :func:`provider.core.geometry.cubemap.pool`) to the texel centres of
every prefiltered mip. Each weight is the exact integral of the kernel over the part of a
source texel assigned to that level (q × q sub-texels with exact solid angles): near ``r``
the finest level the lobe needs, then rings at coarser levels where the kernel is smooth
(angle ≥ ``RING`` × the level's texel size). Integrating instead of sampling keeps a 10⁴
sun exact (importance sampling "falls apart" there, DESIGN.md §12); the GGX tail is never
dropped, only read at a coarser level, so the filter keeps every source's energy.
"""
from __future__ import annotations

import math

import numpy as np

from ..geometry import cubemap

#: Sub-texels per axis used to integrate the kernel over a source texel.
SUBSAMPLES = 4
#: Level k after the near one is used from RING[k] of its texel sizes away from r outward
#: (the last value for the rest). Measured on the nine panoramas (``shlight bench --sections
#: environment``): worst mip 1.9 % against brute force at 1.08 M non-zeros for 32²; a ring of
#: 3 throughout errs up to 3.4 %, 4 throughout 1.8 % at 1.65 M.
RING = (3.5, 3.0, 2.5)
#: Rings for cubes of 16² and less, whose few outputs afford more (bridge's worst mip at 16²:
#: 3.4 % with RING, 2.0 % with these).
RING_SMALL = (4.0, 4.0, 3.0)
#: The near level's texel must be at most this fraction of the lobe's half width.
NEAR_FRACTION = 1 / 6


def ggx_weight(r: np.ndarray, l: np.ndarray, alpha: float) -> np.ndarray:
    """D(h) ⟨r·l⟩ for unit ``r`` (..., 3) and ``l`` (..., 3) (n = v = r), broadcast."""
    rl = np.einsum("...k,...k->...", r, l)
    # |r + l|² = 2 + 2 r·l and r·h = (1 + r·l)/|r + l|, so cos²θ_h = (1 + r·l)/2.
    cos2 = np.clip((1 + rl) / 2, 0.0, 1.0)
    a2 = alpha * alpha
    denom = cos2 * (a2 - 1) + 1
    d = a2 / (math.pi * denom * denom)
    return d * np.maximum(rl, 0.0)


def lobe_half_width(alpha: float) -> float:
    """Angle (radians) between r and l where the GGX lobe falls to half its peak."""
    if alpha >= 1:
        return math.pi / 2
    return 2 * math.atan(0.6436 * alpha)


def texel_angle(n: int) -> float:
    """Angular size (radians) of a face-centre texel of an n × n cube."""
    return (math.pi / 2) / n


class PyramidGeometry:
    """What the operator needs of each pyramid level: texel centres, sub-texel directions
    and exact sub-texel solid angles; level ``k`` has faces of ``sizes[k]``."""

    def __init__(self, sizes: list[int], q: int = SUBSAMPLES):
        self.sizes = list(sizes)
        self.q = q
        self.offsets = np.cumsum([0] + [6 * n * n for n in sizes])
        self.centres = [cubemap.texel_directions(n).reshape(-1, 3) for n in sizes]
        self.sub_dirs, self.sub_omega = [], []
        for n in sizes:
            m = n * q
            d = cubemap.texel_directions(m).reshape(6, n, q, n, q, 3)
            w = cubemap.texel_solid_angles(m).reshape(6, n, q, n, q)
            # (texel, q·q sub-texels) ordered by the level's flat texel index.
            self.sub_dirs.append(d.transpose(0, 1, 3, 2, 4, 5).reshape(6 * n * n, q * q, 3))
            self.sub_omega.append(w.transpose(0, 1, 3, 2, 4).reshape(6 * n * n, q * q))

    @property
    def total(self) -> int:
        return int(self.offsets[-1])


def build_operator(outputs: np.ndarray, alpha: float, geom: PyramidGeometry,
                   ring: float | None = None, chunk: int = 64):
    """Sparse prefilter of one mip: ``(rows, cols, vals, norm)`` with ``PF[rows] += vals ·
    pyramid[cols]``, rows normalised to sum to 1 (a constant map stays constant); ``norm``
    (T,) is each row's ``∫ D(h) ⟨r·l⟩ dl`` before normalising.

    ``outputs`` (T, 3): unit directions where PF is evaluated (the mip's texel centres).
    """
    half = lobe_half_width(alpha)
    taus = [texel_angle(n) for n in geom.sizes]
    ring = RING if ring is None else ring
    near = 0                                # the finest level, unless a coarser one will do
    for k, tau in enumerate(taus):          # finest first: the coarsest level fine enough
        if tau <= half * NEAR_FRACTION:
            near = k
    # Level k covers angles [lo_k, hi_k): the near level from 0, each coarser one from
    # ring × its own texel size (never closer than the finer level's start).
    levels = list(range(near, len(taus)))
    rings = ring if isinstance(ring, (list, tuple)) else [ring] * len(levels)
    lo = [0.0] + [rings[min(i, len(rings) - 1)] * taus[k]
                  for i, k in enumerate(levels[1:])]
    lo = np.maximum.accumulate(lo)
    hi = list(lo[1:]) + [math.pi + 1]
    rows_all, cols_all, vals_all, norms = [], [], [], []
    for t0 in range(0, len(outputs), chunk):
        r = outputs[t0:t0 + chunk]
        acc_rows, acc_cols, acc_vals = [], [], []
        for k, a, b in zip(levels, lo, hi):
            if a >= math.pi:
                break
            pad = 1.5 * taus[k]             # a texel's centre-to-corner angle, with margin
            cosang = np.clip(r @ geom.centres[k].T, -1, 1)
            ang = np.arccos(cosang)
            cand_t, cand_j = np.nonzero((ang < b + pad) & (ang >= a - pad))
            if cand_t.size == 0:
                continue
            l = geom.sub_dirs[k][cand_j]               # (P, q², 3)
            rr = r[cand_t][:, None, :]
            w = ggx_weight(rr, l, alpha) * geom.sub_omega[k][cand_j]
            theta = np.arccos(np.clip(np.einsum("pqk,pqk->pq", np.broadcast_to(rr, l.shape), l),
                                      -1, 1))
            w = np.where((theta >= a) & (theta < b), w, 0.0).sum(axis=1)
            keep = w > 0
            acc_rows.append(cand_t[keep] + t0)
            acc_cols.append(cand_j[keep] + geom.offsets[k])
            acc_vals.append(w[keep])
        rows = np.concatenate(acc_rows)
        vals = np.concatenate(acc_vals)
        norm = np.bincount(rows - t0, weights=vals, minlength=len(r))
        vals = vals / norm[rows - t0]
        norms.append(norm)
        rows_all.append(rows)
        cols_all.append(np.concatenate(acc_cols))
        vals_all.append(vals)
    return (np.concatenate(rows_all), np.concatenate(cols_all),
            np.concatenate(vals_all), np.concatenate(norms))


class SparseOperator:
    """``y = A x`` for a fixed sparse ``A`` (CSR: rows sorted), x of shape (M, C)."""

    def __init__(self, rows, cols, vals, shape):
        order = np.lexsort((cols, rows))
        rows, cols, vals = rows[order], cols[order], vals[order]
        self.shape = shape
        self.cols = cols.astype(np.int32)
        self.vals = vals.astype(np.float32)
        counts = np.bincount(rows, minlength=shape[0])
        if np.any(counts == 0):
            raise ValueError("every output needs at least one input")
        self.starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)

    @property
    def nnz(self) -> int:
        return int(self.vals.size)

    def apply(self, x: np.ndarray) -> np.ndarray:
        """(M, C) float32 → (N, C) float32 (one 1-D gather per channel: numpy gathers
        scalars several times faster than rows of three)."""
        out = np.empty((self.shape[0], x.shape[1]), np.float32)
        for c in range(x.shape[1]):
            xc = np.ascontiguousarray(x[:, c])
            out[:, c] = np.add.reduceat(np.take(xc, self.cols) * self.vals, self.starts)
        return out
