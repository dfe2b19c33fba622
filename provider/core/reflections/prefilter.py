"""GGX prefiltering of a radiance cube as a fixed sparse linear operator (no pixels, no I/O).

Definition (Karis's split sum with n = v = r, docs/contract.md §12): the prefiltered radiance
toward ``r`` at roughness ``ρ`` (α = ρ²) is

    PF(r) = ∫ L(l) D(h) ⟨r·l⟩ dl / ∫ D(h) ⟨r·l⟩ dl,   h = (r + l)/|r + l|,

D the GGX (Trowbridge-Reitz) distribution. It depends on pixels only through L, so the whole
filter is built once: a sparse matrix from a radiance pyramid (the base cube and its
solid-angle-exact 2×2 pools, :func:`provider.core.geometry.cubemap.pool`) to the texel centres of
every prefiltered mip. Each weight is the exact integral of the kernel over one texel of the
pyramid (sub-texels with exact solid angles), and each output reads a quadtree cut of the
pyramid: a texel is read whole (its mean radiance) where the kernel is nearly constant over
it, else its four children, down to the base level. What reading a texel whole can cost is
∫ (k − k̄)(L − L̄) over it, so a texel is split when the kernel's L1 departure from its mean
over the texel, ∫ |k − k̄|, exceeds a small fraction of the whole lobe's integral
(:func:`mip_tolerance`; measured on the sub-texels of its children, so that a peak at its
centre is seen). This puts the texels where the lobe bends, wherever that is, for every
roughness alike (the fixed rings it replaced, each level from a multiple of its texel size
outward, over-read the far tail and under-read the shoulder of rough lobes). Integrating
instead of sampling keeps a 10⁴ sun exact (importance sampling "falls apart" there,
DESIGN.md §12); the GGX tail is never dropped, only read at a coarser level, so the filter
keeps every source's energy.
"""
from __future__ import annotations

import math

import numpy as np

from ..geometry import cubemap

#: Sub-texels per axis used to integrate the kernel over a source texel.
SUBSAMPLES = 4
#: A pyramid texel is split into its four children when ∫ |k − k̄| over it exceeds the mip's
#: tolerance times ∫ k over the sphere (k = D(h)⟨r·l⟩, k̄ its mean over the texel): this
#: value for mip 1, halved for each mip after it (:func:`mip_tolerance`).
TOLERANCE = 7e-4


def mip_tolerance(mip: int, face: int) -> float:
    """The splitting tolerance of prefiltered mip ``mip`` (≥ 1) evaluated on faces of
    ``face``²: :data:`TOLERANCE` halved for each mip after the first (each has a quarter of
    the outputs of the one before, so a tighter tolerance costs it little per frame), but
    at least ``TOLERANCE · face/16``: the mips of cubes above 32², whose narrow lobes are
    limited by the base level's texels rather than by the quadtree.

    Measured against a float64 brute force of PF (``shlight bench --sections environment``
    for the nine shared panoramas; nine other Poly Haven rooms of the same source; the nine
    turned 45° about +Y): the worst mip of a 32² cube errs 0.84 %, 0.93 % and 1.27 %
    (relative RMS), of 8² and 16² cubes at most 0.96 %, 1.03 % and 2.25 %, of 64² 1.64 %,
    1.60 % and 1.94 %; the fixed rings this replaced erred 1.95 %, 3.4 % and 3.3 % at 32²
    with more non-zeros (32²: 1.08 M, now 1.04 M; 16²: 0.36 M, now 0.24 M; 64²: 4.54 M,
    now 2.61 M).
    """
    return TOLERANCE * max(2.0 ** (1 - mip), face / 16)


def ggx_weight(r: np.ndarray, l: np.ndarray, alpha: float) -> np.ndarray:
    """D(h) ⟨r·l⟩ for unit ``r`` (..., 3) and ``l`` (..., 3) (n = v = r), broadcast."""
    rl = np.einsum("...k,...k->...", r, l)
    # |r + l|² = 2 + 2 r·l and r·h = (1 + r·l)/|r + l|, so cos²θ_h = (1 + r·l)/2.
    cos2 = np.clip((1 + rl) / 2, 0.0, 1.0)
    a2 = alpha * alpha
    denom = cos2 * (a2 - 1) + 1
    d = a2 / (math.pi * denom * denom)
    return d * np.maximum(rl, 0.0)


def lobe_integral(alpha: float, steps: int = 20000) -> float:
    """∫ D(h) ⟨r·l⟩ dl over the sphere, 2π ∫₀^{π/2} k(θ) sin θ dθ by the midpoint rule (1 at
    α = 1: the cosine lobe over π)."""
    theta = (np.arange(steps) + 0.5) * (math.pi / 2 / steps)
    l = np.stack([np.sin(theta), np.zeros(steps), np.cos(theta)], axis=-1)
    k = ggx_weight(np.array([0.0, 0.0, 1.0]), l, alpha)
    return float(2 * math.pi * np.sum(k * np.sin(theta)) * (math.pi / 2 / steps))


class PyramidGeometry:
    """What the operator needs of each pyramid level: sub-texel directions, exact sub-texel
    and texel solid angles; level ``k`` has faces of ``sizes[k]`` (finest first, each level
    half the one before)."""

    def __init__(self, sizes: list[int], q: int = SUBSAMPLES):
        self.sizes = list(sizes)
        if any(a != 2 * b for a, b in zip(self.sizes, self.sizes[1:])):
            raise ValueError(f"pyramid levels must halve, finest first: {sizes}")
        self.q = q
        self.offsets = np.cumsum([0] + [6 * n * n for n in sizes])
        self.sub_dirs, self.sub_omega = [], []
        for n in sizes:
            m = n * q
            d = cubemap.texel_directions(m).reshape(6, n, q, n, q, 3)
            w = cubemap.texel_solid_angles(m).reshape(6, n, q, n, q)
            # (texel, q·q sub-texels) ordered by the level's flat texel index.
            self.sub_dirs.append(d.transpose(0, 1, 3, 2, 4, 5).reshape(6 * n * n, q * q, 3))
            self.sub_omega.append(w.transpose(0, 1, 3, 2, 4).reshape(6 * n * n, q * q))
        self.omega = [w.sum(axis=1) for w in self.sub_omega]

    @property
    def total(self) -> int:
        return int(self.offsets[-1])


def children(texels: np.ndarray, n: int) -> np.ndarray:
    """(P, 4) flat indices at level 2n of the four children of flat texels (P,) at level n."""
    face, rem = np.divmod(texels, n * n)
    i, j = np.divmod(rem, n)
    m = 2 * n
    first = (face * m + 2 * i) * m + 2 * j
    return np.stack([first, first + 1, first + m, first + m + 1], axis=1)


def build_operator(outputs: np.ndarray, alpha: float, geom: PyramidGeometry,
                   tolerance: float = TOLERANCE, chunk: int = 32):
    """Sparse prefilter of one mip: ``(rows, cols, vals, norm)`` with ``PF[rows] += vals ·
    pyramid[cols]``, rows normalised to sum to 1 (a constant map stays constant); ``norm``
    (T,) is each row's ``∫ D(h) ⟨r·l⟩ dl`` before normalising.

    ``outputs`` (T, 3): unit directions where PF is evaluated (the mip's texel centres).
    Each output's texels are found top-down from the coarsest level: a texel is kept whole
    unless ∫ |k − k̄| over it (on the q × q sub-texels of each child) exceeds ``tolerance`` ×
    :func:`lobe_integral`, else its children are examined in turn; texels behind the
    horizon (k = 0) are dropped.
    """
    limit = tolerance * lobe_integral(alpha)
    last = len(geom.sizes) - 1
    rows_all, cols_all, vals_all, norms = [], [], [], []
    for t0 in range(0, len(outputs), chunk):
        r = outputs[t0:t0 + chunk]
        k, n = last, geom.sizes[last]
        # (output, texel) pairs to examine at level k
        pt = np.repeat(np.arange(len(r)), 6 * n * n)
        pj = np.tile(np.arange(6 * n * n), len(r))
        acc_rows, acc_cols, acc_vals = [], [], []
        while pt.size:
            if k == 0:                          # the base: read whole
                w = (ggx_weight(r[pt][:, None, :], geom.sub_dirs[0][pj], alpha)
                     * geom.sub_omega[0][pj]).sum(axis=1)
                keep = w > 0
                acc_rows.append(pt[keep])
                acc_cols.append(pj[keep] + geom.offsets[0])
                acc_vals.append(w[keep])
                break
            ch = children(pj, n)                                        # (P, 4)
            sub = (ggx_weight(r[pt][:, None, None, :], geom.sub_dirs[k - 1][ch], alpha)
                   * geom.sub_omega[k - 1][ch])                         # (P, 4, q²)
            w = sub.sum(axis=(1, 2))
            density = (w / geom.omega[k][pj])[:, None, None]
            split = np.abs(sub - density * geom.sub_omega[k - 1][ch]).sum(axis=(1, 2)) > limit
            keep = ~split & (w > 0)
            acc_rows.append(pt[keep])
            acc_cols.append(pj[keep] + geom.offsets[k])
            acc_vals.append(w[keep])
            pt, pj = np.repeat(pt[split], 4), ch[split].reshape(-1)
            k, n = k - 1, geom.sizes[k - 1]
        rows = np.concatenate(acc_rows)
        vals = np.concatenate(acc_vals)
        norm = np.bincount(rows, weights=vals, minlength=len(r))
        norms.append(norm)
        rows_all.append(rows + t0)
        cols_all.append(np.concatenate(acc_cols))
        vals_all.append(vals / norm[rows])
    return (np.concatenate(rows_all), np.concatenate(cols_all),
            np.concatenate(vals_all), np.concatenate(norms))


class SparseOperator:
    """``y = A x`` for a fixed sparse ``A`` (CSR: rows sorted), x of shape (M, C)."""

    def __init__(self, rows, cols, vals, shape):
        order = np.lexsort((cols, rows))
        rows, cols, vals = rows[order], cols[order], vals[order]
        self.shape = shape
        # intp: numpy's gather casts other index types on every call; the columns are in
        # range by construction, so ``take`` needs no per-element bounds check (mode="clip").
        self.cols = cols.astype(np.intp)
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
            out[:, c] = np.add.reduceat(np.take(xc, self.cols, mode="clip") * self.vals,
                                        self.starts)
        return out
