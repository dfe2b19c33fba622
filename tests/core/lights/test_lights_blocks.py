"""The lights' per-frame sums taken in cache-sized pieces (issue 44: a Cortex-A53's 512 KB
cache) are the sums they replace: the truth at the normals by blocks of normals against
the whole kernel's product, the coarse rest with the candidates' excess taken off its
blocks against the coarse copy of the rest, and a clean detection copy (a table's block
means) left unclamped only where nothing is there to clamp."""
import numpy as np
import pytest

from provider.core.geometry.projections import DualFisheye, Equirect, Fisheye
from provider.core.lights import first_pass as first_pass_module
from provider.core.lights.analysis import LUMA
from provider.core.lights.extractor import LightExtractor
from provider.core.lights.views import DetectionCopy
from provider.core.radiometry.blocks import shrink
from provider.core.sh9.engine import SH9Projector

PROJECTIONS = {
    "theta": lambda: DualFisheye(1280, 720),
    "equirect": lambda: Equirect(512, 256),
    "fisheye-ground": lambda: Fisheye(640, 480, fill="ground", albedo=0.3),
    "fisheye-mirror": lambda: Fisheye(640, 480, fill="mirror", albedo=0.3),
}


@pytest.mark.parametrize("name", PROJECTIONS)
def test_the_truth_by_blocks_is_the_whole_kernels_product(name):
    x = LightExtractor(PROJECTIONS[name](), max_lights=3)
    t = x.coarse_truth
    dirs = t.coarse.directions().reshape(-1, 3)[t.pixels]
    omega = t.coarse.solid_angle.reshape(-1)[t.pixels]
    whole = x._brute_kernel(dirs, omega)                  # float64, fill terms included
    coarse = np.random.default_rng(1).random((t.coarse.height, t.coarse.width, 3),
                                             dtype=np.float32)
    rest = coarse.reshape(-1, 3)[t.pixels]
    got = t(coarse)
    assert got.shape == (len(x.normals), 3)
    # float32 kernel and sums of ≤ 3,600 non-negative terms: at most n·2⁻²⁴ (2e-4) of each
    # sum apart from the float64 product, about √n·2⁻²⁴ in practice
    np.testing.assert_allclose(got, whole @ rest.astype(np.float64), rtol=2e-4, atol=0)
    if t.split is not None:
        # No fill: the kernel split by caps of normals (a cap's core linear, its horizon
        # band's entries kept). Float32 sums of ≤ 2,556 terms a cap's core (signed: d ω x)
        # and band row, products with the normals in float64; for uniform [0, 1) radiance
        # no sum cancels much, so √n·2⁻²⁴ a term, ~1e-6 of the float64 product (9.4e-7
        # measured): 1e-5 holds on any CPU's rounding.
        np.testing.assert_allclose(got, whole @ rest.astype(np.float64), rtol=1e-5, atol=0)
        assert x._fill is None and t.kernel is None
        return
    assert x._fill is not None
    # the blocks change nothing: the same float32 product of the kernel's rows, unblocked
    # (each normal's sum one BLAS matrix-vector kernel, blocks of a multiple of its 4 rows:
    # 1e-6 leaves room for a BLAS that sums a short last block in another order)
    rows = t.kernel.reshape(-1, t.kernel.shape[2])[:len(x.normals)]
    unblocked = np.stack([rows @ np.ascontiguousarray(rest[:, c]) for c in range(3)], 1)
    np.testing.assert_allclose(got, unblocked, rtol=1e-6)


def test_the_excess_comes_off_the_coarse_blocks():
    x = LightExtractor(DualFisheye(1280, 720), max_lights=3)
    t = x.coarse_truth
    # a Theta S's 256 × 144 mid pixels in 85 × 48 blocks of 3 × 3: the last column is
    # outside every block (the crop), as the excess there must be
    assert t.blocks and t.factor == 3 and t.crop == (255, 144)
    rng = np.random.default_rng(2)
    h, w = x.mid.height, x.mid.width
    small = (rng.random((h, w, 3)) * 10).astype(np.float32)
    union = np.sort(rng.choice(h * w, 4000, replace=False))
    excess = (small.reshape(-1, 3)[union] * rng.random((4000, 1))).astype(np.float32)
    copy = small.copy()
    copy.reshape(-1, 3)[union] -= excess
    bw, bh = t.crop
    expected = shrink(copy[:bh, :bw], (x.coarse.width, x.coarse.height))
    got = t.rest(small, union, excess)
    assert got.shape == expected.shape and got.dtype == np.float32
    # block means of values ≤ 10 in another order: float32 rounding of the block sums
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-5)
    np.testing.assert_array_equal(t.rest(small), shrink(small[:bh, :bw],
                                  (x.coarse.width, x.coarse.height)))


def test_a_clean_copy_is_only_one_with_nothing_to_clamp():
    x = LightExtractor(DualFisheye(1280, 720), max_lights=3)
    sink = DetectionCopy(x)
    srgb = SH9Projector(1280, 720, "dual-fisheye")._lut(np.uint8)
    for table, clean in ((srgb, True), (srgb - np.float32(0.01), False),
                         (np.where(np.arange(256) == 7, np.nan, srgb).astype(np.float32), False),
                         (np.linspace(0, 1, 65536, dtype=np.float32), False), (None, False)):
        sink.start(None, table, {})
        assert sink.clean is clean
    mid = np.random.default_rng(3).random((x.mid.height, x.mid.width, 3), np.float32)
    mid[:4] = -1.0                                      # ringing: clamped unless clean
    assert x.reduce(mid, clean=True) is mid
    assert x.reduce(mid).min() == 0.0 and x.reduce(mid)[4:].tolist() == mid[4:].tolist()


def test_the_lights_of_a_clean_copy_are_those_of_the_clamped_one():
    from provider.bench.edge_frames import lit_theta_frame
    p = SH9Projector(1280, 720, "dual-fisheye", lights="auto")
    frame = lit_theta_frame(1280, 720)
    served = p.project(frame)
    assert served.lights
    x = p._extractor
    mid = x.reduce(p._linearise(frame))
    a = x.analyse(mid, served.coefficients, clean=True)
    b = x.analyse(mid, served.coefficients)
    # a clean copy skips only cv2.max(copy, 0) on a copy with nothing below 0: the same
    # floats go into the same operations, on any CPU
    np.testing.assert_array_equal(a.truth, b.truth)
    assert [c.pixels.tolist() for c in a.candidates] == [c.pixels.tolist() for c in b.candidates]


@pytest.mark.parametrize("kernel", ["built", "twin"])
@pytest.mark.parametrize("name", ["theta", "equirect"])
def test_the_first_pass_is_the_whole_frames(name, kernel, monkeypatch):
    """Luminance, flux and coarse copy of the mid copy in one pass (the C kernel and its
    twin, a band at a time): the float64 luminance, flux and block means of the frame, to
    float32 rounding (each Y three float32 weights, three products and two sums of
    non-negative terms: at most 5·2⁻²⁴ of Y, wherever FMA fuses them or not; a block mean
    f² sums and a scale: (f² + 1)·2⁻²⁴; the flux a float64 sum of float32 products: 1e-6),
    and the frame scaled in place as the mean scale says."""
    if kernel == "twin":
        monkeypatch.setattr(first_pass_module, "_first_pass_kernel",
                            first_pass_module.first_pass_twin)
    elif not first_pass_module.KERNEL:
        pytest.skip("the C kernels were not built (tests/core/kernels/test_kernels.py)")
    x = LightExtractor(PROJECTIONS[name](), max_lights=3)
    sums = (np.random.default_rng(4).random((x.mid.height, x.mid.width, 3)) * 80
            ).astype(np.float32)
    mid = sums.copy()
    Y, total, coarse, top = first_pass_module.first_pass(mid, 1.0 / 16,
                                                         *x.first_pass_args(mid.shape[:2]))
    np.testing.assert_array_equal(top, Y.max(axis=1))
    np.testing.assert_array_equal(mid, sums * np.float32(1.0 / 16))   # exact: a power of 2
    rgb = mid.astype(np.float64)
    whole = rgb @ LUMA
    np.testing.assert_allclose(Y, whole, rtol=5 * 2.0 ** -24, atol=0)
    want = float(whole.reshape(-1) @ x._omega32.reshape(-1).astype(np.float64))
    assert total == pytest.approx(want, rel=1e-6)
    t = x.coarse_truth
    if not t.blocks:                                    # INTER_AREA's fractional weights
        assert coarse is None
        return
    bw, bh = t.crop
    f = t.factor
    means = rgb[:bh, :bw].reshape(bh // f, f, bw // f, f, 3).mean(axis=(1, 3))
    np.testing.assert_allclose(coarse, means, rtol=(f * f + 1) * 2.0 ** -24, atol=0)


