"""The C kernels (setup.py) are built, and they and their Python twins compute what the
products' numpy/OpenCV paths compute (the ``kernels`` fixture, tests/conftest.py, runs each
test over both).

The test command builds the kernels as required (``SHLIGHT_BUILD_KERNELS=yes``,
scripts/test.sh), so a kernel that did not build is a failure here, not a silent fall back
to the slower path."""
from __future__ import annotations

import numpy as np
import pytest

from provider.core.radiometry import blocks

BUILD_HINT = ("the C kernels were not built: install a C compiler and Python's headers "
              "(Debian: gcc python3-dev) and rerun `bash scripts/setup.sh test`")


def test_kernels_are_built():
    from provider.core.lights import caps, coarse_truth, first_pass
    from provider.core.sh9 import equirect_pass, lens_fold
    assert blocks.KERNEL and lens_fold.KERNEL and equirect_pass.KERNEL, BUILD_HINT
    assert coarse_truth.KERNEL and caps.KERNEL and first_pass.KERNEL, BUILD_HINT


def _tables():
    rng = np.random.default_rng(3)
    srgb = ((np.arange(256) / 255.0) ** 2.2).astype(np.float32)
    per_channel = (srgb[:, None] * rng.uniform(0.5, 2.0, 3)).astype(np.float32)
    return {"shared": srgb, "per_channel": per_channel.reshape(256, 1, 3)}


@pytest.mark.parametrize("table", ["shared", "per_channel"])
@pytest.mark.parametrize("factor", [1, 2, 3, 4, 8])
def test_decode_blocks_equals_lut_and_area_resize(table, factor, kernels):
    import cv2
    rng = np.random.default_rng(factor)
    frame = rng.integers(0, 256, (67, 93, 3), dtype=np.uint8)
    frame[5:9, 10:20] = 255                                   # a clipped lamp
    t = _tables()[table]
    got = blocks.decode_blocks(frame, t, factor)
    h, w = 67 // factor, 93 // factor
    lut = cv2.LUT(frame[:h * factor, :w * factor], t)        # OpenCV's two calls
    ref = cv2.resize(lut, (w, h), interpolation=cv2.INTER_AREA) if factor > 1 else lut
    assert got.shape == (h, w, 3) and got.dtype == np.float32
    # float32 block sums of at most 64 samples in two orders: ~1e-7 relative
    np.testing.assert_allclose(got, ref, rtol=3e-7, atol=1e-9)
    # The blocks' means, from first principles (float64).
    lin = t.reshape(256, -1)[frame.astype(np.intp), np.arange(3) if t.size > 256 else 0]
    means = lin[:h * factor, :w * factor].reshape(h, factor, w, factor, 3).mean(axis=(1, 3))
    np.testing.assert_allclose(got, means, rtol=1e-6)


def test_decode_blocks_reads_a_window_and_writes_into_out(kernels):
    rng = np.random.default_rng(7)
    frame = rng.integers(0, 256, (40, 64, 3), dtype=np.uint8)
    view = frame[4:36, 8:56]                                  # strided rows
    out = np.full((16, 24, 3), -1.0, np.float32)
    t = _tables()["shared"]
    assert blocks.decode_blocks(view, t, 2, out) is out
    means = t[view.astype(np.intp)].reshape(16, 2, 24, 2, 3).mean(axis=(1, 3))
    np.testing.assert_allclose(out, means, rtol=3e-7)


@pytest.mark.parametrize("bad", ["float frame", "factor 0", "short table", "wrong out",
                                 "factor larger than the frame"])
def test_decode_blocks_refuses_bad_arrays_with_a_message(bad, kernels):
    frame = np.zeros((8, 8, 3), np.uint8)
    t, factor, out = _tables()["shared"], 2, None
    if bad == "float frame":
        frame = frame.astype(np.float32)
    elif bad == "factor 0":
        factor = 0
    elif bad == "short table":
        t = t[:100]
    elif bad == "wrong out":
        out = np.zeros((3, 4, 3), np.float32)
    else:       # no whole block: an empty answer would pass for a black frame
        frame, factor = np.zeros((37, 53, 3), np.uint8), 100
    with pytest.raises(ValueError, match="factor: larger than the frame" if factor == 100
                       else None):
        blocks.decode_blocks(frame, t, factor, out)


# -- the fold kernel (provider/core/sh9/_fold.c) ------------------------------------------------

FOLD_CASES = {
    "Theta S dual fisheye, lights": (1280, 720, "dual-fisheye", {"lights": "auto"}),
    "Pi fisheye 640×480": (640, 480, "fisheye", {}),
    "odd size, pixel-centred lens": (641, 481, "fisheye", {}),
    "mirror ball in a window of the frame": (640, 480, "mirrorball",
                                             {"center": (300, 200), "radius": 150}),
    "Pi fisheye, --downsample 2": (640, 480, "fisheye", {"downsample": 2}),
}


def _lamp_frame(w, h, seed):
    """An 8-bit frame: noise, two clipped lamps, and black where no pixel has a weight (a
    lens's surround), as a camera gives."""
    rng = np.random.default_rng(seed)
    frame = rng.integers(0, 200, (h, w, 3), dtype=np.uint8)
    frame[h // 3:h // 3 + 4, w // 4:w // 4 + 6] = 255
    frame[h // 2:h // 2 + 3, (3 * w) // 5:(3 * w) // 5 + 3] = (255, 240, 200)
    return frame


#: The C fold against numpy's band by band path: float32 sums over 10^5-10^6 pixels in other
#: orders (the kernel's rows and quarters, numpy's and the BLAS's blocks, which each CPU's
#: BLAS kernels order its own way). Measured: 2e-6 of the largest coefficient on x86-64,
#: 9.4e-6 on aarch64 (Debian 12's OpenBLAS NEON kernels, scripts/arm64.sh); a wrong weight or
#: a missed pixel is 1e-3 or more.
FOLD_ATOL = 3e-5


def _both_paths(monkeypatch, build, frame):
    from provider.core.sh9 import lens_fold
    with_kernel = build().project(frame)
    monkeypatch.setattr(lens_fold, "KERNEL", False)
    without = build().project(frame)
    monkeypatch.setattr(lens_fold, "KERNEL", True)
    return with_kernel, without


@pytest.mark.parametrize("case", FOLD_CASES, ids=list(FOLD_CASES))
def test_fold_kernel_gives_the_numpy_fold_coefficients(case, monkeypatch, kernels):
    from provider.core.sh9 import lens_fold
    from provider.core.sh9.engine import SH9Projector
    w, h, name, options = FOLD_CASES[case]
    frame = _lamp_frame(w, h, 5)
    calls = []
    real = lens_fold._fold_kernel
    monkeypatch.setattr(lens_fold, "_fold_kernel", lambda *a: calls.append(1) or real(*a))
    got, want = _both_paths(monkeypatch, lambda: SH9Projector(w, h, name, **options), frame)
    assert calls, "the 8-bit frame went through the kernel"
    scale = np.abs(want.coefficients).max()
    np.testing.assert_allclose(got.coefficients, want.coefficients, atol=FOLD_ATOL * scale)
    assert got.stats["clipped_fraction"] == want.stats["clipped_fraction"]


def test_fold_kernel_reads_a_camera_table_and_a_window_of_the_frame(monkeypatch, kernels):
    """A per-channel table (a calibrated camera's three curves) and a frame given as a view
    with strided rows (a crop of a larger capture)."""
    from provider.core.radiometry.response import CameraResponse
    from provider.core.sh9.engine import SH9Projector
    v = np.arange(256) / 255.0
    table = np.stack([v ** 2.0, v ** 2.2, v ** 2.4], axis=1)
    response = CameraResponse(table, method="table")
    assert not response.channels_identical
    big = _lamp_frame(700, 520, 6)
    frame = big[20:500, 30:670]                          # 640×480, rows strided
    got, want = _both_paths(monkeypatch, lambda: SH9Projector(
        640, 480, "fisheye", response=response), frame)
    scale = np.abs(want.coefficients).max()
    np.testing.assert_allclose(got.coefficients, want.coefficients, atol=FOLD_ATOL * scale)


def test_fold_kernel_gives_the_lights_the_block_means_of_what_they_see(monkeypatch,
                                                                     kernels):
    """The lights' detection copy made inside the kernel: the f × f block means of the
    decoded frame (pixels without a weight count as black), and the same lights."""
    from provider.core.sh9.engine import SH9Projector
    p = SH9Projector(1280, 720, "dual-fisheye", lights="auto")
    frame = _lamp_frame(1280, 720, 7)
    seen = np.any(p.projection.sh_weights != 0, axis=1).reshape(720, 1280)
    frame[~seen] = 0                                     # black outside the lenses
    ext, f = p._extractor, p._extractor.mid_factor
    mid = ext.new_mid()
    acc = p._fold.new()
    table = p._lut(np.uint8)
    p._fold.decode_project(frame, table, acc, mid, f)
    lin = table[frame.astype(np.intp)]
    means = lin.reshape(720 // f, f, 1280 // f, f, 3).mean(axis=(1, 3))
    np.testing.assert_allclose(mid, means, rtol=2e-6, atol=1e-9)
    got, want = _both_paths(monkeypatch, lambda: SH9Projector(
        1280, 720, "dual-fisheye", lights="auto"), frame)
    assert len(got.lights) == len(want.lights)
    for a, b in zip(got.lights, want.lights):
        np.testing.assert_allclose(a.direction, b.direction, atol=1e-5)
        np.testing.assert_allclose(a.irradiance, b.irradiance, rtol=1e-4)
    # a relative RMS error of ~1e-3, moved by at most the coefficients' own difference
    assert got.stats["light_error"] == pytest.approx(want.stats["light_error"], abs=FOLD_ATOL)


@pytest.mark.parametrize("clip", [False, True])
def test_fold_kernel_runs_the_lights_first_pass_as_it_fills_their_copy(kernels, clip):
    """The lights' first pass run by the fold kernel on each band of their copy as the fold
    completes it (issue 44: the copy crosses the memory bus once): the same copy, luminance
    and coarse copy as the first pass run on the finished copy (the same float32
    operations on the same sums: equal), the same Σ Y ω (a double sum in another band
    order: 1e-12), rows' largest Y, SH9 sums, unpaired pixels and clip tally."""
    from provider.core.lights.first_pass import first_pass
    from provider.core.sh9.engine import SH9Projector
    p = SH9Projector(1280, 720, "dual-fisheye", lights="auto")
    frame = _lamp_frame(1280, 720, 11)
    frame[300:340, 100:1200] = 255                      # clipped rows across both lenses
    ext, f = p._extractor, p._extractor.mid_factor
    table = p._lut(np.uint8)
    args = ext.first_pass_args((ext.mid.height, ext.mid.width))
    assert args[2] is not None, "the Theta S's coarse pixels are whole blocks of its copy"
    runs = []
    for fused in (True, False):
        mid, acc = ext.new_mid(), p._fold.new()
        tally = np.zeros(4) if clip else None
        out = p._fold.decode_project(frame, table, acc, mid, f, tally, mean=False,
                                     first=args if fused else None)
        if not fused:
            assert out is None
            out = first_pass(mid, 1.0 / (f * f), *args)
        runs.append((mid, out, p._fold.coefficients(acc), tally))
    (mid, (Y, total, coarse, top), sh9, tally), (mid0, (Y0, total0, coarse0, top0), sh90,
                                                tally0) = runs
    np.testing.assert_array_equal(mid, mid0)
    np.testing.assert_array_equal(Y, Y0)
    np.testing.assert_array_equal(top, top0)
    np.testing.assert_array_equal(top, Y.max(axis=1))
    np.testing.assert_array_equal(coarse, coarse0)
    # Σ Y ω: the same 36,864 non-negative float32 products added in double in two band
    # orders; each order's rounding is a sum of independent ±2⁻⁵³ errors, ~√n·2⁻⁵³ ≈ 2e-14
    # of the total on any IEEE machine (no fused multiply-add reaches it: each product is
    # rounded to float32 first), so 1e-12 leaves 50× (aarch64 under qemu: passes)
    assert total == pytest.approx(total0, rel=1e-12) and total > 0
    np.testing.assert_array_equal(sh9, sh90)
    if clip:
        np.testing.assert_array_equal(tally, tally0)
        assert tally[0] > 0
    # and what the lights see: block means of the decoded frame (black outside the lenses)
    seen = np.any(p.projection.sh_weights != 0, axis=1).reshape(720, 1280)
    lin = np.where(seen[..., None], table[frame.astype(np.intp)], 0.0)
    means = lin.reshape(720 // f, f, 1280 // f, f, 3).mean(axis=(1, 3))
    np.testing.assert_allclose(mid, means, rtol=2e-6, atol=1e-9)


def test_fold_kernel_frames_in_a_row_leave_nothing_behind(kernels):
    """Its buffers are per call: a frame after another gives what a fresh projector gives."""
    from provider.core.sh9.engine import SH9Projector
    p = SH9Projector(1280, 720, "dual-fisheye", lights="auto")
    p.project(_lamp_frame(1280, 720, 8))
    second = _lamp_frame(1280, 720, 9)
    np.testing.assert_array_equal(
        p.project(second).coefficients,
        SH9Projector(1280, 720, "dual-fisheye", lights="auto").project(second).coefficients)


@pytest.mark.parametrize("bad", ["float frame with a table", "square off the frame",
                                 "right half left of the frame", "top half below the frame",
                                 "short extents", "parity 7", "radial of 10 columns",
                                 "a negative bin width", "a correction past the square"])
def test_fold_kernel_refuses_bad_arrays_with_a_message(bad, kernels):
    from provider.core.sh9 import lens_fold
    frame = np.zeros((8, 8, 3), np.uint8)
    table = np.zeros(256, np.float32)
    geometry = (4, 4, 4, 4, 4, 4)
    extents = np.full(4, 4, np.int32)
    tables = np.zeros((2, 16), np.float32)
    parities = np.array([0, 3], np.int32)
    radial, inv_step = np.zeros((8, 20), np.float32), 4.0
    fix_at, fixes = np.array([3], np.int32), np.zeros((1, 9), np.float32)
    if bad == "float frame with a table":
        frame = frame.astype(np.float32)
    elif bad == "square off the frame":
        geometry = (4, 4, 4, 4, 5, 4)
    elif bad == "right half left of the frame":       # would read before the row
        geometry = (4, -100_000_000, 4, 4, 4, 4)
    elif bad == "top half below the frame":           # would read past the frame
        geometry = (4, 4, 100_000_000, 4, 4, 4)
    elif bad == "short extents":
        extents = extents[:2]
    elif bad == "radial of 10 columns":
        radial = np.zeros((8, 10), np.float32)
    elif bad == "a negative bin width":
        inv_step = -4.0
    elif bad == "a correction past the square":
        fix_at = np.array([16], np.int32)
    else:
        parities = np.array([0, 7], np.int32)
    with pytest.raises(ValueError):
        lens_fold._fold_kernel(frame, table, geometry, np.zeros((0, 2), np.int32), extents,
                               radial, inv_step, fix_at, fixes, tables, parities,
                               np.zeros((1, 11, 3)), None, 1, False)


def test_downsample_2_is_withdrawn_where_the_half_size_lens_is_off_the_grid():
    """A Theta S lens is centred on a pixel's centre: at half size its centre falls between
    pixels, the small frame's table is dense (9 weights a small pixel, as many floats as the
    full frame's quarter tables) and the exact fold is faster (20.6 M against 26.2 M
    instructions, issue 34): --downsample 2 says so and projects exactly; 4 stays."""
    from provider.core.sh9.engine import SH9Projector
    frame = _lamp_frame(1280, 720, 10)
    half = SH9Projector(1280, 720, "dual-fisheye", downsample=2)
    assert half.downsample == 1 and any("--downsample 2 is withdrawn" in w for w in half.warnings)
    np.testing.assert_array_equal(half.project(frame).coefficients,
                                  SH9Projector(1280, 720, "dual-fisheye").project(frame).coefficients)
    assert SH9Projector(1280, 720, "dual-fisheye", downsample=4).downsample == 4
    assert SH9Projector(640, 480, "fisheye", downsample=2).downsample == 2   # on the grid


def test_without_the_c_kernels_the_twins_are_chosen_at_import():
    """An install where no compiler built them (``SHLIGHT_BUILD_KERNELS=no``): each module
    takes its Python twin at import, says so in ``KERNEL``, and a frame projects to the
    same coefficients. (A fresh interpreter: the choice is made once, at import.)"""
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    from provider.core.sh9.engine import SH9Projector
    script = """if True:
        import json, sys
        import numpy as np
        sys.modules["provider.core.radiometry._blocks"] = None   # as if never built
        sys.modules["provider.core.sh9._fold"] = None
        sys.modules["provider.core.lights._lights"] = None
        from provider.core.radiometry import blocks
        from provider.core.sh9 import fold_twin, lens_fold
        from provider.core.sh9.engine import SH9Projector
        assert not blocks.KERNEL and blocks._decode_blocks is blocks._decode_blocks_py
        assert not lens_fold.KERNEL and lens_fold._fold_kernel is fold_twin.fold_lens
        from provider.core.lights import caps, coarse_truth, first_pass
        assert not first_pass.KERNEL
        assert first_pass._first_pass_kernel is first_pass.first_pass_twin
        assert not coarse_truth.KERNEL
        assert coarse_truth._truth_kernel is coarse_truth.truth_caps_twin
        assert not caps.KERNEL and caps._excess_kernel is caps.excess_rows_twin
        frame = np.frombuffer(sys.stdin.buffer.read(), np.uint8).reshape(120, 160, 3)
        print(json.dumps(SH9Projector(160, 120, "fisheye").project(frame).coefficients.tolist()))
    """
    frame = _lamp_frame(160, 120, 11)
    repo = Path(__file__).resolve().parents[3]
    done = subprocess.run([sys.executable, "-c", script], input=frame.tobytes(),
                          capture_output=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(repo)})
    assert done.returncode == 0, done.stderr.decode()[-2000:]
    got = np.array(json.loads(done.stdout))
    want = SH9Projector(160, 120, "fisheye").project(frame).coefficients
    # the band by band float32 path against the C fold's: float32 sums in other orders
    np.testing.assert_allclose(got, want, atol=FOLD_ATOL * np.abs(want).max())
