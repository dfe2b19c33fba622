"""The clip counter of a folded lens's 8-bit frame, tallied inside the fold kernel's one pass
over the bytes (provider.core.sh9.clipping, lens_fold, _fold.c): the clipped_fraction of a
compare of the whole frame, sample for sample, and its clipped L00, wherever the samples
clip (inside a lens, outside every lens's square, on an unpaired centre row or column, one
channel of a camera's own curves); over the C kernel and its Python twin."""
import numpy as np
import pytest

from provider.core.radiometry.response import CameraResponse
from provider.core.sh9.clipping import ClippedLight, _outside_squares
from provider.core.sh9.engine import SH9Projector


def _three_curves() -> CameraResponse:
    """A calibrated camera's own curve per channel: each channel's top code its own value."""
    v = np.arange(256) / 255.0
    return CameraResponse(np.stack([v ** 2.0, 1.5 * v ** 2.2, 0.7 * v ** 2.4], axis=1),
                          method="table")


CASES = {
    "Theta S dual fisheye (two lenses, one call; a margin below)": (
        1280, 720, "dual-fisheye", {}),
    "pixel-centred lens (unpaired centre row and column)": (161, 121, "fisheye", {}),
    "lens off the frame's centre (a margin outside its square)": (
        200, 150, "fisheye", {"center": (80, 75), "radius": 60}),
    "mirror ball in a window of the frame": (
        200, 160, "mirrorball", {"center": (90, 70), "radius": 50}),
    "a camera's three curves": (161, 121, "fisheye", {"response": "three curves"}),
}


@pytest.fixture(scope="module")
def projectors():
    made = {}

    def get(case):
        if case not in made:
            w, h, name, options = CASES[case]
            if options.get("response") == "three curves":
                options = {**options, "response": _three_curves()}
            made[case] = SH9Projector(w, h, name, **options)
        return made[case]
    return get


def _frame(w: int, h: int, seed: int, share: float) -> np.ndarray:
    """Codes below the top, ``share`` of the samples at 255 anywhere, a lamp, a sample
    clipped in one channel alone, and the corners (outside every lens) clipped."""
    rng = np.random.default_rng(seed)
    frame = rng.integers(0, 255, (h, w, 3), dtype=np.uint8)
    frame[rng.random((h, w, 3)) < share] = 255
    frame[h // 3:h // 3 + 3, w // 4:w // 4 + 4] = 255
    frame[h // 2 + 3, w // 3, 1] = 255
    frame[0, 0] = 255
    frame[-1, -1, 2] = 255
    return frame


def _whole(p: SH9Projector, frame: np.ndarray) -> tuple[float, float]:
    """(clipped_fraction, clipped L00) of the compare of the whole frame (the reference)."""
    stats = {}
    l00 = p._clipped.whole(frame, p._lut(np.uint8), stats)
    return stats["clipped_fraction"], l00


@pytest.mark.parametrize("share", [0.0, 0.01, 0.3])
@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_the_fold_tallies_what_the_whole_frame_compare_gives(case, share, projectors,
                                                             kernels, monkeypatch):
    p = projectors(case)
    assert p._fold is not None
    frame = p._prepare(_frame(p.width, p.height, 5, share))     # (a ball's window)
    want_fraction, want_l00 = _whole(p, frame)

    def no_whole(*args):
        raise AssertionError("the whole frame compared again")
    monkeypatch.setattr(ClippedLight, "whole", no_whole)
    stats = {}
    got = p._project_frame(frame, stats)
    assert stats["clipped_fraction"] == want_fraction        # a count: exact
    # The reference sums float32 weights in float32 (BLAS); the kernel its weights made
    # from the radial tables (each within 1e-6 of the weight's largest, RADIAL_TOLERANCE)
    # in float64: 6e-6 apart at most on a Theta S frame with 30 % of its samples clipped,
    # the reference's float32 sum's error (both 1e-8 or closer to a float64 sum's).
    assert got.clip.l00 == pytest.approx(want_l00, rel=2e-5, abs=1e-15)


def test_a_sample_outside_every_square_counts_but_carries_no_light(projectors, kernels):
    p = projectors("lens off the frame's centre (a margin outside its square)")
    r0, r1, a, b = _outside_squares(p._fold.lenses, p.height, p.width)[-1]
    frame = np.zeros((p.height, p.width, 3), np.uint8)
    frame[r1 - 1, b - 1, 0] = 255
    stats = {}
    got = p._project_frame(frame, stats)
    assert stats["clipped_fraction"] == 1 / frame.size
    assert got.clip.l00 == 0.0


def test_an_unpaired_pixel_carries_its_own_weight(projectors, kernels):
    p = projectors("a camera's three curves")
    y, x = 60, 90                 # on the lens centre's row (through pixel centres)
    at = y * p.width + x
    assert at in p._fold._res_index and p._l00_weights[at] > 0
    frame = np.zeros((p.height, p.width, 3), np.uint8)
    frame[y, x, 1:] = 255         # green and blue: their own top values
    stats = {}
    got = p._project_frame(frame, stats)
    assert stats["clipped_fraction"] == 2 / frame.size
    top = p._lut(np.uint8).reshape(256, 3)[255].astype(np.float64)
    # its own float32 weight, summed in float64: exact to float64 rounding
    assert got.clip.l00 == pytest.approx(float(top[1:].sum()) * float(p._l00_weights[at]),
                                         rel=1e-12)
