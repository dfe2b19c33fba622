"""The frame pass: decode strategy × band iteration, in one place (no I/O).

:class:`FramePass` holds a product's decode strategies, in the order they are tried; the
first whose ``accepts(frame, sinks)`` holds decodes the frame and feeds the sinks
(:mod:`.sinks`). A strategy ``serves`` the sinks (by name) it fills inside a fused kernel
(the pass feeds them no band); it accepts a frame only where every other sink copes
without bands.

* :class:`LutBands`: an 8/16-bit frame at its own size, band by band through its table,
  or only the column spans the projection sees (:class:`~provider.core.sh9.support.DecodeSpans`-like
  ``spans``) unless a sink needs every column;
* :class:`FloatBands`: a float frame, each band cleaned
  (:class:`~provider.core.radiometry.float_clean.FloatCleaner`) while in cache;
* :class:`BlockMeans`: the fast path (``downsample`` > 1): the frame's linear block means
  (the C kernel, the spans seen, or a decode and an area resize), fed whole to the sinks at
  the projection's size; the linear frame itself too where a sink at the frame's size
  reads it.
"""
from __future__ import annotations

import numpy as np

from ..radiometry import blocks
from ..radiometry.blocks import shrink
from ..radiometry.float_clean import FloatCleaner, clean_frame

_INTEGER = (np.uint8, np.uint16)


def _finish(sinks, stats: dict) -> None:
    for s in sinks.all:
        s.finish(stats)


class FramePass:
    """One traversal of each frame of a decoder (a
    :class:`~provider.core.radiometry.decode.FrameDecoder`) that feeds the frame's sinks.

    ``strategies``: the decode strategies, tried in order (the product's one list of
    them); ``band_rows``: rows per band (the float32 band stays in cache)."""

    def __init__(self, strategies: list, band_rows: int = 32):
        self.strategies, self.band_rows = list(strategies), band_rows

    def strategy(self, frame: np.ndarray, sinks):
        """The first strategy that takes ``frame`` with these sinks."""
        for strategy in self.strategies:
            if strategy.accepts(frame, sinks):
                return strategy
        raise ValueError(f"no decode strategy takes a {frame.dtype} frame")   # a bug

    def run(self, decoder, frame: np.ndarray, sinks, stats: dict,
            lut: np.ndarray | None = None) -> None:
        """Decode ``frame`` (after ``decoder._prepare``) once and feed ``sinks``; ``lut``: a
        table other than the decoder's own (a bracket slot's)."""
        table = None
        if frame.dtype in _INTEGER:
            table = decoder._lut(frame.dtype) if lut is None else lut
        for s in sinks.all:
            s.start(frame, table, stats)
        self.strategy(frame, sinks).run(self, decoder, frame, table, lut, sinks, stats)


class LutBands:
    """8/16-bit frames at their own size, band by band through the table; ``spans``: decode
    only the columns seen (None: all)."""

    serves = frozenset()

    def __init__(self, spans=None):
        self.spans = spans

    def accepts(self, frame, sinks) -> bool:
        return frame.dtype in _INTEGER

    def run(self, fp, decoder, frame, table, lut, sinks, stats):
        spans = self.spans
        if spans is not None and any(s.all_columns for s in sinks):
            spans = None
        buffer = spans.new_buffer() if spans is not None else None
        fed = sinks.all
        columns = None
        for r0 in range(0, frame.shape[0], fp.band_rows):
            band = frame[r0:r0 + fp.band_rows]
            if spans is None:
                lin = decoder._linearise(band, lut)
            else:
                lin, columns = spans.decode(band, r0, table, buffer), spans.columns(r0)
            for s in fed:
                s.band(lin, r0, band, columns)
        if buffer is not None:
            spans.done(buffer)
        _finish(sinks, stats)


class FloatBands:
    """Float frames (linear radiance), each band cleaned of NaN, infinite and negative
    samples (counted) just before the sinks read it."""

    serves = frozenset()

    def accepts(self, frame, sinks) -> bool:
        return frame.dtype not in _INTEGER

    def run(self, fp, decoder, frame, table, lut, sinks, stats):
        cleaner = FloatCleaner()
        fed = sinks.all
        for r0 in range(0, frame.shape[0], fp.band_rows):
            band = frame[r0:r0 + fp.band_rows]
            lin = cleaner.band(band)
            for s in fed:
                s.band(lin, r0, band, None)
        _finish(sinks, stats)
        cleaner.finish(stats)


class BlockMeans:
    """The fast path: the linear frame area-averaged by ``factor`` over the ``block``
    (w, h) it covers into the projection's ``size`` (w, h). 8-bit frames: the C kernel,
    which decodes and averages in one pass (``kernel_spans``: the blocks it reads);
    ``spans``: decode only the blocks seen (:class:`~provider.core.sh9.support.DownsampledSpans`-like);
    else the whole frame decoded, then resized."""

    serves = frozenset()

    def __init__(self, factor: int, block: tuple, size: tuple, kernel_spans=None,
                 spans=None):
        self.factor, self.block, self.size = factor, block, size
        self.kernel_spans, self.spans = kernel_spans, spans

    def accepts(self, frame, sinks) -> bool:
        return True

    def run(self, fp, decoder, frame, table, lut, sinks, stats):
        integer = frame.dtype in _INTEGER
        # sinks at the frame's size that read it whole (the lights' copy): decode it all
        full = [s for s in sinks.all if not s.at_projection and s.needs_bands]
        lin = None
        bw, bh = self.block
        if frame.dtype == np.uint8 and blocks.KERNEL and not full:
            small = blocks.decode_blocks(frame[:bh, :bw], table, self.factor,
                                         spans=self.kernel_spans)
        elif integer and self.spans is not None and not full:
            small = self.spans.small(frame, table)
        else:
            lin = decoder._linearise(frame, lut) if integer else clean_frame(frame, stats)
            small = shrink(lin[:bh, :bw], self.size)
        for s in sinks.all:
            if s.at_projection:
                s.whole(small)
            elif lin is not None:
                s.band(lin, 0, frame, None)
        _finish(sinks, stats)


def band_rows(factor: int, nominal: int = 32) -> int:
    """Rows per band for a detection copy of ``factor`` × ``factor`` blocks: a multiple of
    the factor between ¾ ``nominal`` and ``nominal`` (a band's float copy no larger than it
    was, so it stays in cache; not many more bands, each a few calls) with the most factors
    of two (a cube's work image of 2, 4, 8 or 16 × 16 blocks shares the bands), the
    nearest ``nominal`` among those; else the tallest multiple up to ``nominal`` (or the
    factor, where it is taller).
    1, 2, 4, 8, 16 → 32; 3 → 24; 5 → 30; 12 → 24; 21 → 21."""
    rows = range(factor * -(-nominal * 3 // 4 // factor), nominal + 1, factor)
    if not rows:
        return factor * max(1, nominal // factor)
    return max(rows, key=lambda r: (r & -r, -abs(r - nominal)))
