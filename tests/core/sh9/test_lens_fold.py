"""The folded fisheye and probe-disc projection (provider.core.sh9.lens_fold) gives the
coefficients of the dense per-pixel table, to float32 rounding, for every frame type and
path; lenses whose pixel grid is not symmetric keep the dense table."""
import numpy as np
import pytest

from provider.core.sh9.engine import SH9Projector


def _dense_twin(projector: SH9Projector) -> SH9Projector:
    """The same projector forced onto the dense (H·W, 9) table: the reference."""
    twin = SH9Projector(projector.width, projector.height, projector.projection)
    twin._fold = None
    twin._weights = projector.projection.sh_weights.astype(np.float32)
    return twin


CASES = {
    "Theta S dual fisheye": (1280, 720, "dual-fisheye", {}),
    "Pi fisheye 640×480": (640, 480, "fisheye", {}),
    "odd size, pixel-centred lens": (641, 481, "fisheye", {}),
    "mirror fill": (320, 240, "fisheye", {"fill": "mirror", "albedo": 0.3}),
    "narrow lens, far from the frame edge": (400, 300, "fisheye", {"fov_deg": 120,
                                                                    "radius": 100}),
    "mirror ball": (400, 400, "mirrorball", {}),
    "angular map": (401, 401, "angular", {}),
    "mirror ball in a window of the frame": (640, 480, "mirrorball",
                                             {"center": (300, 200), "radius": 150}),
}


@pytest.mark.parametrize("case", CASES, ids=list(CASES))
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
def test_folded_projection_equals_the_dense_table(case, dtype, kernels):
    if kernels == "python" and dtype != np.uint8:
        pytest.skip("the fold kernel reads 8-bit frames only (and the fast path's blocks)")
    w, h, name, options = CASES[case]
    folded = SH9Projector(w, h, name, **options)
    assert folded._fold is not None, "a lens centred on the pixel grid is folded"
    assert folded._fold.table_floats < 0.3 * w * h * 9    # a quarter of the table, or less
    rng = np.random.default_rng(3)
    top = {np.uint8: 255, np.uint16: 65535}.get(dtype, 1)
    frame = rng.integers(0, top + 1, (h, w, 3)).astype(dtype)
    if dtype == np.float32:
        frame = rng.random((h, w, 3), dtype=np.float32) * 4
    frame[h // 3, w // 4] = top * (1 if dtype != np.float32 else 50)   # a clipped lamp
    got = folded.project(frame)
    want = _dense_twin(folded).project(frame)
    scale = np.abs(want.coefficients).max()
    assert np.abs(got.coefficients - want.coefficients).max() <= 1e-5 * scale  # float32 sums
    assert got.stats["clipped_fraction"] == want.stats["clipped_fraction"]
    # a ratio of two float32 sums, each within ~1e-5 of the other path's (the bound on the
    # coefficients above): BLAS's kernel, chosen by CPU, moves it by 4e-6 (AVX-512 against AVX2)
    assert got.stats["clipped_light_fraction"] == pytest.approx(
        want.stats["clipped_light_fraction"], rel=2e-5, abs=1e-12)


def test_fast_path_is_folded_too(kernels):
    fast = SH9Projector(640, 480, "fisheye", downsample=2)
    assert fast._fold is not None
    frame = np.random.default_rng(4).integers(0, 256, (480, 640, 3), dtype=np.uint8)
    ref = SH9Projector(640, 480, "fisheye", downsample=2)
    ref._fold, ref._weights = None, ref.projection.sh_weights.astype(np.float32)
    a, b = fast.project(frame).coefficients, ref.project(frame).coefficients
    assert np.abs(a - b).max() <= 1e-5 * np.abs(b).max()


def test_lights_see_the_same_frame_through_the_fold(kernels):
    frame = np.full((720, 1280, 3), 30, np.uint8)
    frame[150:170, 250:270] = 255                     # a lamp in the front lens
    folded = SH9Projector(1280, 720, "dual-fisheye", lights="auto")
    dense = SH9Projector(1280, 720, "dual-fisheye", lights="auto")
    dense._fold, dense._weights = None, dense.projection.sh_weights.astype(np.float32)
    # Black around the lenses' circles, as a Theta's frame: the fold's copy counts the
    # pixels without a weight as black, the dense path reads them (a grey surround changes
    # the truth's edge blocks; with a 60 background the lamp's gain sat at min_gain itself).
    # The solid angles are the dense twin's, made with its weights above (not made again).
    frame[dense.projection.solid_angle.reshape(720, 1280) <= 0] = 0
    a, b = folded.project(frame), dense.project(frame)
    assert len(a.lights) == len(b.lights)
    scale = np.abs(b.ambient).max()
    assert np.abs(a.ambient - b.ambient).max() <= 1e-5 * scale
    for la, lb in zip(a.lights, b.lights):
        assert np.allclose(la.direction, lb.direction, atol=1e-5)


def test_off_grid_centre_keeps_the_dense_table():
    """A centre between pixel centres and corners has no mirror pixels: not folded, and the
    dense table gives the result."""
    p = SH9Projector(640, 480, "fisheye", center=(320.3, 240.0))
    assert p._fold is None and p._weights.shape == (640 * 480, 9)
    frame = np.full((480, 640, 3), 128, np.uint8)
    assert np.all(np.isfinite(p.project(frame).coefficients))


def test_frames_in_a_row_reuse_the_fold_buffers_without_stale_rows():
    """The per-lens fold buffers are kept from frame to frame: every frame's coefficients
    (and up-facing sums) are those of a projector that never saw the frames before it,
    whatever their type, and two frames in flight at once each get their own buffers."""
    w, h = 1280, 720
    rng = np.random.default_rng(7)
    frames = [rng.integers(0, 256, (h, w, 3), dtype=np.uint8),
              rng.random((h, w, 3), dtype=np.float32) * 3,
              np.full((h, w, 3), 40, np.uint8),
              rng.integers(0, 65536, (h, w, 3), dtype=np.uint16)]
    used = SH9Projector(w, h, "dual-fisheye")
    fresh = SH9Projector(w, h, "dual-fisheye")
    assert used._fold is not None
    for frame in frames:
        fresh._fold._pool.clear()                  # a new set of buffers for each frame
        got, want = used.project(frame).coefficients, fresh.project(frame).coefficients
        assert np.array_equal(got, want)
    # Two accumulators at once (two frames in flight): separate buffers, separate sums.
    fold = used._fold
    states = [fold.new(used.BAND_ROWS), fold.new(used.BAND_ROWS)]
    lins = [np.asarray(used._linearise(f), np.float32) for f in (frames[0], frames[2])]
    for r0 in range(0, h, used.BAND_ROWS):
        for lin, state in zip(lins, states):
            fold.add(lin[r0:r0 + used.BAND_ROWS], r0, state)
    for lin, state in zip(lins, states):
        alone = fold.new(used.BAND_ROWS)
        fold.add(lin, 0, alone)                    # the whole frame as one band
        np.testing.assert_allclose(fold.coefficients(state), fold.coefficients(alone),
                                   rtol=1e-5, atol=1e-7 * np.abs(fold.coefficients(alone)).max())
