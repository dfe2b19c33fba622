"""The Python twin of the C fold kernel (``_fold.c``): the same signature, the same
numbers to float rounding, the same errors (no I/O).

:mod:`.lens_fold` chooses one of the two once, at import, as the ``websockets`` library
chooses its ``speedups``: the C kernel where ``pip install`` built it, this twin where it
could not (no C compiler). The tests run the products over both (the ``kernels`` fixture)
and drive both with random arrays (``tests/core/kernels/test_kernel_twins.py``). Sums in float64 where
the C sums a row in float32 lanes: they differ by float rounding.
"""
from __future__ import annotations

import operator

import numpy as np

from ..radiometry.blocks import buffer_view, c_int, contiguous


def fold_lens(frame, table, geometry, extents, tables, parities, sums, mid, factor,
              clear) -> None:
    """One lens's folded projection of ``frame`` (8-bit through ``table``, or linear
    float32 with ``table`` None) added to ``sums``, and its pixels' block sums to ``mid``:
    see ``_fold.c`` (the arguments) and ``_fold.pyi``."""
    xl, xr, yt, yb, nx, ny = (operator.index(v) for v in _six(geometry))
    f, clear = c_int(factor), bool(clear)
    use_mid, linear = mid is not None, table is None
    fr = buffer_view(frame, False, "f" if linear else "B", 3,
                     "frame (no table: float32)" if linear else "frame (with a table: uint8)")
    tb = None if linear else buffer_view(table, False, "f", 1, "table")
    ex = buffer_view(extents, False, "i", 1, "extents")
    tabs = buffer_view(tables, False, "f", 2, "tables")
    par = buffer_view(parities, False, "i", 1, "parities")
    sm = buffer_view(sums, True, "d", 2, "sums")
    md = buffer_view(mid, True, "f", 3, "mid") if use_mid else None
    H, W = fr.shape[:2]
    K = tabs.shape[0]
    item = 4 if linear else 1
    err = None
    if fr.shape[2] != 3 or fr.strides[2] != item or fr.strides[1] != 3 * item:
        err = "frame: (H, W, 3) with contiguous pixels"
    elif not linear and (not contiguous(tb) or tb.shape[0] not in (256, 768)):
        err = "table: 256 contiguous entries, or 768 (per channel)"
    elif (nx < 1 or ny < 1 or xl < nx or yt < ny or xr < xl or yb < yt or nx > W - xr
          or ny > H - yb):
        err = "geometry: the square must lie inside the frame"
    elif not contiguous(ex) or ex.shape[0] != ny:
        err = "extents: (ny,) contiguous int32"
    elif not contiguous(tabs) or tabs.shape[1] != nx * ny:
        err = "tables: (K, ny * nx) contiguous float32"
    elif not contiguous(par) or par.shape[0] != K:
        err = "parities: (K,) contiguous int32"
    elif not contiguous(sm) or sm.shape[0] != K or sm.shape[1] != 3:
        err = "sums: (K, 3) contiguous float64"
    elif use_mid and (f < 1 or not contiguous(md) or md.shape[0] != H // f
                      or md.shape[1] != W // f or md.shape[2] != 3
                      or nx > (W // f) * f - xr or ny > (H // f) * f - yb):
        err = "mid: (H / f, W / f, 3) float32 holding the square's blocks"
    extent = np.asarray(ex).astype(np.int64)
    parity = np.asarray(par).astype(np.int64)
    if err is None and np.any((extent < 0) | (extent > nx)):
        err = "extents: in [0, nx]"
    if err is None and np.any((parity < 0) | (parity > 3)):
        err = "parities: 0 to 3"
    if err is not None:
        raise ValueError(err)

    # The four quarters, each row i and column j counted from the centre: bottom right a,
    # bottom left b, top right c, top left d; a row pair reads columns j < extent[i] only.
    pixels = np.asarray(fr)
    i, j = np.arange(ny)[:, None], np.arange(nx)[None, :]
    rows = (yb + i, yb + i, yt - 1 - i, yt - 1 - i)
    cols = (xr + j, xl - 1 - j, xr + j, xl - 1 - j)
    read = np.broadcast_to(j < extent[:, None], (ny, nx))
    t = None if linear else np.asarray(tb).astype(np.float64)
    quarters = []
    for r, c in zip(rows, cols):
        q = pixels[r, c]                                       # (ny, nx, 3)
        if linear:
            q = q.astype(np.float64)
        elif t.size == 256:
            q = t[q]
        else:
            q = t.reshape(256, 3)[q, np.arange(3)]
        quarters.append(np.where(read[..., None], q, 0.0))
    a, b, c, d = quarters
    folds = np.stack([(a + b) + (c + d), (a - b) + (c - d), (a + b) - (c + d),
                      (a - b) - (c - d)]).reshape(4, ny * nx, 3)
    weights = np.asarray(tabs).astype(np.float64)
    out = np.asarray(sm)
    for k in range(K):
        out[k] += weights[k] @ folds[parity[k]]
    if use_mid:
        blocks = np.asarray(md)
        if clear:
            blocks[...] = 0.0
        mh, mw = H // f, W // f
        at = np.concatenate([((r // f) * mw + c // f)[read] for r, c in zip(rows, cols)])
        values = np.concatenate([q[read] for q in quarters])
        for ch in range(3):
            added = np.bincount(at, values[:, ch], minlength=mh * mw)
            blocks[..., ch] += added.reshape(mh, mw).astype(np.float32)


def _six(geometry) -> tuple:
    """``geometry`` unpacked as ``PyArg_ParseTuple``'s "(nnnnnn)" does (a sequence of 6)."""
    try:
        items = tuple(geometry)
    except TypeError:
        raise TypeError("must be sequence of length 6, not "
                        f"{type(geometry).__name__}") from None
    if len(items) != 6:
        raise TypeError(f"must be sequence of length 6, not {len(items)}")
    return items
