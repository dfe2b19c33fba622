"""The cube update's per-frame work trimmed (issue 34, cube pass 2): an 8-bit frame decoded
and block-averaged in one pass, segment sums grouped by length, the bright pixels found
without partitioning every work pixel. Each is held to what it replaced."""
import cv2
import numpy as np
import pytest

from provider.core.radiometry.response import CameraResponse
from provider.core.reflections import prefilter
from provider.core.reflections.bright import BRIGHT_PIXELS, bright_split, holding_the_largest
from provider.core.reflections.environment import EnvironmentProjector


def per_channel_response():
    z = np.arange(256) / 255.0
    return CameraResponse(np.stack([z ** 2.2, 0.9 * z ** 2.0, 0.8 * z ** 2.4], axis=1))


@pytest.mark.parametrize("projection,w,h,size,dtype,options,blocks", [
    ("dual-fisheye", 1280, 720, 32, np.uint8, {}, 2),      # the Theta S frame's 32² cube
    ("dual-fisheye", 1280, 720, 8, np.uint8, {}, 5),
    ("equirect", 1920, 960, 8, np.uint8, {}, 8),
    ("equirect", 1920, 960, 8, np.uint8, {"response": per_channel_response()}, 8),
    ("equirect", 1900, 950, 8, np.uint8, {}, None),        # 270×135 from 1900×950: no blocks
    ("dual-fisheye", 1280, 720, 8, np.uint16, {}, 5),      # 16-bit: decoded band by band
])
def test_an_integer_frames_cube_is_that_of_its_decoded_frame(projection, w, h, size, dtype,
                                                             options, blocks):
    """8-bit frames whose crop is whole blocks of the work image are decoded and averaged
    in one pass (decode_blocks), others band by band: either way the cube is that of the
    whole frame decoded to float and area-resized, to float rounding (the block sums are
    added in another order than OpenCV's resize: rtol 1e-6, not bit-exact)."""
    top = np.iinfo(dtype).max
    frame = np.random.default_rng(5).integers(0, top + 1, (h, w, 3), dtype=dtype)
    proj = EnvironmentProjector(w, h, projection, size=size, **options)
    assert proj._block_factor == blocks
    if blocks is None:          # nor may SH9's bands fill its work image
        assert proj.new_work() is None
    whole = proj.project_linear(proj.decode(proj._prepare(frame), {}))
    got = proj.project(frame)
    for x, y in zip(got.mips, whole.mips):
        np.testing.assert_allclose(x, y, rtol=1e-6, atol=1e-9)


def reference_product(rows, cols, vals, n_rows, x):
    out = np.zeros((n_rows, x.shape[1]))
    np.add.at(out, rows, vals[:, None] * x[cols].astype(np.float64))
    return out


def test_grouped_segment_sums_are_the_sparse_product():
    """Rows of 1 to 60 entries (repeated columns too), grouped by length and padded: the
    product is the float64 one to float32 rounding, whatever the order of the entries."""
    rng = np.random.default_rng(6)
    n_rows, n_cols = 700, 3000
    counts = np.concatenate([np.ones(50, int), rng.integers(1, 61, n_rows - 50)])
    rows = np.repeat(np.arange(n_rows), counts)
    cols = rng.integers(0, n_cols, rows.size)
    cols[:20] = cols[0]
    vals = rng.random(rows.size)
    shuffle = rng.permutation(rows.size)
    op = prefilter.SparseOperator(rows[shuffle], cols[shuffle], vals[shuffle], (n_rows, n_cols))
    x = rng.random((n_cols, 3)).astype(np.float32)
    got = op.apply(x)
    assert got.shape == (n_rows, 3) and got.dtype == np.float32
    np.testing.assert_allclose(got, reference_product(rows, cols, vals, n_rows, x), rtol=2e-6)
    assert op.nnz == rows.size <= op.stored
    with pytest.raises(ValueError):
        prefilter.SparseOperator(rows[counts[0]:], cols[counts[0]:], vals[counts[0]:],
                                 (n_rows, n_cols))       # row 0 has no entry


def test_length_groups_cover_every_length_once_at_the_least_modelled_cost():
    counts = np.array([3] * 500 + [4] * 2 + [5] * 400 + [40] * 30 + [41] * 30 + [90])
    groups = prefilter.length_groups(counts)
    lengths = np.unique(counts)
    # contiguous ranges of the distinct lengths, in order, covering all of them
    covered = [int(l) for lo, hi in groups for l in lengths[(lengths >= lo) & (lengths <= hi)]]
    assert covered == lengths.tolist()
    assert all(lo <= hi for lo, hi in groups)

    def cost(gs):
        return sum(prefilter.GROUP_COST + prefilter.PAD_COST * np.sum(
            hi - counts[(counts >= lo) & (counts <= hi)]) for lo, hi in gs)
    assert cost(groups) <= cost([(l, l) for l in lengths])          # no group merged
    assert cost(groups) <= cost([(lengths[0], lengths[-1])])        # one group
    assert (4, 4) not in groups                   # two rows of 4 cost less padded than alone


def test_the_overlap_operator_is_its_entries():
    """The real overlap (work pixels → base texels) of the Theta S geometry applied to a
    frame: the float64 sum of its (texel, pixel, weight) entries."""
    proj = EnvironmentProjector(1280, 720, "dual-fisheye", size=8)
    op = proj._overlap_op
    x = np.random.default_rng(7).random((op.shape[1], 3)).astype(np.float32)
    want = reference_product(proj._tex, proj._pix, proj._val.astype(np.float64), op.shape[0], x)
    np.testing.assert_allclose(op.apply(x), want, rtol=2e-6, atol=1e-12)


def full_partition_split(px):
    """What the bright split did before: argpartition over every work pixel."""
    lum = cv2.transform(px.reshape(-1, 1, 3), np.array([[0.2126, 0.7152, 0.0722]],
                                                       np.float32)).reshape(-1)
    k = min(BRIGHT_PIXELS, lum.size - 1)
    top = np.argpartition(lum, lum.size - k - 1)[lum.size - k - 1:]
    cap = lum[top].min()
    bright = np.sort(top[lum[top] > cap])
    if bright.size == 0 or not cap >= 0:
        return None, None
    return bright, (px[bright] * (1 - (cap / lum[bright])[:, None])).astype(np.float64)


@pytest.mark.parametrize("case", ["noise", "ties", "uniform", "lamps", "small"])
def test_the_bright_pixels_are_those_of_a_full_partition(case):
    rng = np.random.default_rng(8)
    n = 100 if case == "small" else 230_400
    px = rng.random((n, 3)).astype(np.float32)
    if case == "ties":
        px = np.round(px * 3) / 3
    elif case == "uniform":
        px[:] = 0.5
    elif case == "lamps":
        px[rng.integers(0, n, 40)] = 1e4
    want = full_partition_split(px)
    got = bright_split(px)
    if want[0] is None:
        assert got == (None, None)
    else:
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])


def test_the_candidates_hold_the_largest_values_or_say_they_cannot():
    rng = np.random.default_rng(9)
    lum = rng.random(100_000).astype(np.float32)
    among = holding_the_largest(lum, 65)
    assert among.size < lum.size // 10
    assert set(np.argsort(lum)[-65:]) <= set(among.tolist())
    assert holding_the_largest(lum[:1000], 65) is None       # too few blocks to help
    lum[5] = np.nan
    assert holding_the_largest(lum, 65) is None              # NaN: the full partition


def test_without_the_c_kernel_8bit_frames_take_the_band_path(monkeypatch):
    """Where the C kernel was not built, an 8-bit frame is decoded band by band as before
    (each band's float copy in cache, not OpenCV's whole-frame fallback): the same cube."""
    from provider.core.radiometry import blocks
    frame = np.random.default_rng(10).integers(0, 256, (720, 1280, 3), dtype=np.uint8)
    proj = EnvironmentProjector(1280, 720, "dual-fisheye", size=8)
    with_kernel = proj.project(frame)
    calls = []
    monkeypatch.setattr(blocks, "KERNEL", False)
    monkeypatch.setattr(blocks, "decode_blocks", lambda *a, **k: calls.append(a))
    without = proj.project(frame)
    assert calls == []
    for x, y in zip(without.mips, with_kernel.mips):
        np.testing.assert_allclose(x, y, rtol=1e-6, atol=1e-9)
