"""Each C kernel and its Python twin, driven with random arrays: the same numbers (to float
rounding) or the same error.

Random shapes, strides (negative ones, pixels that are not contiguous), block factors
(larger than the frame too), spans, lens geometries (squares reaching past the frame),
tables, extents and parities, equirect row weights, some of them wrong on purpose: for every draw either both
refuse it with the same exception and message, or both write the same arrays. The arrays'
values come from a drawn seed (numpy fills them), so that hypothesis draws the structure."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from provider.core.radiometry import blocks
from provider.core.sh9 import equirect_pass, fold_twin, lens_fold

pytestmark = pytest.mark.skipif(
    not (blocks.KERNEL and lens_fold.KERNEL and equirect_pass.KERNEL),
    reason="the C kernels were not built (tests/core/kernels/test_kernels.py says how)")

# No deadline: a loaded 2-core machine may take a while for one draw; what is checked is
# what the two compute, never how fast.
SETTINGS = settings(max_examples=200, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
EPS32 = 2.0 ** -24          # float32's unit roundoff
SOURCES = Path(__file__).resolve().parents[3] / "provider" / "core"


@pytest.fixture(scope="module")
def c_kernels(tmp_path_factory):
    """build -> (decode_blocks, fold_lens, equirect_rows, count_top) in C: "vector", as
    installed (GCC's vector extension), and "scalar", compiled here with SHLIGHT_SCALAR_KERNELS (the
    portable loops a compiler without the extension, MSVC, takes)."""
    from setuptools import Distribution, Extension
    from setuptools.command.build_ext import build_ext

    from provider.core.radiometry import _blocks
    from provider.core.sh9 import _equirect, _fold
    out = tmp_path_factory.mktemp("scalar_kernels")
    exts = [Extension(name, [str(SOURCES / source)], include_dirs=[str(SOURCES / "_kernels")],
                      define_macros=[("SHLIGHT_SCALAR_KERNELS", "1")])
            for name, source in (("_blocks", "radiometry/_blocks.c"), ("_fold", "sh9/_fold.c"),
                                 ("_equirect", "sh9/_equirect.c"))]
    cmd = build_ext(Distribution({"ext_modules": exts}))
    cmd.build_lib, cmd.build_temp = str(out), str(out / "tmp")
    cmd.ensure_finalized()
    cmd.run()
    scalar = {}
    for ext in exts:
        spec = importlib.util.spec_from_file_location(ext.name, cmd.get_ext_fullpath(ext.name))
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        scalar[ext.name] = module
    return {"vector": (_blocks.decode_blocks, _fold.fold_lens, _equirect.equirect_rows,
                       _fold.count_top),
            "scalar": (scalar["_blocks"].decode_blocks, scalar["_fold"].fold_lens,
                       scalar["_equirect"].equirect_rows, scalar["_fold"].count_top)}


def _copy(a):
    """A copy of an array a kernel writes, with its strides (a window's rows kept apart)."""
    if a is None or a.flags.c_contiguous:
        return None if a is None else a.copy()
    wide = np.empty((a.shape[0], a.shape[1] + 1) + a.shape[2:], a.dtype)[:, :a.shape[1]]
    wide[...] = a
    return wide


def _call(kernel, args: tuple, written_at: tuple):
    """(the error, None) or (None, the arrays at ``written_at`` after the call, on copies)."""
    call = list(args)
    for i in written_at:
        call[i] = _copy(call[i])
    try:
        kernel(*call)
    except Exception as exc:          # noqa: BLE001: the error itself is compared
        return exc, None
    return None, [call[i] for i in written_at]


def _same(c_kernel, twin, args: tuple, written_at: tuple):
    """Both kernels on copies of the arrays they write (at ``written_at``): (C's written
    arrays, the twin's), or None where both refused the call with the same error."""
    c_err, c_out = _call(c_kernel, args, written_at)
    t_err, t_out = _call(twin, args, written_at)
    if c_err is not None or t_err is not None:
        assert (type(c_err), str(c_err)) == (type(t_err), str(t_err)), (c_err, t_err)
        return None
    return c_out, t_out


def _strided(base: np.ndarray, row_step: int, col_step: int, reverse_channels: bool):
    view = base[::row_step, ::col_step]
    return view[..., ::-1] if reverse_channels else view


BLOCKS_FAULTS = ["factor 0", "factor past the frame", "an empty frame", "5 channels",
                 "pixels not contiguous", "channels reversed", "short table",
                 "float64 table", "out a row too tall", "spans past the row"]


@st.composite
def blocks_calls(draw):
    """(frame, table, factor, out, spans): half of them right, half with one fault."""
    fault = draw(st.sampled_from(BLOCKS_FAULTS)) if draw(st.booleans()) else None
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    H, W = draw(st.integers(1, 20)), draw(st.integers(1, 20))
    H = 0 if fault == "an empty frame" else H
    C = 5 if fault == "5 channels" else draw(st.integers(1, 4))
    factor = draw(st.integers(1, max(min(H, W), 1)))
    factor = {"factor 0": 0, "factor past the frame": max(H, W) + 1}.get(fault, factor)
    row_step = draw(st.sampled_from([1, -1, 2, -2]))
    col_step = draw(st.sampled_from([-1, 2])) if fault == "pixels not contiguous" else 1
    base = rng.integers(0, 256, (H * abs(row_step), W * abs(col_step), C), dtype=np.uint8)
    frame = _strided(base, row_step, col_step, fault == "channels reversed" and C > 1)
    entries = 100 if fault == "short table" else draw(st.sampled_from([256, 256 * C]))
    table = (rng.random(entries) * 4).astype(
        np.float64 if fault == "float64 table" else np.float32)
    f = max(factor, 1)
    h, w = H // f + (fault == "out a row too tall"), W // f
    out = np.full((h, w, C), -7.0, np.float32)
    if draw(st.booleans()):                                  # a window: strided rows
        out = np.full((h, w + 1, C), -7.0, np.float32)[:, :w]
    spans = None
    if draw(st.booleans()) or fault == "spans past the row":
        first = rng.integers(0, w + 1, h)
        stop = first + rng.integers(0, w + 1 - first)
        if fault == "spans past the row" and h > 0:
            stop[-1] = w + 1
        spans = np.stack([first, stop], axis=1).astype(np.int32)
    return frame, table, factor, out, spans


@pytest.mark.parametrize("build", ["vector", "scalar"])
@SETTINGS
@given(call=blocks_calls())
def test_decode_blocks_and_its_twin_agree(c_kernels, build, call):
    frame, table, factor, out, spans = call
    args = (frame, table, factor, out, spans)
    both = _same(c_kernels[build][0], blocks._decode_blocks_py, args, (3,))
    if both is None:
        return
    (got,), (want,) = both
    # The C sums a block's f² samples in float32, the twin in float64: the table's values
    # are positive, so float32's summation errs by at most f²·2⁻²⁴ of the block's mean.
    f = max(factor, 1)
    np.testing.assert_allclose(got, want, rtol=2 * f * f * EPS32, atol=1e-30)


FOLD_FAULTS = ["square off the frame", "right half left of the left", "float frame with a "
               "table", "uint8 frame without a table", "pixels reversed", "short table",
               "extent past the square", "short extents", "parity 4", "sums short",
               "mid too small", "factor 0 with mid", "radial of 19 columns", "no radial bins",
               "step 0", "fixes out of order", "fix past the square", "fixes of 8 weights",
               "another lens off the frame", "another lens's centre offset", "clip of 3",
               "clip of a float frame"]


@st.composite
def fold_calls(draw, faults=tuple(FOLD_FAULTS)):
    """fold_lens's arguments: half of them right, half with one fault (of ``faults``)."""
    fault = draw(st.sampled_from(faults)) if faults and draw(st.booleans()) else None
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    nx, ny = draw(st.integers(1, 6)), draw(st.integers(1, 6))
    W, H = 2 * nx + draw(st.integers(0, 7)), 2 * ny + draw(st.integers(0, 7))
    xl, yt = draw(st.integers(nx, W - nx)), draw(st.integers(ny, H - ny))
    # a centre on a pixel corner (xr = xl) or on a pixel centre (xr = xl + 1)
    xr = min(xl + draw(st.integers(0, 1)), W - nx)
    yb = min(yt + draw(st.integers(0, 1)), H - ny)
    if fault == "square off the frame":
        nx = W - xr + 1
    elif fault == "right half left of the left":
        xr = xl - 1
    # More lenses with the same weights (a dual fisheye's other lens): their (xl, xr).
    others, hi = [], W - nx - max(xr - xl, 0)
    for _ in range(draw(st.integers(0, 2)) if hi >= nx else 0):
        ol = draw(st.integers(nx, hi))
        others.append((ol, ol + xr - xl))
    if fault == "another lens off the frame":
        others.append((W - nx + 1, W - nx + 1 + xr - xl))
    elif fault == "another lens's centre offset":
        others.append((nx, nx + 1 - (xr - xl)))
    others = np.array(others, np.int32).reshape(-1, 2)
    linear = draw(st.booleans())
    row_step = draw(st.sampled_from([1, -1, 2]))
    col_step = -1 if fault == "pixels reversed" else 1
    shape = (H * abs(row_step), W * abs(col_step), 3)
    floats = linear != (fault in ("float frame with a table", "uint8 frame without a table"))
    base = (rng.standard_normal(shape).astype(np.float32) * 3 if floats
            else rng.integers(0, 256, shape, dtype=np.uint8))
    if not floats:                     # clipped samples to count: none, a few, most
        base[rng.random(shape) < draw(st.sampled_from([0.0, 0.05, 0.6]))] = 255
    frame = _strided(base, row_step, col_step, False)
    entries = 100 if fault == "short table" else draw(st.sampled_from([256, 768]))
    table = None if linear else (rng.random(entries) * 4).astype(np.float32)
    extents = rng.integers(0, nx + 1, ny).astype(np.int32)
    if fault == "extent past the square":
        extents[-1] = nx + 1
    elif fault == "short extents":
        extents = extents[:-1]
    # The SH9 weights' radial table: bins of a drawn width, some pixels past the last bin.
    bins = 0 if fault == "no radial bins" else draw(st.integers(1, 40))
    radial = rng.standard_normal((bins, 19 if fault == "radial of 19 columns" else 20)
                                 ).astype(np.float32)
    inv_step = 0.0 if fault == "step 0" else draw(st.sampled_from([0.5, 1.0, 4.0, 3.3]))
    fix_at = np.flatnonzero(rng.random(ny * nx) < draw(st.sampled_from([0.0, 0.2, 1.0])))
    if fault == "fixes out of order" and fix_at.size > 1:
        fix_at = fix_at[::-1]
    elif fault == "fix past the square":
        fix_at = np.append(fix_at, ny * nx)
    fix_at = fix_at.astype(np.int32)
    fixes = rng.standard_normal((fix_at.size, 8 if fault == "fixes of 8 weights" else 9)
                                ).astype(np.float32)
    K = draw(st.integers(0, 4))
    tables = rng.standard_normal((K, ny * nx)).astype(np.float32)
    parities = rng.integers(0, 4, K).astype(np.int32)
    if fault == "parity 4" and K:
        parities[0] = 4
    sums = rng.standard_normal((1 + len(others), 9 + K - (fault == "sums short"), 3))
    factor, mid = draw(st.integers(1, 4)), None
    if draw(st.booleans()) or fault in ("mid too small", "factor 0 with mid"):
        right = max([xr] + [o[1] for o in others])
        if nx > (W // factor) * factor - right or ny > (H // factor) * factor - yb:
            factor = 1                     # blocks that hold the squares
        if fault == "factor 0 with mid":
            factor = 0
        f = max(factor, 1)
        mid = rng.standard_normal((H // f - (fault == "mid too small"), W // f, 3)
                                  ).astype(np.float32)
    clip = None          # the clip tally (8-bit frames), added to what it holds
    faulty = fault in ("clip of 3", "clip of a float frame")
    if (not linear and draw(st.integers(0, 3))) or faulty:
        clip = np.array([7.0, *rng.random(3)])[:3 if fault == "clip of 3" else 4]
        if fault == "clip of a float frame" and not linear:
            frame, table = base.astype(np.float32)[::row_step], None
    call = (frame, table, (xl, xr, yt, yb, nx, ny), others, extents, radial, inv_step, fix_at,
            fixes, tables, parities, sums, mid, factor, draw(st.booleans()))
    return call if clip is None and draw(st.booleans()) else call + (clip,)


@pytest.mark.parametrize("build", ["vector", "scalar"])
@SETTINGS
@given(call=fold_calls())
def test_fold_lens_and_its_twin_agree(c_kernels, build, call):
    both = _same(c_kernels[build][1], fold_twin.fold_lens, call,
                 (11, 12) + ((15,) if len(call) > 15 else ()))
    if both is None:
        return
    (sums, mid, *clip), (want_sums, want_mid, *want_clip) = both
    (frame, table, geometry, others, extents, radial, inv_step, fix_at, fixes, tables,
     parities, start, start_mid, factor, clear, *start_clip) = call
    nx = geometry[4]
    values = np.abs(np.asarray(frame, np.float64) if table is None else table).max(initial=0)
    # The weights' magnitudes: the radial ones as the C makes them in float32 (a value, a
    # fraction of a slope, a monomial, a correction: each within 4·2⁻²⁴ of its terms' sum).
    made = np.abs(fold_twin.radial_weights(np.abs(radial), inv_step, geometry))
    made[:, fix_at] += np.abs(fixes.T)
    # (counted five times: the making's rounding beside the sums')
    weights = np.concatenate([made * 5, np.abs(tables).astype(np.float64)])
    # The C folds four samples and sums a row pair's products in four float32 lanes, the
    # twin in float64: they differ by at most (nx + 8)·2⁻²⁴ of the sum of the products'
    # magnitudes, each at most |weight|·4·max|sample|.
    bound = (nx + 8) * EPS32 * weights.sum(axis=1) * 4 * values
    assert np.all(np.abs(sums - want_sums) <= 2 * bound[:, None] + 1e-12 * np.abs(start))
    if mid is not None and len(others):
        # A block the lenses share gets each one's sums: at most their count times one's.
        values = values * (1 + len(others))
    if mid is not None:
        # A block's at most f² samples (and the value it held) summed in float32.
        f = factor
        held = 0.0 if clear else np.abs(start_mid).max(initial=0)
        tol = (f * f + 2) * EPS32 * (held + f * f * values) * 2
        np.testing.assert_allclose(mid, want_mid, rtol=0, atol=tol + 1e-30)
    if clip and clip[0] is not None:
        (clip,), (want_clip,) = clip, want_clip
        # the samples at 255 in the squares: a count, the same
        assert clip[0] == want_clip[0]
        # each clipped pixel's L00 weight as the C makes it in float32 (within 5·2⁻²⁴ of its
        # terms' magnitudes: made[0]), summed in float64 by both: at most every read pixel
        # of every quarter and lens clipped
        bound = 5 * EPS32 * made[0].sum() * 4 * (1 + len(others))
        assert np.all(np.abs(clip[1:] - want_clip[1:])
                      <= bound + 1e-12 * np.abs(start_clip[0][1:]))


EXTRA_FAULTS = ["residual a list", "residual starts short", "residual starts decreasing",
                "residual col past the frame", "residual sums of 2 channels",
                "first a list", "first without clear", "first without mid", "first omega short",
                "first factor 0", "first coarse too tall", "first luma of 4", "first Ymax short"]


@st.composite
def fold_extra_calls(draw):
    """fold_lens's arguments with its unpaired pixels (``residual``) and the lights' first
    pass (``first``): a right base call, then half of them right, half with one fault."""
    call = list(draw(fold_calls(faults=())))
    call += [None] * (16 - len(call))
    fault = draw(st.sampled_from(EXTRA_FAULTS)) if draw(st.booleans()) else None
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    frame, mid = call[0], call[12]
    H, W = frame.shape[:2]
    residual = None
    if draw(st.booleans()) or fault and fault.startswith("residual"):
        R, C = draw(st.integers(0, 12)), draw(st.integers(1, 11))
        rows = np.sort(rng.integers(0, H, R))
        starts = np.searchsorted(rows, np.arange(H + 1)).astype(np.int32)
        cols = rng.integers(0, W, R).astype(np.int32)
        if fault == "residual starts short":
            starts = starts[:-1]
        elif fault == "residual starts decreasing" and H > 1:
            starts[1] = R + 1
        elif fault == "residual col past the frame" and R:
            cols[-1] = W
        residual = (starts, cols, rng.standard_normal((R, C)).astype(np.float32),
                    rng.standard_normal((C, 2 if fault == "residual sums of 2 channels" else 3)))
        if fault == "residual a list":
            residual = list(residual)
    first = None
    if fault and fault.startswith("first") or (not fault and draw(st.booleans())):
        if fault == "first without mid":
            mid = call[12] = None
        elif mid is None:
            mid = call[12] = np.zeros((H, W, 3), np.float32)
            call[13] = 1
        call[14] = fault != "first without clear"
        h, w = (H, W) if mid is None else mid.shape[:2]
        cf = 0 if fault == "first factor 0" else draw(st.integers(1, 3))
        coarse = None
        if draw(st.booleans()) or fault == "first coarse too tall":
            c = max(cf, 1)
            coarse = np.empty((h // c + (fault == "first coarse too tall"), w // c, 3),
                              np.float32)
        first = (rng.random(4 if fault == "first luma of 4" else 3).astype(np.float32),
                 rng.random((h - (fault == "first omega short"), w)).astype(np.float32),
                 np.empty((h, w), np.float32), coarse, cf,
                 draw(st.sampled_from([1.0, 0.25, 1 / 9])),
                 np.empty(h - (fault == "first Ymax short"), np.float32))
        if fault == "first a list":
            first = list(first)
    return tuple(call) + (residual, first)


def _run_extra(kernel, call):
    """(the error, None) or (None, (sums, mid, clip, residual sums, Y, coarse, total,
    Ymax)) of fold_lens on copies of what it writes."""
    call = list(call)
    for i in (11, 12, 15):
        call[i] = None if call[i] is None else call[i].copy()
    res, first = call[16], call[17]
    if isinstance(res, tuple):
        res = call[16] = res[:3] + (res[3].copy(),)
    if isinstance(first, tuple):
        first = call[17] = first[:2] + tuple(None if a is None else a.copy()
                                             for a in first[2:4]) + first[4:6] + (
                                                 first[6].copy(),)
    try:
        total = kernel(*call)
    except Exception as exc:          # noqa: BLE001: the error itself is compared
        return exc, None
    return None, (call[11], call[12], call[15], None if res is None else res[3],
                  None if first is None else first[2], None if first is None else first[3],
                  total, None if first is None else first[6])


@pytest.mark.parametrize("build", ["vector", "scalar"])
@SETTINGS
@given(call=fold_extra_calls())
def test_fold_lens_residual_and_first_pass_agree_with_the_twin(c_kernels, build, call):
    """The unpaired pixels read at their rows and the first pass run band by band as the
    fold completes them (C) give what the twin gives reading them, and running the first
    pass, at the end; and each one's Y, coarse copy and Σ Y ω are its own copy's."""
    (c_err, c_out), (t_err, t_out) = (_run_extra(k, call) for k in (
        c_kernels[build][1], fold_twin.fold_lens))
    if c_err is not None or t_err is not None:
        assert (type(c_err), str(c_err)) == (type(t_err), str(t_err)), (c_err, t_err)
        return
    frame, table, residual, first = call[0], call[1], call[16], call[17]
    values = np.abs(np.asarray(frame, np.float64) if table is None else table).max(initial=0)
    if residual is not None:
        # float32 weights times samples, summed in double by both (BLAS's order or the rows')
        w = np.abs(residual[2]).astype(np.float64).sum(axis=0)
        assert np.all(np.abs(c_out[3] - t_out[3])
                      <= 1e-12 * ((w * values)[:, None] + np.abs(residual[3])) + 1e-300)
    assert (c_out[6] is None) == (first is None) == (t_out[6] is None)
    if first is None:
        return
    mid_c, mid_t = c_out[1], t_out[1]
    # a block's at most f² + R samples summed in float32 by the C (float64 by the twin)
    f, R = call[13], 0 if residual is None else len(residual[1])
    n = f * f * (1 + len(call[3])) + R
    held = 0.0 if call[14] else np.abs(call[12]).max(initial=0)
    np.testing.assert_allclose(mid_c, mid_t, rtol=0,
                               atol=(n + 2) * EPS32 * (held + n * values) * first[5] * 2 + 1e-30)
    luma, omega, cf = first[0].astype(np.float64), first[1].astype(np.float64), first[4]
    for mid, Y, coarse, total, Ymax in ((mid_c, *c_out[4:]), (mid_t, *t_out[4:])):
        m = mid.astype(np.float64)
        np.testing.assert_array_equal(Ymax, np.max(Y, axis=1, initial=-np.inf))
        assert np.all(np.abs(Y - m @ luma) <= 5 * EPS32 * (np.abs(m) @ luma) + 1e-30)
        assert total == pytest.approx(float((Y.astype(np.float64) * omega).sum()),
                                      rel=1e-6, abs=1e-6 * float(np.abs(Y).sum()) + 1e-30)
        if coarse is not None:
            hc, wc = coarse.shape[:2]
            blocks = m[:hc * cf, :wc * cf].reshape(hc, cf, wc, cf, 3)
            tol = (cf * cf + 2) * EPS32 * np.abs(blocks).max(initial=0) + 1e-30
            np.testing.assert_allclose(coarse, blocks.mean(axis=(1, 3)), rtol=0, atol=tol)


COUNT_FAULTS = ["float frame", "pixels not contiguous", "rects of 3", "rects of int64",
                "a rect past the frame", "a rect upside down"]


@st.composite
def count_calls(draw):
    """count_top's arguments (frame, rects): half of them right, half with one fault; rows
    long enough for the 16-byte compares, samples at 255 from none to most."""
    fault = draw(st.sampled_from(COUNT_FAULTS)) if draw(st.booleans()) else None
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    H, W = draw(st.integers(0, 12)), draw(st.integers(0, 40))
    row_step = draw(st.sampled_from([1, -1, 2]))
    col_step = -1 if fault == "pixels not contiguous" else 1
    shape = (H * abs(row_step), W, 3)
    base = rng.integers(0, 256, shape, dtype=np.uint8)
    base[rng.random(shape) < draw(st.sampled_from([0.0, 0.02, 0.7]))] = 255
    if fault == "float frame":
        base = base.astype(np.float32)
    frame = _strided(base, row_step, col_step, False)
    R = draw(st.integers(0, 5))
    r = np.sort(rng.integers(0, H + 1, (R, 2)), axis=1)
    c = np.sort(rng.integers(0, W + 1, (R, 2)), axis=1)
    rects = np.concatenate([r, c], axis=1)
    if fault == "a rect past the frame":
        rects = np.vstack([rects, [0, H, 0, W + 1]])
    elif fault == "a rect upside down":
        rects = np.vstack([rects, [1, 0, 0, W]])
    rects = rects[:, :3] if fault == "rects of 3" else rects
    return frame, rects.astype(np.int64 if fault == "rects of int64" else np.int32)


@pytest.mark.parametrize("build", ["vector", "scalar"])
@SETTINGS
@given(call=count_calls())
def test_count_top_and_its_twin_agree(c_kernels, build, call):
    if _same(c_kernels[build][3], fold_twin.count_top, call, ()) is None:
        return                                  # both refused it, with the same error
    frame, rects = call
    want = sum(int((np.asarray(frame)[r0:r1, a:b] == 255).sum()) for r0, r1, a, b in rects)
    assert c_kernels[build][3](frame, rects) == fold_twin.count_top(frame, rects) == want


EQUIRECT_FAULTS = ["odd width", "float frame", "4 channels", "pixels not contiguous",
                   "short table", "float64 table", "5 row functions", "rows a row long",
                   "acc a column wrong", "acc rows strided", "counts a row short"]


@st.composite
def equirect_calls(draw):
    """equirect_rows's arguments (frame, table, rows, acc, counts): half of them right,
    half with one fault; odd heights (a middle row) and empty frames among them."""
    fault = draw(st.sampled_from(EQUIRECT_FAULTS)) if draw(st.booleans()) else None
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    H, W = draw(st.integers(0, 13)), 2 * draw(st.integers(0, 11)) + (fault == "odd width")
    C = 4 if fault == "4 channels" else 3
    row_step = draw(st.sampled_from([1, -1, 2, -2]))
    col_step = draw(st.sampled_from([-1, 2])) if fault == "pixels not contiguous" else 1
    shape = (H * abs(row_step), W * abs(col_step), C)
    base = rng.integers(0, 256, shape, dtype=np.uint8)
    base[rng.random(shape) < 0.1] = 255                        # clipped samples to count
    if fault == "float frame":
        base = base.astype(np.float32)
    frame = _strided(base, row_step, col_step, False)
    entries = 100 if fault == "short table" else draw(st.sampled_from([256, 768]))
    table = (rng.standard_normal(entries) * 2).astype(
        np.float64 if fault == "float64 table" else np.float32)
    K = 5 if fault == "5 row functions" else draw(st.sampled_from([6, 7]))
    rows = rng.standard_normal((K, H + (fault == "rows a row long"))).astype(np.float32)
    n = 3 * W + ((-1 if W else 1) if fault == "acc a column wrong" else 0)
    acc = rng.standard_normal((K, n)).astype(np.float32)
    if fault == "acc rows strided":                              # a window of a wider one
        acc = np.zeros((K, n + 1), np.float32)[:, :n]
    counts = None
    if draw(st.booleans()) or fault == "counts a row short":
        counts = np.full((max(H - (fault == "counts a row short"), 0), 3), -1, np.int32)
    return frame, table, rows, acc, counts


@pytest.mark.parametrize("build", ["vector", "scalar"])
@SETTINGS
@given(call=equirect_calls())
def test_equirect_rows_and_its_twin_agree(c_kernels, build, call):
    both = _same(c_kernels[build][2], equirect_pass._equirect_rows_py, call, (3, 4))
    if both is None:
        return
    (acc, counts), (want_acc, want_counts) = both
    frame, table, rows, start, _ = call
    if counts is not None:
        np.testing.assert_array_equal(counts, want_counts)
    # The second half of each row of acc is not touched.
    half = acc.shape[1] // 2
    np.testing.assert_array_equal(acc[:, half:], start[:, half:])
    # The C folds four samples (two adds), multiplies once and adds a column's row pairs in
    # float32, the twin in float64: they differ by at most (pairs + 4)·2⁻²⁴ of the sum of
    # the products' magnitudes and the value acc held (H + 8 covers it).
    H = rows.shape[1]
    lin = np.abs(table.astype(np.float64)[np.asarray(frame, np.intp)]) if table.size == 256 \
        else np.abs(table.astype(np.float64).reshape(256, 3)[np.asarray(frame, np.intp),
                                                            np.arange(3)])
    lin = lin.reshape(H, 2 * half)
    folded = lin[:, :half] + lin[:, half:]
    weights = np.abs(rows.astype(np.float64))
    pairs = H // 2
    weights[:6, H - pairs:] = weights[:6, :pairs][:, ::-1]   # the mirrored rows' weights
    weights[0] = weights[3] + weights[5]          # row 0 is not read: rows 3 and 5 added
    bound = (H + 8) * EPS32 * (weights @ folded + np.abs(start[:, :half]))
    assert np.all(np.abs(acc[:, :half] - want_acc[:, :half]) <= bound + 1e-30)
