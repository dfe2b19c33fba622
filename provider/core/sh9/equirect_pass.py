"""An 8-bit equirect frame projected in one pass over its bytes (no I/O).

:func:`project` decodes each byte through the frame's table and sums the decoded rows
against the separable row weights of :class:`~provider.core.geometry.projections.Equirect`
in the same pass, folded by the sphere's symmetries (about the equator, and a half turn:
``_equirect.c`` says how), and counts the samples at the top code on the way: what the band
by band ``cv2.LUT`` and matrix product of :class:`~.engine.SH9Projector` compute, without
the float copy of the frame (issue 44: 69.9 M x86 instructions a 1920×960 frame before).

Its kernel is chosen once, at import, as the ``websockets`` library chooses its
``speedups``: the C kernel ``_equirect.c`` (built by ``pip install``; ``setup.py``), or
where it was not built its Python twin :func:`_equirect_rows_py`: the same signature, the
same numbers to float rounding, the same errors (``tests/core/kernels/test_kernel_twins.py``). The
projector takes this pass only where the C kernel is built (:data:`KERNEL`); without it the
band by band path is as fast as the twin.
"""
from __future__ import annotations

import numpy as np

from ..radiometry.blocks import buffer_view, contiguous

#: Under the equator's mirror, row H-1-y weighs as +/- row y: the six row functions' signs
#: (1, cos, sin, cos², sin·cos, sin², each times sin θ).
ROW_SIGNS = (1, -1, 1, 1, -1, 1)
#: Under a half turn, column x + W/2 adds (+1) or subtracts (-1): the row functions' column
#: partners' parity (cos φ, sin φ odd), and the up row (its column function is 1).
HALF_TURN = (1, 1, -1, 1, -1, 1, 1)


def _equirect_rows_py(frame, table, rows, acc, counts) -> None:
    """The Python twin of the C kernel ``_equirect.equirect_rows`` (its signature and
    checks, see ``_equirect.c`` and ``_equirect.pyi``): ``acc[k, :3W/2]`` gets the folded
    sums of the frame decoded through ``table`` against row ``k``'s weights, ``counts`` the
    samples at code 255 per row and channel; row 0's weights are not read (rows 3 and 5
    added). Sums in float64 (the C in float32: they differ by float rounding)."""
    fr = buffer_view(frame, False, "B", 3, "frame")
    tb = buffer_view(table, False, "f", 1, "table")
    rw = buffer_view(rows, False, "f", 2, "rows")
    ac = buffer_view(acc, True, "f", 2, "acc")
    ct = None if counts is None else buffer_view(counts, True, "i", 2, "counts")
    H, W = fr.shape[:2]
    K = rw.shape[0]
    err = None
    if fr.shape[2] != 3 or fr.strides[2] != 1 or fr.strides[1] != 3 or W % 2:
        err = "frame: (H, W, 3) with W even and contiguous pixels"
    elif not contiguous(tb) or tb.shape[0] not in (256, 768):
        err = "table: 256 contiguous entries, or 768 (per channel)"
    elif K not in (6, 7) or rw.shape[1] != H or not contiguous(rw):
        err = "rows: (6 or 7, H) contiguous float32"
    elif ac.shape[0] != K or ac.shape[1] != 3 * W or not contiguous(ac):
        err = "acc: (K, W * 3) contiguous float32"
    elif ct is not None and (ct.shape[0] != H or ct.shape[1] != 3 or not contiguous(ct)):
        err = "counts: (H, 3) contiguous int32"
    if err is not None:
        raise ValueError(err)
    pixels = np.asarray(fr)
    t = np.asarray(tb).astype(np.float64)
    lin = t[pixels] if t.size == 256 else t.reshape(256, 3)[pixels, np.arange(3)]
    lin = lin.reshape(H, 3 * W)
    half = 3 * W // 2
    folded = {1: lin[:, :half] + lin[:, half:], -1: lin[:, :half] - lin[:, half:]}
    # Each row function's weight of every row: the bottom half mirrors the top's (the
    # middle row of an odd height keeps its own); the up row is read whole.
    weights = np.asarray(rw).astype(np.float64)
    pairs = H // 2
    for k, sign in enumerate(ROW_SIGNS):
        weights[k, H - pairs:] = sign * weights[k, :pairs][::-1]
    # Row 0 is not read: sin θ = sin θ cos² θ + sin θ sin² θ, rows 3 and 5 added (the C
    # kernel weighs each folded sample by rows 3 and 5 only).
    weights[0] = weights[3] + weights[5]
    out = np.asarray(ac)
    for k in range(K):
        out[k, :half] += weights[k] @ folded[HALF_TURN[k]]
    if ct is not None:
        np.asarray(ct)[...] = (pixels == 255).sum(axis=1)


try:
    from ._equirect import equirect_rows as _equirect_rows
except ImportError:          # built without a C compiler: its Python twin
    _equirect_rows = _equirect_rows_py

#: True when the C kernel is built (``pip install`` with a C compiler).
KERNEL = _equirect_rows is not _equirect_rows_py


def takes(frame: np.ndarray, table: np.ndarray) -> bool:
    """Whether :func:`project` takes this frame and table: the kernel built, an (H, W, 3)
    uint8 frame of even width (a half turn is whole columns), a float32 table of 256 or 768
    entries."""
    return (KERNEL and frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
            and frame.shape[1] % 2 == 0 and table.dtype == np.float32
            and table.size in (256, 768))


def project(frame: np.ndarray, table: np.ndarray, rows: np.ndarray,
            acc: np.ndarray) -> np.ndarray:
    """Add an 8-bit equirect frame's folded row sums to ``acc`` (K, W·3) float32 (K = 6, or
    7 with the up-facing cosine row), its first half; the second half is left as it is, and
    the column contraction (``SH9Projector._coefficients``) gives the coefficients as from
    the unfolded sums (the column functions' half-turn symmetry). ``table``: float32 (256,),
    or (256, 1, 3) one curve per channel. Returns (H, 3) int32: the samples at code 255 of
    each row and channel."""
    counts = np.empty((frame.shape[0], 3), np.int32)
    if frame.strides[2] != 1 or frame.strides[1] != 3:
        frame = np.ascontiguousarray(frame)
    _equirect_rows(frame, np.ascontiguousarray(table, np.float32).reshape(-1),
                   np.ascontiguousarray(rows, np.float32), acc, counts)
    return counts


class EquirectRows:
    """The frame pass's fused strategy (:mod:`provider.core.framepass`) for an 8-bit
    equirect frame: :func:`project`, one pass over the bytes that fills the SH9 sums (the
    up-facing row with them) and counts the clipped samples. Taken where the frame
    feeds no other sink (the lights' copy, a cube's work image share the band pass's decode);
    a table the kernel does not take goes to ``bands`` (the band by band strategy)."""

    serves = frozenset({"sh9", "up", "clip"})

    def __init__(self, rows: np.ndarray, bands):
        self.rows, self.bands = np.ascontiguousarray(rows, np.float32), bands

    def accepts(self, frame, sinks) -> bool:
        if not (frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
                and frame.shape[1] % 2 == 0):
            return False
        # Only its own sinks: a lights' copy or a cube's work image shares the band pass's
        # decode (one decode for them all costs less than this pass and a second decode).
        return self.serves.issuperset(sinks.named)

    def run(self, fp, decoder, frame, table, lut, sinks, stats):
        if not takes(frame, table):
            return self.bands.run(fp, decoder, frame, table, lut, sinks, stats)
        counts = project(frame, table, self.rows, sinks.sh9.acc)
        sinks.sh9.folded = True        # its column contraction reads the first half only
        if sinks.clip is not None:
            sinks.clip.counted(counts, stats)
        for s in sinks.all:
            s.finish(stats)
