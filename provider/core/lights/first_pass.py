"""The first pass over a frame's mid copy (maths only): its block sums made means, its
luminance, its flux and its coarse copy, in one pass.

The extractor (:class:`~provider.core.lights.extractor.LightExtractor`) needs, every frame,
the mid copy's luminance Y (to find the pixels above its thresholds), Σ Y ω (the frame's
mean luminance, what the thresholds are relative to) and the coarse copy (the truth's
input). The C kernel (``_lights.first_pass``) makes them a band of rows at a time while
the band is in cache: the mid copy (442 KB for a Theta S) crosses the memory bus once.
:func:`first_pass_twin` is its twin, chosen at import where no compiler built it.
"""
from __future__ import annotations

import cv2
import numpy as np

from ..radiometry.blocks import buffer_view, contiguous, shrink

try:
    from ._lights import first_pass as _first_pass_kernel
except ImportError:          # no compiler at install: its twin (below) takes its place
    _first_pass_kernel = None

#: Mid rows a band of :func:`first_pass_twin` (32 × 320 × 3 floats: 123 KB of a Theta's
#: mid copy, in cache for its three reads).
TWIN_ROWS = 32


def first_pass(mid: np.ndarray, scale: float, luma: np.ndarray, omega: np.ndarray,
               coarse_size: tuple[int, int] | None, factor: int):
    """(Y, total, coarse, Ymax) of the mid copy ``mid`` (h, w, 3) float32 C-contiguous,
    first multiplied in place by ``scale`` (block sums to means; 1: left as it is): its
    luminance ``luma · rgb`` (h, w) float32, ``Σ Y ω`` over ``omega`` (h, w) float32
    (float32 products, a float64 sum), where ``coarse_size`` (wc, hc) is given the means of
    its ``factor`` × ``factor`` blocks (hc, wc, 3) float32 (else None), and each row's
    largest Y (h,) float32 (−inf where none is above it)."""
    h, w = mid.shape[:2]
    Y, Ymax = np.empty((h, w), np.float32), np.empty(h, np.float32)
    coarse = (None if coarse_size is None
              else np.empty((coarse_size[1], coarse_size[0], 3), np.float32))
    total = _first_pass_kernel(mid, float(scale), luma, omega, Y, coarse, int(factor), Ymax)
    return Y, float(total), coarse, Ymax


def first_pass_twin(mid, scale, luma, omega, Y, coarse, factor, Ymax) -> float:
    """The C kernel ``_lights.first_pass`` in numpy and OpenCV: the same arguments, numbers
    (to float rounding) and errors (``_lights.c`` says what each argument is); a band of
    :data:`TWIN_ROWS` rows at a time, each in cache for its three reads."""
    views = [buffer_view(a, name not in ("luma", "omega"), "f", nd, name)
             for a, name, nd in zip((mid, luma, omega, Y, Ymax, coarse),
                                    ("mid", "luma", "omega", "Y", "Ymax", "coarse"),
                                    (3, 1, 2, 2, 1, 3))
             if a is not None]
    if not all(map(contiguous, views)):
        raise ValueError("every array: C-contiguous")
    h, w = mid.shape[:2]
    if mid.shape[2] != 3:
        raise ValueError("mid: (h, w, 3) float32")
    if luma.shape != (3,):
        raise ValueError("luma: (3,) float32")
    if omega.shape != (h, w) or Y.shape != (h, w):
        raise ValueError("omega, Y: (h, w) float32, mid's height and width")
    if Ymax.shape != (h,):
        raise ValueError("Ymax: (h,) float32")
    if factor < 1:
        raise ValueError("factor: at least 1")
    if coarse is not None and (coarse.shape[2] != 3 or coarse.shape[0] > h // factor
                               or coarse.shape[1] > w // factor):
        raise ValueError("coarse: (hc, wc, 3) float32, hc * factor <= h, wc * factor <= w")
    f = factor
    rows = max(f, TWIN_ROWS // f * f)
    if coarse is not None:
        hc, wc = coarse.shape[:2]
        bh, bw = hc * f, wc * f
    m = luma.reshape(1, 3)
    total = 0.0
    for r0 in range(0, h, rows):
        band = mid[r0:r0 + rows]
        if np.float32(scale) != 1:
            band *= np.float32(scale)
        y = Y[r0:r0 + rows]
        y[...] = cv2.transform(band, m).reshape(y.shape)
        # each row's largest, NaN never (fmax), −inf for a row of none (as the C)
        Ymax[r0:r0 + rows] = np.fmax.reduce(y, axis=1, initial=-np.inf)
        total += cv2.sumElems(cv2.multiply(y, omega[r0:r0 + rows]))[0]
        if coarse is not None and r0 < bh:
            r1 = min(r0 + rows, bh)
            if wc:
                coarse[r0 // f:r1 // f] = shrink(band[:r1 - r0, :bw], (wc, (r1 - r0) // f))
    return float(total)


if _first_pass_kernel is None:
    _first_pass_kernel = first_pass_twin
#: Whether the first pass's C kernel is built (else its twin, :func:`first_pass_twin`).
KERNEL = _first_pass_kernel is not first_pass_twin
