"""The lights' views of a frame for the engine's frame pass (no I/O): the detection copy a
pass fills (:class:`DetectionCopy`, a sink of :mod:`provider.core.framepass`) and the
full-resolution linear radiance decoded on demand where a light is refined
(:class:`LinearView`)."""
from __future__ import annotations

import numpy as np

from ..framepass.sinks import Sink
from .extractor import LightExtractor


class DetectionCopy(Sink):
    """The lights' sink in the frame pass: the detection copy (``image``, mid resolution
    block means of ``factor``) of an integer frame, built band by band from the linear
    bands (:meth:`LightExtractor.reduce_band`) or by a fused kernel that serves it."""

    def __init__(self, extractor: LightExtractor):
        self.extractor, self.factor = extractor, extractor.mid_factor
        self.image = extractor.new_mid()
        #: ``clean``: no negative or non-finite sample (a table's block means); ``scale``:
        #: what makes ``image`` the block means (a fused kernel may leave block sums);
        #: ``first``: the first pass's (Y, total, coarse, Ymax) where a fused kernel ran it
        self.clean, self.scale, self.first = False, 1.0, None

    def start(self, frame, table, stats):
        # Block means of a table's values hold no negative or non-finite sample where the
        # table holds none: the lights then skip their clamp, a whole pass over the copy
        # (issue 44). A 16-bit table is not scanned every frame.
        self.clean = (table is not None and table.size <= 4096
                      and bool(np.isfinite(table).all()) and float(table.min()) >= 0.0)
        self.scale, self.first = 1.0, None

    def band(self, lin, r0, raw, columns):
        self.extractor.reduce_band(lin, r0, self.image, columns)


class LinearView:
    """The linear radiance of an integer frame, decoded slice by slice on demand, for
    :meth:`LightExtractor.refine` (which reads a few hundred pixels under each compact
    light): ``view[r0:r1, c0:c1]`` = ``linearise(frame[r0:r1, c0:c1])``."""

    def __init__(self, frame: np.ndarray, linearise):
        self.frame, self.linearise = frame, linearise
        self.shape = frame.shape

    def __getitem__(self, index):
        return self.linearise(np.ascontiguousarray(self.frame[index]))
