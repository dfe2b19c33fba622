"""The cube's work image of one integer frame, filled by the pass that decodes it anyway
(no I/O).

:class:`WorkImage` lets SH9's band-by-band decode of an 8- or 16-bit frame
(:meth:`~provider.core.sh9.engine.SH9Projector.project`'s ``work``) hand the linear bands
to :class:`~provider.core.reflections.environment.EnvironmentProjector`, which then does
not decode the frame again; the projector's own band path fills one the same way.
"""
from __future__ import annotations

import numpy as np

from ..framepass.sinks import Sink
from ..radiometry.blocks import shrink


class WorkImage(Sink):
    """The work image of one integer frame, filled band by band by a pass that decodes the
    frame anyway (SH9's: :meth:`~provider.core.sh9.engine.SH9Projector.project`'s ``work``), so
    that the frame is decoded once for both products. Made by
    :meth:`~provider.core.reflections.environment.EnvironmentProjector.new_work` (its
    ``projector``); bands must come in order from row 0. In the frame pass it is the
    cube's sink: it needs every column decoded, and a pass that feeds it no band (a fused
    kernel's) leaves it incomplete (the cube then decodes the frame itself)."""

    all_columns = True
    needs_bands = False

    def __init__(self, projector):
        self.projector = projector
        w = projector._work
        self.array = np.empty((w.height, w.width, 3), np.float32)
        self.rows = 0                   # frame rows received, in order
        self.complete = False

    def add_band(self, lin: np.ndarray, r0: int) -> None:
        """Linear float32 rows ``[r0, r0 + len(lin))`` of the frame (after its window)."""
        if r0 != self.rows:             # out of order: this work image is not usable
            self.rows = -1
            return
        n = lin.shape[0]
        self.rows += n
        crop = self.projector._crop
        if crop is None:
            self.array[r0:r0 + n] = lin
            self.complete = self.rows >= self.array.shape[0]
            return
        cw, ch = crop
        f = ch // self.array.shape[0]
        stop = min(r0 + n, ch)
        if stop > r0:
            self.array[r0 // f:stop // f] = shrink(
                lin[:stop - r0, :cw], (self.array.shape[1], (stop - r0) // f))
        self.complete = self.rows >= ch

    def band(self, lin, r0, raw, columns):
        self.add_band(lin, r0)
