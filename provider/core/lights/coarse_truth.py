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

import numpy as np

from ..geometry.projections import Projection
from ..radiometry.blocks import shrink


class CoarseTruth:
    """The kernel and coarse geometry of one extractor's truth.

    mid : the mid copy's projection; ``factor``: mid pixels a coarse pixel side;
    brute_kernel : ``(dirs, omega) -> (N, n)`` float64 irradiance at the N normals per unit
        radiance of each pixel (fill terms included);
    normals : N.
    """

    #: Kernel bytes a block of normals: the three channels' products read it from cache.
    BLOCK_BYTES = 128 << 10

    def __init__(self, mid: Projection, factor: int, brute_kernel, normals: int):
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
        x = np.ascontiguousarray(seeing.T)[None, :, :, None]          # (1, 3, Pc, 1)
        out = np.matmul(self.kernel[:, None], x)                      # (B, 3, rows, 1)
        return (out[..., 0].transpose(1, 0, 2).reshape(3, -1)[:, :self.normals]
                .T.astype(np.float64))
