"""Issue 34: with an absolute camera scale, ``illuminance_lux`` is the up-facing cosine
weights summed as a 10th weight in the projection's own pass (no second decode). It must be
the number :meth:`SH9Projector.up_illuminance` gets from the pixels, for every projection
that has weights: equirect (a row of the separable pass), turned equirect (per pixel),
fisheye and dual fisheye folded about their centres (the weight's four parity parts), a
fisheye whose centre is off the grid (the dense table's 10th column); 8-bit and float."""
from __future__ import annotations

import numpy as np
import pytest

from provider.core.radiometry.response import CameraResponse
from provider.core.radiometry.photometry import luminance
from provider.core.sh9.engine import SH9Projector
from provider.core.sh9.meter import up_weights

C_CD_M2, F_NUMBER = 40.0, 2.0


def absolute_response() -> CameraResponse:
    response = CameraResponse.srgb(8)
    response.params["absolute"] = {"cd_m2": C_CD_M2, "f_number": F_NUMBER, "iso": 100.0,
                                   "lux": 1.0}
    return response


def frame_u8(w: int, h: int, seed: int = 0) -> np.ndarray:
    """Smooth walls and noise, a bright patch off every symmetry axis."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w]
    img = (90 + 60 * np.sin(x / (w / 9.0))[..., None] + 40 * np.cos(y / (h / 5.0))[..., None]
           + rng.integers(0, 30, (h, w, 3)))
    img[h // 5:h // 5 + 4, w // 3:w // 3 + 5] = 255
    return np.clip(img, 0, 255).astype(np.uint8)


CASES = {
    "equirect": dict(width=128, height=64, projection="equirect"),
    "equirect-turned": dict(width=128, height=64, projection="equirect",
                            rotation=[[1, 0, 0], [0, 0, -1], [0, 1, 0]]),
    "fisheye-folded": dict(width=96, height=96, projection="fisheye"),
    "fisheye-turned-folded": dict(width=96, height=96, projection="fisheye",
                                  rotation=[[0.8, 0.6, 0], [-0.48, 0.64, 0.6],
                                            [0.36, -0.48, 0.8]]),
    "dual-fisheye-folded": dict(width=1280, height=720, projection="dual-fisheye"),
    "mirrorball-folded": dict(width=120, height=120, projection="mirrorball"),
    "fisheye-dense": dict(width=96, height=96, projection="fisheye", center=(47.3, 48.1)),
}


@pytest.mark.parametrize("name", list(CASES))
@pytest.mark.parametrize("dtype", ["uint8", "float32"])
def test_illuminance_in_the_pass_is_the_pixels_sum(name, dtype):
    opts = dict(CASES[name])
    w, h = opts.pop("width"), opts.pop("height")
    projector = SH9Projector(w, h, opts.pop("projection"), response=absolute_response(),
                             **opts)
    assert projector._up_in_pass
    if name.endswith("folded"):
        assert projector._fold is not None and projector._fold.extras == 1
        if name == "fisheye-turned-folded":     # a tilted up: all four parity parts
            groups = projector._fold.lenses[0].groups
            assert sum(9 in k for _, k, _ in groups) == 4
    if name == "fisheye-dense":
        assert projector._fold is None and projector._weights.shape[1] == 10
    frame = frame_u8(w, h)
    if dtype == "float32":
        frame = (frame.astype(np.float32) / 255.0) ** 2.2
    t, gain = 1 / 60, 2.0
    result = projector.project(frame, exposure_s=t, gain=gain)
    assert result.stats["coefficient_units"] == "cd/m²"
    k = C_CD_M2 * F_NUMBER ** 2 / (t * gain)
    # the reference in float64: the meter's weights times the decoded pixels
    cosine = up_weights(projector.projection, projector.rotation)[0]
    lin = (projector._lut(np.uint8).astype(np.float64)[frame] if dtype == "uint8"
           else frame.astype(np.float64))
    expected = float(luminance(np.tensordot(cosine, lin, axes=([0, 1], [0, 1])))) * k
    assert expected > 0
    # float32 sums over ~10⁵ pixels round at ~1e-5; a wrong parity part is off by O(1)
    assert result.stats["illuminance_lux"] == pytest.approx(expected, rel=1e-4)
    assert projector.up_illuminance(frame, k) == pytest.approx(expected, rel=1e-4)


def test_no_up_column_without_an_absolute_scale():
    """A camera without an absolute scale pays nothing: no 10th weight, no lux."""
    plain = SH9Projector(96, 96, "fisheye")
    assert not plain._up_in_pass and plain._fold is not None and plain._fold.extras == 0
    result = plain.project(frame_u8(96, 96), exposure_s=0.01)
    assert "illuminance_lux" not in result.stats


# -- the decode reads only the columns each band sees (provider.core.sh9.support) ----------------

@pytest.mark.parametrize("size,bits", [((1280, 720), 8), ((640, 480), 8), ((640, 480), 16)])
def test_decoding_only_the_seen_columns_changes_no_coefficient(size, bits):
    """SH9 and the clipped tallies with the support's spans are those of the whole frame
    decoded (frame after frame: the reused band buffer holds nothing stale), and the
    spans leave out the surround (Theta S: 28 %, the Pi camera's fisheye: 37 %)."""
    w, h = size
    name = "dual-fisheye" if w == 1280 else "fisheye"
    spans = SH9Projector(w, h, name)
    assert spans._spans is not None and spans._spans.fraction < 0.75
    whole = SH9Projector(w, h, name)
    whole._spans = None
    for seed in range(3):
        frame = frame_u8(w, h, seed)
        frame[5 * h // 6:, :] = 255              # a clipped surround outside the circles
        if bits == 16:
            frame = frame.astype(np.uint16) * 257
        a, b = spans.project(frame), whole.project(frame)
        scale = np.abs(b.coefficients).max()
        assert np.abs(a.coefficients - b.coefficients).max() <= 1e-6 * scale
        assert a.stats["clipped_fraction"] == b.stats["clipped_fraction"]
        assert a.stats["clipped_light_fraction"] == b.stats["clipped_light_fraction"]


@pytest.mark.parametrize("size,factor,bits", [((640, 480), 2, 8), ((640, 480), 4, 16),
                                              ((1280, 720), 4, 8)])
def test_the_fast_path_decodes_only_the_blocks_it_weighs(size, factor, bits, monkeypatch):
    """``--downsample F`` without lights decodes only the blocks the small projection weighs
    (the Pi camera's fisheye leaves out about a third): the coefficients and clipped tallies
    are those of shrinking the whole decoded frame, frame after frame; with lights (which
    read the whole linear frame) the whole frame is decoded as before. The error estimate's
    coarser copy sees the unweighed blocks as black (a real lens's surround), so it moves a
    little. 8-bit frames where the C kernels are built: decode_blocks reads the same blocks
    (its spans), against the numpy/OpenCV whole-frame path to float rounding."""
    from provider.core.radiometry import blocks
    w, h = size
    name = "dual-fisheye" if w == 1280 else "fisheye"
    spans = SH9Projector(w, h, name, downsample=factor, error_estimate=True)
    assert spans._spans is not None and spans._spans.spans.fraction < 0.8
    whole = SH9Projector(w, h, name, downsample=factor, error_estimate=True)
    whole._spans = None
    assert SH9Projector(w, h, name, downsample=factor, lights="auto")._spans is None
    for seed in range(3):
        frame = frame_u8(w, h, seed)
        frame[5 * h // 6:, :] = 255              # a clipped surround outside the circles
        if bits == 16:
            frame = frame.astype(np.uint16) * 257
        a = spans.project(frame)
        monkeypatch.setattr(blocks, "KERNEL", False)      # the reference: no C kernel
        b = whole.project(frame)
        monkeypatch.setattr(blocks, "KERNEL", True)
        if bits == 8 and blocks.KERNEL:
            assert spans._block_spans is not None
            np.testing.assert_allclose(a.coefficients, b.coefficients,
                                       atol=2e-6 * np.abs(b.coefficients).max())
        else:
            np.testing.assert_array_equal(a.coefficients, b.coefficients)
        assert a.stats["clipped_fraction"] == b.stats["clipped_fraction"]
        assert a.stats["clipped_light_fraction"] == pytest.approx(   # over the sums above
            b.stats["clipped_light_fraction"], rel=1e-6)
        # the estimate's coarser copy averages the unweighed blocks (now zero) at the rim
        # (decode_blocks' spans are per block row, tighter than the bands': more of them)
        assert a.stats["error_estimate"] == pytest.approx(b.stats["error_estimate"], rel=0.1)
