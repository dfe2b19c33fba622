"""The SH9 engine's per-pixel tables of a projection that is not separable (fisheye, dual
fisheye, probes, cube maps): built once per geometry, compactly, and kept on disk
(:mod:`provider.core.table_cache`).

The projection's dense weights (H·W × 10 float64: 74 MB for a Theta S 1280×720 frame) are
what the tables are made of, never what a frame reads: a lens symmetric about its centre
keeps its radial tables (:mod:`.lens_fold`), any other geometry a float32 copy, and the
dense weights are dropped as soon as the tables are made (the projection would rebuild them
if asked again).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import table_cache
from .lens_fold import LensFold, lens_fold


@dataclass
class PixelTables:
    """What a frame of a non-separable projection reads: the lens fold (or None), the dense
    float32 weights (H·W, 9 + extras) where there is no fold (else (0, 9)), the pixels that
    see anything (H, W) bool, each pixel's L00 weight (H·W,) float32 (the clipping tally),
    and the solid angle the frame sees (sr)."""

    fold: LensFold | None
    weights: np.ndarray
    seen: np.ndarray
    l00: np.ndarray
    coverage: float


def pixel_tables(projection, up: np.ndarray | None = None, progress=None,
                 notes: list | None = None) -> PixelTables:
    """The :class:`PixelTables` of ``projection`` (``up``: an extra world-frame weight
    column (H·W,) summed in the same pass), from the table cache where it holds them."""
    key = table_cache.key_of("sh9", table_cache.state_of(projection),
                             None if up is None else np.asarray(up))
    return table_cache.cached("sh9", key, lambda: _build(projection, up, progress), notes)


def _build(p, up, progress) -> PixelTables:
    p.progress = progress
    try:
        dense = p.sh_weights                          # (H·W, 9) float64, a view
    finally:
        p.progress = None
    coverage = p.coverage
    extra = None if up is None else np.asarray(up).reshape(-1, 1)
    fold = lens_fold(p, dense, extra)
    if fold is not None:
        weights = np.zeros((0, 9), np.float32)
    else:
        weights = (dense if extra is None else np.hstack([dense, extra])).astype(np.float32)
    seen = np.any(dense != 0, axis=1).reshape(p.height, p.width)
    l00 = dense[:, 0].astype(np.float32)
    del dense
    p._weights = None    # the projection's lazy integrals (74 MB at a Theta S's size): no frame
    #                      reads them, and the projection builds them again if asked
    return PixelTables(fold, weights, seen, l00, coverage)
