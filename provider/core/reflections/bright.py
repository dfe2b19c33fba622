"""The brightest work pixels of a frame, prefiltered from their own directions (no I/O).

A sun or a lamp is nearly a delta: no texel-sized quadrature of the pyramid gets its GGX
lobe right. :func:`bright_split` takes the light of the :data:`BRIGHT_PIXELS` brightest
work pixels above the next one's luminance out of what the pyramid carries, and
:class:`~provider.core.reflections.environment.EnvironmentProjector` sends it to every
prefiltered mip exactly, from each pixel's mean direction (docs/contract.md §12).
"""
from __future__ import annotations

import cv2
import numpy as np

from ..radiometry.photometry import LUMINANCE_WEIGHTS

#: Work pixels whose light above the rest is prefiltered exactly (a sun, a lamp).
BRIGHT_PIXELS = 64
#: Rec. 709 luminance of linear RGB, as a (1, 3) matrix for ``cv2.transform``.
LUMINANCE = LUMINANCE_WEIGHTS.astype(np.float32)[None]


def bright_split(px: np.ndarray):
    """The brightest of the work pixels ``px`` (P, 3) float32 (linear, clean) and their
    light above the next one's luminance. Returns the (sorted) pixel indices and their
    excess radiance (K, 3) float64, or Nones where no pixel stands above the rest."""
    # OpenCV's 3 → 1 channel transform: half the instructions of numpy's (P, 3) @ (3,)
    lum = cv2.transform(px.reshape(-1, 1, 3), LUMINANCE).reshape(-1)
    k = min(BRIGHT_PIXELS, lum.size - 1)
    among = holding_the_largest(lum, k + 1)
    sub = lum if among is None else lum[among]
    top = np.argpartition(sub, sub.size - k - 1)[sub.size - k - 1:]
    top = top if among is None else among[top]
    cap = lum[top].min()
    bright = np.sort(top[lum[top] > cap])
    if bright.size == 0 or not cap >= 0:
        return None, None
    keep = (cap / lum[bright])[:, None]
    excess = (px[bright] * (1 - keep)).astype(np.float64)
    return bright, excess


def holding_the_largest(lum: np.ndarray, m: int, block: int = 64):
    """Indices (ascending) of the values of ``lum`` (P,) at or above a bound that the m-th
    largest value is known to reach, so that they hold the m largest (ties included); or
    None where the bound does not help (fewer than 4m blocks, NaNs). The bound is the m-th
    largest maximum of blocks of ``block`` values: m blocks each hold a value at least that
    large. Partitioning these few instead of all P values saves ~3 M instructions of the
    Theta frame's cube (230 400 work pixels; issue 34). Any partition into blocks will do:
    values ``j, j + B, j + 2B…`` make block j, so that the maxima are ``block`` − 1
    element-wise maxima of whole rows (numpy's maximum along a short axis is 5× dearer)."""
    blocks = lum.size // block
    if blocks < 4 * m:
        return None
    peaks = lum[:blocks * block].reshape(block, blocks).max(axis=0)
    if np.isnan(peaks).any():
        return None
    bound = np.partition(peaks, blocks - m)[blocks - m]
    return np.flatnonzero(lum >= bound)
