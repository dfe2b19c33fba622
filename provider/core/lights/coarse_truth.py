"""The lights' truth at the normals from the coarse copy of a frame's rest (maths only).

Every frame the extractor (:class:`~provider.core.lights.extractor.LightExtractor`) needs
the brute-force irradiance at its normals of what the candidates leave, from a coarse
copy (~4k pixels) of the mid copy: a (normals × coarse pixels) kernel times the rest.
:class:`CoarseTruth` holds that kernel and the coarse geometry, sized for a Cortex-A53's
512 KB last-level cache (issue 44): columns only for the coarse pixels that see something,
rows in blocks that one stacked product reads once for the three channels, and the
candidates' excess taken off the coarse blocks rather than off a copy of the mid frame.
"""
from __future__ import annotations

import math

import numpy as np

from ..geometry.projections import Projection
from ..radiometry.blocks import buffer_view, contiguous, shrink

try:
    from ._lights import truth_caps as _truth_kernel
except ImportError:          # no compiler at install: its twin (below) takes its place
    _truth_kernel = None


class CoarseTruth:
    """The kernel and coarse geometry of one extractor's truth.

    mid : the mid copy's projection; ``factor``: mid pixels a coarse pixel side;
    brute_kernel : ``(dirs, omega) -> (N, n)`` float64 irradiance at the N normals per unit
        radiance of each pixel (fill terms included);
    normals : N.
    """

    #: Kernel bytes a block of normals: the three channels' products read it from cache.
    BLOCK_BYTES = 128 << 10
    #: Normals a cap of the split kernel (:class:`SplitKernel`).
    CAP_NORMALS = 8

    def __init__(self, mid: Projection, factor: int, brute_kernel, normals,
                 linear: bool = False):
        """``normals``: (N, 3) unit normals, or their count N (the dense kernel);
        ``linear``: the kernel is ``max(0, n·d) ω`` alone (no fill terms), so it is split
        by caps of normals (:class:`SplitKernel`)."""
        dirs_n = None if np.ndim(normals) == 0 else np.asarray(normals, np.float64)
        normals = len(dirs_n) if dirs_n is not None else int(normals)
        self.mid, self.factor, self.normals = mid, factor, normals
        self.coarse = mid if factor == 1 else mid.scaled(factor)
        self.crop = mid.scaled_source_size(factor)
        # the coarse pixels are whole blocks of factor × factor mid pixels (else
        # INTER_AREA's fractional weights): the candidates' excess can come off them
        self.blocks = factor > 1 and self.crop == (self.coarse.width * factor,
                                                   self.coarse.height * factor)
        cd = self.coarse.directions().reshape(-1, 3)
        co = self.coarse.solid_angle.reshape(-1)
        # Only the coarse pixels that see something (a Theta's two circles: 68 % of its
        # 80×45 grid) carry kernel columns: the kernel is read from DRAM every frame.
        self.pixels = np.flatnonzero(co > 0)
        self.split = None
        # the split's pixel lists are 16-bit (read every frame): past 65,536 seeing coarse
        # pixels (coarse_pixels set that high) the dense kernel
        if linear and dirs_n is not None and 0 < len(self.pixels) <= 1 << 16:
            self.split = SplitKernel(dirs_n, cd[self.pixels], co[self.pixels],
                                     self.CAP_NORMALS)
            self.kernel = None
            return
        kernel = brute_kernel(cd[self.pixels], co[self.pixels]).astype(np.float32)
        # Blocks of normals (zero rows pad the last), a multiple of 4 rows (BLAS's
        # matrix-vector kernels take 4 rows at a time).
        rows = min(len(kernel), max(4, self.BLOCK_BYTES // max(1, 4 * kernel.shape[1])
                                    // 4 * 4))
        self.kernel = np.zeros((-(-len(kernel) // rows), rows, kernel.shape[1]), np.float32)
        self.kernel.reshape(-1, kernel.shape[1])[:len(kernel)] = kernel

    def rest(self, small: np.ndarray, union=None, excess=None, coarse=None) -> np.ndarray:
        """The coarse copy (area means) of the mid copy ``small`` (h, w, 3) float32 less
        ``excess`` (n, 3) float32 on the mid pixels ``union`` (flat indices). Block means
        are linear, so where the blocks are whole (:attr:`blocks`) the excess comes off
        them (its sums over each block / the block's area), not off a copy of the whole
        mid frame: one pass over the frame fewer, 1.4 MB of DRAM traffic a Theta frame;
        the same to float32 rounding. Elsewhere give ``small`` with the excess already
        off and no ``union``. ``coarse``: ``small``'s coarse copy where already made."""
        bw, bh = self.crop
        # Area means (halvings where the factor is a power of two: a third of the
        # instructions of INTER_AREA, issue 34).
        rest = (shrink(small[:bh, :bw], (self.coarse.width, self.coarse.height))
                if coarse is None else coarse)
        if union is None or not len(union):
            return rest
        if not self.blocks:
            raise ValueError("the coarse pixels are not whole blocks: take the excess "
                             "off the mid copy")                           # a bug
        fc, cw = self.factor, self.coarse.width
        y, x = np.divmod(union, self.mid.width)
        seen = (y < bh) & (x < bw)
        cell = (y[seen] // fc) * cw + x[seen] // fc
        drop = np.stack([np.bincount(cell, excess[seen, c], minlength=rest.shape[0] * cw)
                         for c in range(3)], axis=1) * (1.0 / (fc * fc))
        return rest - drop.astype(np.float32).reshape(rest.shape)

    def __call__(self, rest: np.ndarray) -> np.ndarray:
        """(N, 3) float64 irradiance at the normals of the coarse ``rest`` (hc, wc, 3)
        float32: one matrix-vector product a channel and block of normals (a product
        with the 3 interleaved channels packs the whole kernel every frame: 3.4 M
        instructions against 0.8 M, callgrind; issue 34). One stacked matmul runs them
        block by block, a block's three channels one after the other, so the kernel
        crosses the memory bus once a frame, not three times (cachegrind: 11 → 2.7 MB a
        Theta frame; issue 44). Each normal's sum is the same dot product whatever the
        blocks."""
        seeing = np.take(rest.reshape(-1, 3), self.pixels, axis=0)
        if self.split is not None:
            return self.split(seeing)
        x = np.ascontiguousarray(seeing.T)[None, :, :, None]          # (1, 3, Pc, 1)
        out = np.matmul(self.kernel[:, None], x)                      # (B, 3, rows, 1)
        return (out[..., 0].transpose(1, 0, 2).reshape(3, -1)[:, :self.normals]
                .T.astype(np.float64))


class SplitKernel:
    """The truth's kernel ``max(0, n·d) ω`` by caps of normals (issue 44: the dense one,
    2.7 MB for a Theta S, crossed the memory bus every frame).

    The normals are cut into caps of at most ``cap_normals`` (halves across the widest
    axis, again and again). A cap of centre c and radius ρ sees each pixel with d·c > sin ρ
    at a positive cosine from each of its normals, so there ``Σ max(0, n·d) ω x = n · Σ d ω
    xᵀ``: its *core*, one 3 × 3 sum a cap; and none with d·c < −sin ρ. Only the pixels
    between, its horizon band, take a product a normal and pixel: 41 % of the dense
    kernel's for the Theta's 256 normals in caps of 8 (4 a cap: 26 %, but twice the caps'
    sums), each ``max(0, n · d ω)`` made as it is used, not stored (a stored band kernel,
    1.1 MB, was read from DRAM every frame). One call of the C kernel (``_lights.c``) a
    frame; :func:`truth_caps_twin` is its twin."""

    def __init__(self, normals, dirs, omega, cap_normals):
        caps = [np.arange(len(normals))]
        while any(len(c) > cap_normals for c in caps):
            wide = max(caps, key=len)
            caps = [c for c in caps if c is not wide]
            pts = normals[wide]
            axis = np.linalg.svd(pts - pts.mean(axis=0))[2][0]
            order = wide[np.argsort(pts @ axis, kind="stable")]
            caps += [order[:len(order) // 2], order[len(order) // 2:]]
        caps.sort(key=lambda c: int(c.min()))
        k = max(len(c) for c in caps)
        self.normals = np.zeros((len(caps), k, 3))        # zero rows pad a short cap
        self.slot = np.empty(len(normals), np.intp)       # a normal's row of (caps × k)
        core, band = [], []
        for i, cap in enumerate(caps):
            self.normals[i, :len(cap)] = normals[cap]
            self.slot[cap] = i * k + np.arange(len(cap))
            centre = normals[cap].sum(axis=0)
            centre /= np.linalg.norm(centre)
            # a pixel within float32 rounding of the horizon goes to the band, where
            # max(0, ·) takes it exactly
            margin = math.sqrt(max(0.0, 1.0 - float((normals[cap] @ centre).min()) ** 2)
                               ) + 1e-6
            dc = dirs @ centre
            core.append(np.flatnonzero(dc > margin))
            band.append(np.flatnonzero(np.abs(dc) <= margin))
        self.core, self.core_at = _joined(core)
        self.band, self.band_at = _joined(band)
        self.dw = (dirs * omega[:, None]).astype(np.float32)             # (Pc, 3)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """(N, 3) float64 at the normals of the seeing pixels' ``x`` (Pc, 3) float32."""
        out = np.empty(self.normals.shape)
        _truth_kernel(np.ascontiguousarray(x, np.float32), self.dw, self.core, self.core_at,
                      self.band, self.band_at, self.normals, out)
        return out.reshape(-1, 3)[self.slot]


def _joined(parts):
    """Index lists (each below 2¹⁶) joined, uint16, with their offsets, int32 (0 first)."""
    at = np.zeros(len(parts) + 1, np.int32)
    at[1:] = np.cumsum([len(p) for p in parts])
    return np.concatenate(parts).astype(np.uint16), at


def truth_caps_twin(x, dw, core, core_at, band, band_at, normals, out) -> None:
    """The C kernel ``_lights.truth_caps`` in numpy: the same arguments, numbers (to float
    rounding) and errors (``_lights.c`` says what each argument is)."""
    views = [buffer_view(a, name == "out", kind, nd, name) for a, name, kind, nd in zip(
        (x, dw, core, core_at, band, band_at, normals, out),
        ("x", "dw", "core", "core_at", "band", "band_at", "normals", "out"),
        "ffHiHidd", (2, 2, 1, 1, 1, 1, 3, 3))]
    if not all(map(contiguous, views)):
        raise ValueError("every array: C-contiguous")
    P, caps = x.shape[0], normals.shape[0]
    if x.shape[1] != 3 or dw.shape != (P, 3):
        raise ValueError("x, dw: (P, 3) float32")
    if normals.shape[2] != 3 or out.shape != normals.shape:
        raise ValueError("normals, out: (caps, k, 3) float64")
    if core_at.shape != (caps + 1,) or band_at.shape != (caps + 1,):
        raise ValueError("core_at, band_at: (caps + 1,) int32")
    for at, idx in ((core_at, core), (band_at, band)):
        if at[0] != 0 or at[-1] != len(idx) or (np.diff(at) < 0).any():
            raise ValueError("core_at, band_at: 0, non-decreasing, ending at the indices' "
                             "length")
    for idx in (core, band):
        if len(idx) and idx.max() >= P:
            raise ValueError("core, band: pixel indices in [0, P)")
    for i in range(caps):
        c = core[core_at[i]:core_at[i + 1]]
        S = (dw[c].T @ x[c]).astype(np.float64)                            # (3, 3)
        b = band[band_at[i]:band_at[i + 1]]
        rows = np.maximum(normals[i].astype(np.float32) @ dw[b].T, np.float32(0))  # (k, m)
        out[i] = normals[i] @ S + (rows @ x[b]).astype(np.float64)


if _truth_kernel is None:
    _truth_kernel = truth_caps_twin
#: Whether the split truth's C kernel is built (else its twin, :func:`truth_caps_twin`).
KERNEL = _truth_kernel is not truth_caps_twin
