"""Decode only the pixels a projection sees (no I/O).

A fisheye or dual-fisheye frame spends a third of its samples or more outside its image
circles (a Ricoh Theta S 1280×720: 32 %; a Pi camera's 640×480 fisheye: 43 %), where every
weight of the projection is zero. Decoding an 8-bit sample through its table costs about six
instructions (cv2.LUT, scalar), the largest item of a frame, so each band of rows decodes
only the column spans where some pixel of the band has a weight; the rest of the band stays
zero (black, as a real lens's surround). The projection is unchanged (zero weight times
zero), and so are the clipped tallies (counted on the 8-bit frame). The lights' detection
copy sees the surround as black: blocks that straddle the circle's edge average the seen
pixels with zeros instead of with whatever the sensor recorded outside the lens.

:class:`FoldDecode` is SH9's fused decode strategy in the frame pass
(:mod:`provider.core.framepass`): an 8-bit frame of a folded lens decoded inside the fold's
C kernel, no float band at all.
"""
from __future__ import annotations

import cv2
import numpy as np

from ..radiometry.blocks import shrink
from ..radiometry.response import apply_lut

#: Column gaps narrower than this are decoded anyway: one more cv2.LUT call costs more
#: than a few dozen samples.
MERGE_GAP = 16
#: The spans are used only when they leave out at least this share of the frame's samples.
MIN_SAVING = 0.1


def _runs(columns: np.ndarray, merge_gap: int) -> list:
    """[(a, b)]: runs of True in a (W,) bool array, gaps < merge_gap merged."""
    edges = np.flatnonzero(np.diff(np.r_[0, columns.astype(np.int8), 0]))
    runs = []
    for a, b in zip(edges[::2], edges[1::2]):
        if runs and a - runs[-1][1] < merge_gap:
            runs[-1] = (runs[-1][0], int(b))
        else:
            runs.append((int(a), int(b)))
    return runs


class DecodeSpans:
    """Per band of ``band_rows`` rows: the column spans to decode, and the spans of the
    previous band's that this one leaves out (zeroed in a reused band buffer)."""

    def __init__(self, support: np.ndarray, band_rows: int, align: int = 1):
        h, w = support.shape
        self.band_rows, self.width = band_rows, w
        self.spans, self.clear = [], []
        previous = np.zeros(w, bool)
        decoded = 0
        for r0 in range(0, h, band_rows):
            cols = support[r0:r0 + band_rows].any(axis=0)
            if align > 1:        # whole blocks of the lights' detection copy
                cols = np.repeat(cols[:w - w % align].reshape(-1, align).any(axis=1),
                                 align)
                cols = np.r_[cols, np.zeros(w % align, bool)]
            runs = _runs(cols, MERGE_GAP)
            covered = np.zeros(w, bool)
            for a, b in runs:
                covered[a:b] = True
            self.spans.append(runs)
            self.clear.append(_runs(previous & ~covered, 1))
            previous = covered
            decoded += covered.sum() * min(band_rows, h - r0)
        self.fraction = decoded / float(h * w)
        first = np.zeros(w, bool)
        for a, b in self.spans[0]:
            first[a:b] = True
        self.restart = _runs(previous & ~first, 1)     # the last band's, not the first's
        self._pool = []

    @classmethod
    def of(cls, support: np.ndarray, band_rows: int, align: int = 1):
        """The spans of a (H, W) support mask, or None when they would save too little."""
        spans = cls(support, band_rows, align)
        return spans if spans.fraction <= 1.0 - MIN_SAVING else None

    def new_buffer(self) -> np.ndarray:
        """A (band_rows, W, 3) float32 band buffer for one frame's :meth:`decode` calls,
        zero outside the first band's spans; give it back with :meth:`done`. Buffers are
        reused (a pool: one per frame in flight): zeroing a fresh one costs more than the
        decoding it saves."""
        try:
            return self._pool.pop()
        except IndexError:
            return np.zeros((self.band_rows, self.width, 3), np.float32)

    def done(self, buffer: np.ndarray) -> None:
        """``buffer`` (after the last band) back into the pool, zero outside band 0's spans."""
        for a, b in self.restart:
            buffer[:, a:b] = 0.0
        self._pool.append(buffer)

    def decode(self, band: np.ndarray, r0: int, table: np.ndarray,
               buffer: np.ndarray) -> np.ndarray:
        """Linear float32 rows [r0, r0 + len(band)) through ``table``: the band's spans
        decoded into ``buffer``, zero elsewhere (bands in increasing order)."""
        k = r0 // self.band_rows
        out = buffer[:band.shape[0]]
        for a, b in self.clear[k]:       # all rows: a short last band leaves none stale
            buffer[:, a:b] = 0.0
        for a, b in self.spans[k]:
            if band.dtype == np.uint8:
                cv2.LUT(band[:, a:b], table, dst=out[:, a:b])
            else:
                apply_lut(band[:, a:b], table, dst=out[:, a:b])
        return out

    def columns(self, r0: int) -> list:
        """The column spans decoded in the band that starts at row ``r0``."""
        return self.spans[r0 // self.band_rows]


class DownsampledSpans:
    """The fast path's (``--downsample F``) area average of a frame's linear values, decoding
    only the blocks the small projection gives a weight: each band of rows decodes its
    seen spans (whole blocks) and shrinks them (:func:`shrink`). Blocks with no weight
    come out zero, which the projection multiplies by zero: the coefficients are those of
    decoding the whole frame first. None (:meth:`of`) where it would save too little or the
    bands do not hold whole blocks."""

    def __init__(self, spans: DecodeSpans, factor: int, size: tuple[int, int]):
        self.spans, self.factor, self.size = spans, factor, size

    @classmethod
    def of(cls, small_support: np.ndarray, factor: int, band_rows: int):
        """From the small projection's (h, w) mask of pixels with a weight."""
        if factor < 2 or band_rows % factor:
            return None
        full = np.repeat(np.repeat(small_support, factor, axis=0), factor, axis=1)
        spans = DecodeSpans.of(full, band_rows, align=factor)
        h, w = small_support.shape
        return None if spans is None else cls(spans, factor, (w, h))

    def small(self, frame: np.ndarray, table: np.ndarray) -> np.ndarray:
        """(h, w, 3) float32: the block averages of ``frame`` through ``table``."""
        (w, h), f, spans = self.size, self.factor, self.spans
        out = np.empty((h, w, 3), np.float32)
        buffer = spans.new_buffer()
        for r0 in range(0, h * f, spans.band_rows):
            band = frame[r0:min(r0 + spans.band_rows, h * f), :w * f]
            lin = spans.decode(band, r0, table, buffer)
            out[r0 // f:(r0 + len(band)) // f] = shrink(lin, (w, len(band) // f))
        spans.done(buffer)
        return out


class FoldDecode:
    """The frame pass's fused strategy for a lens's fold: an 8-bit frame decoded inside the
    fold's C kernel, one pass over the bytes that fills the SH9 sums and the lights'
    detection copy (no float copy of the frame) and counts the clipped samples. The other
    sinks get no band: a cube's work image stays incomplete (its own decode_blocks costs
    less than a float copy shared by both)."""

    serves = frozenset({"sh9", "lights", "clip"})

    def __init__(self, fold):
        self.fold = fold

    def accepts(self, frame, sinks) -> bool:
        lights = sinks.lights
        if frame.dtype != np.uint8 or not self.fold.decodes(
                frame, None if lights is None else lights.image.shape[:2],
                1 if lights is None else lights.factor):
            return False
        for name, s in sinks.named.items():
            if s.needs_bands and name not in self.serves:
                return False
        return True

    def run(self, fp, decoder, frame, table, lut, sinks, stats):
        lights, clip = sinks.lights, sinks.clip
        tally = None if clip is None else np.zeros(4)
        # A clean copy (nothing for the lights to clamp): their first pass in the kernel
        first = (lights.extractor.first_pass_args(lights.image.shape[:2])
                 if lights is not None and lights.clean else None)
        done = self.fold.decode_project(frame, table, sinks.sh9.acc,
                                        None if lights is None else lights.image,
                                        1 if lights is None else lights.factor, tally,
                                        mean=False, first=first)
        if lights is not None:    # block sums: the lights' first pass scales them in cache
            lights.first = done
            lights.scale = 1.0 if done else 1.0 / (lights.factor * lights.factor)
        if clip is not None:
            clip.folded(tally, stats)
        for s in sinks.all:
            s.finish(stats)
