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

from ..lights.first_pass import first_pass_twin
from ..radiometry.blocks import buffer_view, c_int, contiguous


#: Each lens-frame SH9 weight's fold code (0: x even, y even; 1: x odd; 2: y odd; 3: both)
#: and the monomial of (dx, dy) it carries beside its radial part (see ``_fold.c``).
SH_PARITY = (0, 2, 0, 1, 3, 2, 0, 1, 0)
SH_MONOMIAL = ("1", "dy", "1", "dx", "dx dy", "dy", "1", "dx", "dx2 - dy2")
#: Columns of a radial table's row (one a bin): values and slopes of weights 0-7, then 8's.
RADIAL_COLUMNS = 20


def radial_weights(radial, inv_step, geometry, ks=range(9)) -> np.ndarray:
    """(9, ny·nx) float64: the lens-frame SH9 weights of a lens's quarter pixels (i, j) from
    its radial table, as the kernel computes them: r = √(dx² + dy²) (dx = j + (xr − xl + 1)/2,
    dy = i + (yb − yt + 1)/2, the pixel centre's distance from the lens centre), bin b =
    ⌊r·inv_step⌋ (at most the last), weight k = (value + (r·inv_step − b)·slope) × its
    monomial; r, its bin and the fraction in float32, as the C. ``ks``: those weights only
    (len(ks), ny·nx)."""
    xl, xr, yt, yb, nx, ny = geometry
    rad = np.asarray(radial, np.float32)
    f32 = np.float32
    dx = f32((xr - xl + 1) / 2) + np.arange(nx, dtype=f32)
    dy = f32((yb - yt + 1) / 2) + np.arange(ny, dtype=f32)
    t = np.sqrt(dx[None, :] * dx[None, :] + dy[:, None] * dy[:, None]) * f32(inv_step)
    b = np.minimum(t.astype(np.int64), rad.shape[0] - 1)
    frac = (t - b.astype(f32)).astype(np.float64).reshape(-1)
    b = b.reshape(-1)
    X = np.broadcast_to(dx[None, :].astype(np.float64), (ny, nx)).reshape(-1)
    Y = np.broadcast_to(dy[:, None].astype(np.float64), (ny, nx)).reshape(-1)
    mono = {"1": 1.0, "dx": X, "dy": Y, "dx dy": X * Y, "dx2 - dy2": X * X - Y * Y}
    w = np.empty((len(ks), ny * nx))
    for n, k in enumerate(ks):  # a weight at a time: a table's build holds little more
        value, slope = (k, 8 + k) if k < 8 else (16, 17)
        w[n] = (rad[b, value] + frac * rad[b, slope]) * mono[SH_MONOMIAL[k]]
    return w


def fold_lens(frame, table, geometry, others, extents, radial, inv_step, fix_at, fixes,
              tables, parities, sums, mid, factor, clear, clip=None, residual=None,
              first=None):
    """One lens's folded projection of ``frame`` (8-bit through ``table``, or linear
    float32 with ``table`` None) added to ``sums``, its pixels' block sums to ``mid``, and
    its samples at code 255 with their L00 weight to ``clip``; the ``residual`` pixels'
    sums; the lights' ``first`` pass over ``mid`` (its total returned): see ``_fold.c``
    (the arguments) and ``_fold.pyi``."""
    if residual is not None and not (isinstance(residual, tuple) and len(residual) == 4):
        raise TypeError("residual: a tuple (starts, cols, weights, sums) or None")
    if first is not None and not (isinstance(first, tuple) and len(first) == 7):
        raise TypeError("first: a tuple (luma, omega, Y, coarse, factor, scale, Ymax) or None")
    cf, fscale = (operator.index(first[4]), float(first[5])) if first is not None else (1, 1.0)
    xl, xr, yt, yb, nx, ny = (operator.index(v) for v in _six(geometry))
    f, clear = c_int(factor), bool(clear)
    use_mid, linear = mid is not None, table is None
    fr = buffer_view(frame, False, "f" if linear else "B", 3,
                     "frame (no table: float32)" if linear else "frame (with a table: uint8)")
    tb = None if linear else buffer_view(table, False, "f", 1, "table")
    oth = buffer_view(others, False, "i", 2, "others")
    ex = buffer_view(extents, False, "i", 1, "extents")
    rad = buffer_view(radial, False, "f", 2, "radial")
    inv = float(inv_step)
    fat = buffer_view(fix_at, False, "i", 1, "fix_at")
    fx = buffer_view(fixes, False, "f", 2, "fixes")
    tabs = buffer_view(tables, False, "f", 2, "tables")
    par = buffer_view(parities, False, "i", 1, "parities")
    sm = buffer_view(sums, True, "d", 3, "sums")
    md = buffer_view(mid, True, "f", 3, "mid") if use_mid else None
    cl = buffer_view(clip, True, "d", 1, "clip") if clip is not None else None
    rv = None if residual is None else [
        buffer_view(a, n == 3, fmt, nd, name) for n, (a, fmt, nd, name) in enumerate(zip(
            residual, "iifd", (1, 1, 2, 2), ("residual starts", "residual cols",
                                             "residual weights", "residual sums")))]
    fv = None if first is None else [
        buffer_view(a, n >= 2, "f", nd, name) for n, (a, nd, name) in enumerate(zip(
            (*first[:3], first[6], first[3]), (1, 2, 2, 1, 3),
            ("luma", "omega", "Y", "Ymax", "coarse"))) if a is not None]
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
    elif not contiguous(oth) or oth.shape[1] != 2:
        err = "others: (M, 2) contiguous int32"
    elif not contiguous(ex) or ex.shape[0] != ny:
        err = "extents: (ny,) contiguous int32"
    elif not contiguous(rad) or rad.shape[0] < 1 or rad.shape[1] != RADIAL_COLUMNS:
        err = "radial: (B, 20) contiguous float32"
    elif not (0.0 < inv < float("inf")):
        err = "inv_step: positive and finite"
    elif (not contiguous(fat) or not contiguous(fx) or fx.shape[0] != fat.shape[0]
          or fx.shape[1] != 9):
        err = "fixes: (F,) int32 and (F, 9) float32, contiguous"
    elif not contiguous(tabs) or tabs.shape[1] != nx * ny:
        err = "tables: (K, ny * nx) contiguous float32"
    elif not contiguous(par) or par.shape[0] != K:
        err = "parities: (K,) contiguous int32"
    elif (not contiguous(sm) or sm.shape[0] != 1 + oth.shape[0] or sm.shape[1] != 9 + K
          or sm.shape[2] != 3):
        err = "sums: (1 + M, 9 + K, 3) contiguous float64"
    elif use_mid and (f < 1 or not contiguous(md) or md.shape[0] != H // f
                      or md.shape[1] != W // f or md.shape[2] != 3
                      or nx > (W // f) * f - xr or ny > (H // f) * f - yb):
        err = "mid: (H / f, W / f, 3) float32 holding the square's blocks"
    elif cl is not None and (linear or not contiguous(cl) or cl.shape[0] != 4):
        err = "clip: (4,) contiguous float64, with a table (an 8-bit frame)"
    elif rv is not None and (not all(map(contiguous, rv)) or rv[0].shape[0] != H + 1
                             or rv[2].shape[0] != rv[1].shape[0] or rv[2].shape[1] < 1
                             or rv[3].shape[0] != rv[2].shape[1] or rv[3].shape[1] != 3):
        err = ("residual: starts (H + 1,) int32, cols (R,) int32, weights (R, C) float32, "
               "sums (C, 3) float64, contiguous")
    elif fv is not None and (not use_mid or not clear):
        err = "first: with mid, in the call that clears it (the only call)"
    elif fv is not None and (not contiguous(fv[0]) or fv[0].shape[0] != 3):
        err = "luma: (3,) float32"
    elif fv is not None and (not contiguous(fv[1]) or not contiguous(fv[2])
                             or not fv[1].shape == fv[2].shape == (H // f, W // f)):
        err = "omega, Y: (h, w) float32, mid's height and width"
    elif fv is not None and (not contiguous(fv[3]) or fv[3].shape != (H // f,)):
        err = "Ymax: (h,) float32"
    elif fv is not None and cf < 1:
        err = "first: factor at least 1"
    elif fv is not None and len(fv) == 5 and (
            not contiguous(fv[4]) or fv[4].shape[2] != 3 or fv[4].shape[0] > (H // f) // cf
            or fv[4].shape[1] > (W // f) // cf):
        err = "coarse: (hc, wc, 3) float32, hc * factor <= h, wc * factor <= w"
    if err is None and rv is not None:
        starts, rcols = np.asarray(rv[0]).astype(np.int64), np.asarray(rv[1]).astype(np.int64)
        if starts[0] != 0 or starts[-1] != rcols.size or np.any(np.diff(starts) < 0):
            err = "residual: starts from 0 to R, non-decreasing"
        elif np.any((rcols < 0) | (rcols >= W)):
            err = "residual: cols in [0, W)"
    lenses = [(xl, xr)]
    if err is None:
        lenses += [tuple(int(v) for v in pair) for pair in np.asarray(oth).reshape(-1, 2)]
    for ol, orr in lenses[1:]:
        if err is None and (ol < nx or orr - ol != xr - xl or nx > W - orr
                            or (use_mid and nx > (W // f) * f - orr)):
            err = "others: (xl, xr) of lenses like the first, inside the frame"
    extent = np.asarray(ex).astype(np.int64)
    parity = np.asarray(par).astype(np.int64)
    if err is None and np.any((extent < 0) | (extent > nx)):
        err = "extents: in [0, nx]"
    if err is None and np.any((parity < 0) | (parity > 3)):
        err = "parities: 0 to 3"
    at = np.asarray(fat).astype(np.int64)
    if err is None and (np.any(np.diff(at) <= 0) or np.any((at < 0) | (at >= nx * ny))):
        err = "fixes: increasing indices in [0, ny * nx)"
    if err is not None:
        raise ValueError(err)

    if use_mid and clear:
        np.asarray(md)[...] = 0.0
    # The SH9 weights from the radial table, the exact corrections of the few quarter
    # pixels it does not fit added; then the per-pixel tables' rows: the same for each lens.
    sh9 = radial_weights(rad, inv, (xl, xr, yt, yb, nx, ny))
    sh9[:, at] += np.asarray(fx).astype(np.float64).T
    weights = np.concatenate([sh9, np.asarray(tabs).astype(np.float64)])
    parity = np.concatenate([SH_PARITY, parity])
    tally = np.zeros(4) if cl is not None else None
    for n, (lxl, lxr) in enumerate(lenses):
        _one_lens(fr, tb, (lxl, lxr, yt, yb, nx, ny), extent, weights, parity,
                  np.asarray(sm)[n], md, f, tally)
    if rv is not None:
        _residual(fr, tb, rv, md, f, tally)
    if tally is not None:         # added once, as the C adds its tally after every lens
        np.asarray(cl)[...] += tally
    if fv is not None:            # the lights' first pass over the finished copy
        return first_pass_twin(np.asarray(md), fscale, np.asarray(fv[0]), np.asarray(fv[1]),
                               np.asarray(fv[2]), np.asarray(fv[4]) if len(fv) == 5 else None,
                               cf, np.asarray(fv[3]))
    return None


def _residual(fr, tb, rv, md, f, tally) -> None:
    """The residual pixels (rows by ``starts``, columns ``cols``): their weights' sums into
    ``sums`` (C, 3), their L00 where clipped into ``tally``, their values into ``md``'s
    blocks."""
    starts, cols, weights, out = (np.asarray(v) for v in rv)
    H, W = fr.shape[:2]
    rows = np.repeat(np.arange(H), np.diff(starts.astype(np.int64)))
    cols = cols.astype(np.int64)
    codes = np.asarray(fr)[rows, cols]                          # (R, 3)
    if tb is None:
        px = codes.astype(np.float64)
    else:
        t = np.asarray(tb).astype(np.float64)
        px = t[codes] if t.size == 256 else t.reshape(256, 3)[codes, np.arange(3)]
    w = weights.astype(np.float64)
    out += w.T @ px
    if tally is not None:
        tally[1:] += (codes == 255).T.astype(np.float64) @ w[:, 0]
    if md is not None:
        blocks = np.asarray(md)
        mh, mw = blocks.shape[:2]
        inside = (rows < mh * f) & (cols < mw * f)
        at = (rows[inside] // f) * mw + cols[inside] // f
        for ch in range(3):
            added = np.bincount(at, px[inside, ch], minlength=mh * mw)
            blocks[..., ch] += added.reshape(mh, mw).astype(np.float32)


def _one_lens(fr, tb, geometry, extent, weights, parity, out, md, f, tally=None) -> None:
    """One lens's sums (``out`` (9 + K, 3)), block sums (``md`` or None) and clip tally
    (``tally`` (4,) float64 or None) of the frame."""
    xl, xr, yt, yb, nx, ny = geometry
    linear = tb is None
    H, W = fr.shape[:2]
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
    if tally is not None:
        # every column of the square counted, the L00 weight (weight 0) where read
        top = np.stack([pixels[r, c] == 255 for r, c in zip(rows, cols)])   # (4, ny, nx, 3)
        tally[0] += np.count_nonzero(top)
        tally[1:] += np.einsum("qijc,ij->c", top & read[..., None],
                               weights[0].reshape(ny, nx))
    a, b, c, d = quarters
    folds = np.stack([(a + b) + (c + d), (a - b) + (c - d), (a + b) - (c + d),
                      (a - b) - (c - d)]).reshape(4, ny * nx, 3)
    for k in range(weights.shape[0]):
        out[k] += weights[k] @ folds[parity[k]]
    if md is not None:
        blocks = np.asarray(md)
        mh, mw = H // f, W // f
        at = np.concatenate([((r // f) * mw + c // f)[read] for r, c in zip(rows, cols)])
        values = np.concatenate([q[read] for q in quarters])
        for ch in range(3):
            added = np.bincount(at, values[:, ch], minlength=mh * mw)
            blocks[..., ch] += added.reshape(mh, mw).astype(np.float32)


def count_top(frame, rects) -> int:
    """The samples at code 255 of an 8-bit ``frame`` in the rectangles ``rects`` (R, 4)
    int32 (r0, r1, a, b): see ``_fold.c``."""
    fr = buffer_view(frame, False, "B", 3, "frame")
    rc = buffer_view(rects, False, "i", 2, "rects")
    H, W = fr.shape[:2]
    err = None
    if fr.shape[2] != 3 or fr.strides[2] != 1 or fr.strides[1] != 3:
        err = "frame: (H, W, 3) with contiguous pixels"
    elif not contiguous(rc) or rc.shape[1] != 4:
        err = "rects: (R, 4) contiguous int32"
    boxes = np.asarray(rc).astype(np.int64).reshape(-1, 4) if err is None else ()
    for r0, r1, a, b in boxes:
        if err is None and not (0 <= r0 <= r1 <= H and 0 <= a <= b <= W):
            err = "rects: (r0, r1, a, b) with 0 <= r0 <= r1 <= H and 0 <= a <= b <= W"
    if err is not None:
        raise ValueError(err)
    pixels = np.asarray(fr)
    return sum(int(np.count_nonzero(pixels[r0:r1, a:b] == 255)) for r0, r1, a, b in boxes)


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
