"""Samples clipped at the top code of an 8/16-bit frame, and the light they carry (no I/O).

``clipped_fraction`` counts the channel samples at the top code; ``clipped_light_fraction``
(docs/contract.md §9) is the share of L00 they put into the projection at their clip level, a lower
bound of the light that was never measured: the sun is a few samples and half the light.
:class:`ClippedLight` computes both for an :class:`~.engine.SH9Projector` at little cost:

* equirect: a SIMD compare of each band of rows while the engine's band loop has it in
  cache (or the equirect kernel's per-row counts, :mod:`.equirect_pass`), then per-row
  counts against the row's L00 weight (the weights are separable); nothing more when
  nothing clips;
* a lens fold's 8-bit frame: the fold's C kernel counts the samples at the top code in its
  lenses' squares and sums their pixels' L00 weight on its way over the bytes
  (:meth:`.lens_fold.LensFold.decode_project`), and its ``count_top`` the few rectangles
  outside the squares (margins, a centre row and column through pixel centres): the frame
  is read once, no mask (issue 44: the whole frame's compare and its mask were 7 MB of
  DRAM traffic a Theta S frame through a Pi's 512 KB cache);
* other dense weights (cubemap, a lens not folded, 16-bit frames, downsampling): the mask
  against a per-pixel map of L00 weights (with downsampling, each block's weight shared by
  its pixels), on the rows that clip only.
"""
from __future__ import annotations

import itertools
import weakref

import cv2
import numpy as np

from ..framepass.sinks import Sink
from ..geometry import sh
from ..geometry.projections import Equirect
from .fold_twin import count_top as _count_top_twin

try:
    from ._fold import count_top as _count_top
except ImportError:          # built without a C compiler: its Python twin (same signature)
    _count_top = _count_top_twin


class ClippedLight:
    """Clipped samples and their L00 for one projector (built by it, reads its weights)."""

    def __init__(self, projector):
        # A proxy, not a reference: the projector holds this object, and a cycle would
        # leave an evicted projector (tens of MB of weights) to the cyclic collector.
        self.p = weakref.proxy(projector)
        self._l00 = None        # equirect: L00 weight per row; dense: per pixel (H, W)
        self._outside = None    # (a lens fold, (H, W), the rectangles outside its squares)

    def start(self, frame: np.ndarray, lut: np.ndarray) -> dict:
        """A tally for one frame decoded through ``lut``."""
        h, w = frame.shape[:2]
        top = 255 if frame.dtype == np.uint8 else 65535
        value = np.asarray(lut[top] if lut.ndim == 1 else lut.reshape(top + 1, 3)[top],
                           np.float64).reshape(-1)
        if self.p._weights is None and (self._l00 is None or len(self._l00) != h):
            full = Equirect(w, h)    # full-resolution rows, whatever the downsampling
            self._l00 = sh.C0 * full.row_integrals()[0] * full.col_integrals()[0].mean()
        # array methods, not numpy's Python wrappers: a frame's tally is counted in
        # instructions (shlight bench --sections edge)
        return {"top": top, "value": value, "one": bool((value == value[0]).all()),
                "n": 0, "l00": 0.0}

    def band(self, band: np.ndarray, r0: int, clip: dict) -> None:
        """Equirect: add a band's clipped samples and the L00 they carry to ``clip``."""
        hb, w = band.shape[:2]
        mask = cv2.compare(band.reshape(hb, w * 3), clip["top"], cv2.CMP_EQ)  # 255: clipped
        n = cv2.countNonZero(mask)
        if n == 0:
            return
        clip["n"] += n
        value, rows = clip["value"], self._l00[r0:r0 + hb]
        if clip["one"]:
            counts = cv2.reduce(mask, 1, cv2.REDUCE_SUM, dtype=cv2.CV_32S).reshape(hb)
            clip["l00"] += float(value[0] * (rows @ counts)) / 255.0
        else:                                  # (cv2.reduce of 3 channels at once is slow)
            planes = cv2.split(mask.reshape(hb, w, 3))
            clip["l00"] += sum(float(value[c] * (rows @ cv2.reduce(
                planes[c], 1, cv2.REDUCE_SUM, dtype=cv2.CV_32S).reshape(hb)))
                for c in range(3)) / 255.0

    def counted(self, counts: np.ndarray, frame: np.ndarray, lut: np.ndarray,
                stats: dict) -> float:
        """Equirect: ``stats["clipped_fraction"]`` from ``counts`` (H, 3), the samples at the
        top code per row and channel (counted by the equirect kernel on its way), and the
        clipped L00 summed over the channels, as :meth:`band` gives it."""
        clip = self.start(frame, lut)
        stats["clipped_fraction"] = int(counts.sum()) / frame.size
        if not stats["clipped_fraction"]:
            return 0.0
        per_row = counts @ np.broadcast_to(clip["value"], (3,))
        return float(self._l00 @ per_row)

    def folded(self, tally: np.ndarray, frame: np.ndarray, lut: np.ndarray,
               stats: dict) -> float:
        """A lens fold's 8-bit frame: ``stats["clipped_fraction"]`` and the clipped L00
        (as :meth:`whole` gives them) from the fold's ``tally`` (4,) (the samples at the top
        code in its lenses' squares, each channel's clipped L00 weight:
        :meth:`.lens_fold.LensFold.decode_project`) and the samples outside the squares
        (the kernel's ``count_top``)."""
        clip = self.start(frame, lut)
        fold, size = self.p._fold, frame.shape[:2]
        made = self._outside
        if made is None or made[0] is not fold or made[1] != size:   # (a test swaps folds)
            made = self._outside = (fold, size, _outside_squares(fold.lenses, *size))
        if frame.strides[2] != 1 or frame.strides[1] != 3:
            frame = np.ascontiguousarray(frame)
        n = int(tally[0]) + _count_top(frame, made[2])
        stats["clipped_fraction"] = n / frame.size
        return float(np.broadcast_to(clip["value"], (3,)) @ tally[1:])

    def _dense(self, mask: np.ndarray, clip: dict) -> float:
        h, w = mask.shape[:2]
        p = self.p
        if self._l00 is None:                  # the L00 weight of every source pixel (once)
            ds = p.downsample
            small = p._l00_weights.reshape(p.projection.height, p.projection.width)
            full = np.zeros((h, w), np.float32)
            bw, bh = p._block
            full[:bh, :bw] = np.repeat(np.repeat(small, ds, 0), ds, 1) / float(ds * ds)
            self._l00 = full
        rows = np.flatnonzero(cv2.reduce(mask.reshape(h, w * 3), 1, cv2.REDUCE_SUM,
                                         dtype=cv2.CV_32S))
        few = len(rows) <= h // 2
        weights = self._l00[rows] if few else self._l00
        total = weights.reshape(-1) @ (mask[rows] if few else mask).reshape(-1, 3).astype(
            np.float32)
        value = clip["value"]
        return float((value if value.size == 3 else value.repeat(3)) @ total) / 255.0

    def whole(self, frame: np.ndarray, lut: np.ndarray, stats: dict) -> float:
        """``stats["clipped_fraction"]`` of a whole frame; returns the clipped L00 summed
        over the channels (in the units of ``lut``)."""
        clip = self.start(frame, lut)
        if self.p._weights is not None:
            h, w = frame.shape[:2]
            mask = cv2.compare(frame.reshape(h, w * 3), clip["top"], cv2.CMP_EQ)
            clip["n"] = cv2.countNonZero(mask)
            if clip["n"]:
                clip["l00"] = self._dense(mask.reshape(h, w, 3), clip)
        else:
            for r0 in range(0, frame.shape[0], self.p.BAND_ROWS):
                self.band(frame[r0:r0 + self.p.BAND_ROWS], r0, clip)
        stats["clipped_fraction"] = clip["n"] / frame.size
        return clip["l00"]


def _outside_squares(lenses, h: int, w: int) -> np.ndarray:
    """(R, 4) int32 (r0, r1, a, b): the pixel rectangles of an (h, w) frame outside the
    lens fold's squares (what its kernel reads: ``_fold.c``). The squares do not overlap:
    each lies in its lens's own columns (``lens_region``)."""
    outside = np.ones((h, w), bool)
    for L in lenses:
        xl, xr, yt, yb, nx, ny = L.geometry
        for rows in (slice(yt - ny, yt), slice(yb, yb + ny)):
            outside[rows, xl - nx:xl] = outside[rows, xr:xr + nx] = False
    edges = (tuple(np.flatnonzero(np.diff(np.r_[0, row.astype(np.int8), 0])))
             for row in outside)         # each row's runs of outside columns: a, b, a, b...
    rects, y = [], 0
    for runs, rows in itertools.groupby(edges):    # rows alike: a rectangle a run
        r1 = y + len(list(rows))
        rects += [(y, r1, a, b) for a, b in zip(runs[::2], runs[1::2])]
        y = r1
    return np.array(rects, np.int32).reshape(-1, 4)


class ClipCount(Sink):
    """The clip counter's sink in the frame pass: ``stats["clipped_fraction"]`` and ``l00``
    (the clipped samples' L00, summed over the channels) of one frame. Equirect: each raw
    band tallied while in cache; a fused kernel's tally (the equirect kernel's, a lens
    fold's); dense weights, or a pass that fed no band and counted nothing, the whole
    8/16-bit frame at the end. A float frame clips nothing."""

    needs_bands = False

    def __init__(self, clipped: ClippedLight):
        self.clipped, self.l00 = clipped, 0.0

    def start(self, frame, table, stats):
        self.frame, self.table, self.tally, self.rows = frame, table, None, 0
        if table is None:
            stats["clipped_fraction"] = 0.0
        elif self.clipped.p._weights is None:
            self.tally = self.clipped.start(frame, table)

    def band(self, lin, r0, raw, columns):
        if self.tally is not None:
            self.clipped.band(raw, r0, self.tally)
            self.rows += raw.shape[0]

    def folded(self, tally: np.ndarray, stats: dict) -> None:
        """A lens fold's tally instead of the whole frame's compare (see
        :meth:`ClippedLight.folded`): the result, and nothing left for :meth:`finish`."""
        self.l00 = self.clipped.folded(tally, self.frame, self.table, stats)
        self.frame = self.table = None

    def counted(self, counts: np.ndarray, stats: dict) -> None:
        """A fused pass's tally instead of the bands (the equirect kernel's samples at the
        top code, (H, 3) per row and channel): the result, and nothing left for
        :meth:`finish`."""
        self.l00 = self.clipped.counted(counts, self.frame, self.table, stats)
        self.frame = self.table = None

    def finish(self, stats):
        frame, self.frame = self.frame, None
        if self.table is None:
            return
        if self.tally is not None and self.rows == frame.shape[0]:
            stats["clipped_fraction"] = self.tally["n"] / frame.size
            self.l00 = self.tally["l00"]
        else:
            self.l00 = self.clipped.whole(frame, self.table, stats)
