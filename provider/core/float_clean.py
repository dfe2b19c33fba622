"""Cleaning linear float frames band by band, inside the projection pass (no I/O).

HDR frames (.exr, .hdr, a renderer's output) are linear radiance, but may carry samples no
light can have: NaN, ±inf and negative values (denoisers, debayering, bad pixels). The
engine sets those samples to 0 and counts them. Done on the whole frame first, that
clean-up used to cost as much as the projection itself; here each band of rows is checked
while it is in cache, just before it is projected, and only a band that holds a bad sample
is copied. A clean band costs one sum and one minimum (a few percent of the projection).

:class:`FloatCleaner` keeps the tally of one frame: ``nonfinite_pixels`` (pixels with a
NaN or infinite channel), ``negative_pixels`` (pixels with a finite negative channel) and
``negative_energy_fraction`` (the light the negative samples took away, over the light
left: ``-Σ negatives / Σ positives``).
"""
from __future__ import annotations

import math

import cv2
import numpy as np

from .errors import InputError


def count_pixels(mask: np.ndarray) -> int:
    """Pixels of an (h, w, 3) uint8/bool mask with any channel set."""
    planes = cv2.split(np.ascontiguousarray(mask, dtype=np.uint8))
    return int(cv2.countNonZero(cv2.max(cv2.max(planes[0], planes[1]), planes[2])))


class FloatCleaner:
    """The clean-up of one float frame, band by band: :meth:`band` returns each band as
    clean float32 (the band itself when it was clean), :meth:`finish` writes the counts."""

    def __init__(self):
        self.nonfinite = 0
        self.negative = 0
        self.negative_sum = 0.0   # Σ of the finite negative samples (≤ 0)
        self.positive_sum = 0.0   # Σ of the samples kept
        self.samples = 0

    def band(self, band: np.ndarray) -> np.ndarray:
        """``band`` (h, w, 3) float: a clean float32 band (not copied when clean)."""
        if band.dtype != np.float32:
            band = band.astype(np.float32)
        h = band.shape[0]
        flat = band.reshape(h, -1)
        self.samples += flat.size
        total = cv2.sumElems(flat)[0]
        if math.isfinite(total):
            lo = cv2.minMaxLoc(flat)[0]
            if lo >= 0:
                self.positive_sum += total
                return band
        return self._dirty(band, flat, total)

    def _dirty(self, band: np.ndarray, flat: np.ndarray, total: float) -> np.ndarray:
        """A band with a bad sample: zero them (a copy), count them."""
        if not math.isfinite(total):
            bad = ~np.isfinite(band)
            self.nonfinite += count_pixels(bad)
            flat = np.where(bad, np.float32(0), band).reshape(flat.shape)
            total = cv2.sumElems(flat)[0]
        # NaN > 0 and -inf > 0 are false: both would become 0 here too.
        _, clean = cv2.threshold(flat, 0, 0, cv2.THRESH_TOZERO)
        positive = cv2.sumElems(clean)[0]
        if positive != total or cv2.minMaxLoc(flat)[0] < 0:
            negative = cv2.compare(flat, 0, cv2.CMP_LT).reshape(band.shape)
            # Grey of the 0/255 mask is > 0 where any channel is (the weights are > 0).
            self.negative += cv2.countNonZero(cv2.cvtColor(negative, cv2.COLOR_RGB2GRAY))
            self.negative_sum += total - positive
        self.positive_sum += positive
        return clean.reshape(band.shape)

    def finish(self, stats: dict) -> None:
        """The counts into ``stats``; a frame with no light left after the clean-up (all
        NaN, all negative) is refused rather than served as darkness."""
        stats["nonfinite_pixels"] = self.nonfinite
        stats["negative_pixels"] = self.negative
        if self.negative:
            stats["negative_energy_fraction"] = float(-self.negative_sum
                                                      / max(self.positive_sum, 1e-300))
        if (self.nonfinite or self.negative) and not self.positive_sum > 0:
            raise InputError(
                f"the frame holds no usable light: {self.nonfinite} pixels are NaN or "
                f"infinite and {self.negative} negative, nothing else is above 0 "
                "(a broken render or decoder?)")


def clean_frame(frame: np.ndarray, stats: dict, rows: int = 32) -> np.ndarray:
    """The whole ``frame`` (H, W, 3) as clean float32 linear radiance (bad samples set to
    0, counted into ``stats``); not copied when it is float32 and clean."""
    cleaner = FloatCleaner()
    out = None
    for r0 in range(0, frame.shape[0], rows):
        band = cleaner.band(frame[r0:r0 + rows])
        if out is None and not np.may_share_memory(band, frame):   # a copy: dirty
            out = np.empty(frame.shape, np.float32)
            if r0:
                out[:r0] = frame[:r0]
        if out is not None:
            out[r0:r0 + rows] = band
    cleaner.finish(stats)
    return frame if out is None else out
