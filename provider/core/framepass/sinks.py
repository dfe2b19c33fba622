"""The sink protocol of the frame pass, the sinks of one frame, and the kept frames (no I/O).

A sink is one product of a frame pass. For each frame the pass calls, in order:

1. ``start(frame, table, stats)``: the raw frame (after its window), its decode table
   (None for a float frame) and the frame's statistics;
2. ``band(lin, r0, raw, columns)`` for each band of rows, in order from row 0: the linear
   float32 rows ``[r0, r0 + len(lin))``, the same rows of the raw frame, and the column
   spans ``[(a, b)]`` that were decoded (zero elsewhere), or None (all). A sink
   ``at_projection`` is fed at the projection's size instead: on the fast path
   (``downsample`` > 1) it gets the block means once, through ``whole(lin)``;
3. ``finish(stats)``: after the last band; the sink then holds its result.

A sink is registered under a name (``Sinks(sh9=..., lights=...)``), which the caller reads it
by (``sinks.sh9``) and a fused strategy names it by. What a sink declares: ``at_projection``,
``all_columns`` (needs every column decoded: no spans) and ``needs_bands`` (False: it copes
with a pass that feeds it no band, a fused kernel's or the fast path's, by reading the raw
frame in ``finish`` or by staying incomplete).
"""
from __future__ import annotations

import numpy as np


class Sink:
    """One product of a frame pass (see the module docstring); each method does nothing
    by default."""

    at_projection = False
    all_columns = False
    needs_bands = True

    def start(self, frame: np.ndarray, table: np.ndarray | None, stats: dict) -> None:
        """Before the first band of ``frame``."""

    def band(self, lin: np.ndarray, r0: int, raw: np.ndarray | None,
             columns: list | None) -> None:
        """Linear float32 rows ``[r0, r0 + len(lin))``."""

    def whole(self, lin: np.ndarray) -> None:
        """The whole linear frame at once at the projection's size (the fast path's block
        means): one band by default."""
        self.band(lin, 0, None, None)

    def finish(self, stats: dict) -> None:
        """After the last band."""


class Sinks:
    """The sinks registered for one frame by name (``named``), in the order they are fed
    (``all``); each read as an attribute (``sinks.lights``), None where the frame does not
    feed that product. A product's subclass names its sinks as class attributes set to
    None: an absent one then costs no failed lookup (a frame's pass is counted in
    instructions: ``shlight bench --sections edge``)."""

    def __init__(self, **sinks: Sink):
        self.__dict__.update(sinks)
        self.named = sinks
        self.all = list(sinks.values())

    def __getattr__(self, name: str):
        if name.startswith("__"):
            raise AttributeError(name)
        return None

    def __iter__(self):
        return iter(self.all)


class WholeFrame(Sink):
    """The whole linear frame, kept for a reader after the pass (``image``): the frame
    itself where every band was it (a clean float32 frame), else a float32 copy."""

    frame = out = image = None

    def start(self, frame, table, stats):
        self.frame, self.out = frame, None

    def band(self, lin, r0, raw, columns):
        if self.out is None:
            if np.may_share_memory(lin, self.frame):    # still the frame itself
                return
            if r0 == 0 and lin.shape[0] == self.frame.shape[0]:    # decoded whole
                self.out = lin
                return
            self.out = np.empty(self.frame.shape, np.float32)
            self.out[:r0] = self.frame[:r0]
        self.out[r0:r0 + lin.shape[0]] = lin

    def finish(self, stats):
        self.image = self.frame if self.out is None else self.out
        self.frame = self.out = None


class SmallFrame(Sink):
    """The fast path's block means (``image``), kept for a reader after the pass (the
    error estimate)."""

    at_projection = True
    needs_bands = False
    image = None

    def whole(self, lin):
        self.image = lin
