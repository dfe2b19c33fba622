"""An 8-bit equirect frame projected in one pass over its bytes (provider/core/sh9/_equirect.c
and its Python twin, provider/core/sh9/equirect_pass.py): the coefficients, the clipped
samples and the up-facing illuminance that the band by band ``cv2.LUT`` and matrix product
path gives, on the bundled panoramas encoded as a camera would and on hard frames (the
``kernels`` fixture, tests/conftest.py, runs each test over the C kernel and its twin)."""
from __future__ import annotations

import shutil

import numpy as np
import pytest

from conftest import HDRI_NAMES

#: The kernel against the band path: float32 sums over the frame's rows in other orders (the
#: kernel adds the four samples that share a weight, then the row pairs in turn; the band
#: path multiplies each sample and the BLAS sums 32-row blocks its own way, per CPU), then
#: the same float64 column contraction. Measured: at most 2.4e-7 of the largest coefficient
#: on x86-64 (all 255; 1e-8 to 5e-8 on the panoramas); the fold kernel's like sums differ
#: 5× more on aarch64's OpenBLAS (tests/core/kernels/test_kernels.py), so 3e-6 leaves room. A wrong
#: sign or a row read twice is 1e-3 or more.
ATOL = 3e-6


def _srgb8(linear: np.ndarray) -> np.ndarray:
    """Linear radiance as a camera's 8-bit sRGB frame (clipped above 1)."""
    c = np.clip(linear, 0.0, 1.0)
    v = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)
    return np.round(v * 255).astype(np.uint8)


def _both_paths(monkeypatch, build, frame, **project):
    """(the kernel's result, the band path's), checking that the kernel ran."""
    from provider.core.sh9 import equirect_pass
    calls = []
    real = equirect_pass._equirect_rows
    monkeypatch.setattr(equirect_pass, "_equirect_rows",
                        lambda *a: calls.append(1) or real(*a))
    got = build().project(frame, **project)
    assert calls, "the 8-bit frame went through the kernel"
    monkeypatch.setattr(equirect_pass, "KERNEL", False)
    want = build().project(frame, **project)
    return got, want


def _assert_same(got, want):
    scale = np.abs(want.coefficients).max()
    np.testing.assert_allclose(got.coefficients, want.coefficients, atol=ATOL * scale)
    assert got.stats["clipped_fraction"] == want.stats["clipped_fraction"]
    # the clipped samples' L00 (the same counts against float64 row weights) over the
    # coefficients' L00, which differ by the float rounding above
    assert got.stats["clipped_light_fraction"] == pytest.approx(
        want.stats["clipped_light_fraction"], rel=ATOL, abs=1e-12)


@pytest.mark.parametrize("name", HDRI_NAMES)
def test_equirect_kernel_gives_the_band_path_on_the_bundled_panoramas(name, hdri,
                                                                       monkeypatch, kernels):
    """Each panorama exposed so that its median is mid grey, as auto exposure would: its
    sun and lamps clip."""
    from provider.core.sh9.engine import SH9Projector
    # .exr needs the openexr package (a dependency of the install; scripts/arm64.sh's
    # chroot has Debian's numpy and OpenCV only: the hard frames below run there)
    pytest.importorskip("OpenEXR", reason="reading the panoramas (.exr) needs openexr")
    hdr = np.maximum(hdri(name), 0)
    frame = _srgb8(hdr * (0.18 / max(float(np.median(hdr)), 1e-6)))
    got, want = _both_paths(monkeypatch, lambda: SH9Projector(512, 256), frame)
    _assert_same(got, want)


def _hard_frame(case: str, w: int, h: int) -> np.ndarray:
    rng = np.random.default_rng(len(case))
    if case == "all 255":
        return np.full((h, w, 3), 255, np.uint8)
    if case == "all 0":
        return np.zeros((h, w, 3), np.uint8)
    frame = rng.integers(0, 60, (h, w, 3), dtype=np.uint8)        # a dim room
    y, x = np.mgrid[0:h, 0:w]
    frame[(x - 0.31 * w) ** 2 + (y - 0.22 * h) ** 2 < (0.01 * w) ** 2] = 255   # a sun
    frame[h // 2, :] = (255, 200, 0)            # the equator's row, where the halves meet
    return frame


@pytest.mark.parametrize("case", ["all 255", "all 0", "a sun", "odd height (a middle row)",
                                  "1920×960"])
def test_equirect_kernel_gives_the_band_path_on_hard_frames(case, monkeypatch, kernels):
    from provider.core.sh9.engine import SH9Projector
    w, h = {"odd height (a middle row)": (1026, 513), "1920×960": (1920, 960)}.get(
        case, (512, 256))
    frame = _hard_frame(case, w, h)
    got, want = _both_paths(monkeypatch, lambda: SH9Projector(w, h), frame)
    _assert_same(got, want)
    if case == "all 255":
        assert got.stats["clipped_fraction"] == 1.0
        assert got.stats["clipped_light_fraction"] == pytest.approx(1.0, rel=1e-6)
        # a uniform sphere of radiance 1: L00 = 2√π, nothing else
        np.testing.assert_allclose(got.coefficients[0], 2 * np.sqrt(np.pi), rtol=1e-5)
        np.testing.assert_allclose(got.coefficients[1:], 0, atol=1e-5)
    elif case == "all 0":
        assert got.stats["clipped_fraction"] == 0.0
        np.testing.assert_array_equal(got.coefficients, 0)


def test_equirect_kernel_reads_a_camera_table_and_sums_the_up_facing_light(monkeypatch,
                                                                            kernels):
    """A calibrated camera's three curves (a per-channel table) with an absolute scale: the
    up-facing cosine row summed in the same pass gives the frame's illuminance; and a frame
    given as a view with strided rows (a crop of a larger capture)."""
    from provider.core.radiometry.response import CameraResponse
    from provider.core.sh9.engine import SH9Projector
    v = np.arange(256) / 255.0
    response = CameraResponse(np.stack([v ** 2.0, v ** 2.2, v ** 2.4], axis=1), method="table",
                              params={"absolute": {"cd_m2": 120.0, "f_number": 2.0}})
    big = np.concatenate([_hard_frame("a sun", 520, 260)] * 2, axis=0)
    frame = big[3:259, 4:516]                           # 512×256, rows strided
    got, want = _both_paths(monkeypatch, lambda: SH9Projector(512, 256, response=response),
                            frame, exposure_s=0.01)
    _assert_same(got, want)
    assert got.stats["illuminance_lux"] == pytest.approx(want.stats["illuminance_lux"],
                                                         rel=ATOL)
    assert got.stats["illuminance_lux"] > 0


def test_equirect_kernel_counts_the_clipped_samples_of_wide_overexposed_rows(kernels):
    """Rows mostly at 255 (an overexposed sky), wider than the kernel's byte counters hold
    (255 turns of 48 bytes), one channel more clipped than the others: the counts per row
    and channel."""
    from provider.core.sh9 import equirect_pass
    rng = np.random.default_rng(12)
    frame = np.where(rng.random((3, 4400, 3)) < (0.9, 0.95, 0.5), 255,
                     rng.integers(0, 255, (3, 4400, 3))).astype(np.uint8)
    acc = np.zeros((6, 4400 * 3), np.float32)
    counts = equirect_pass.project(frame, np.linspace(0, 1, 256, dtype=np.float32),
                                   np.ones((6, 3), np.float32), acc)
    np.testing.assert_array_equal(counts, (frame == 255).sum(axis=1))


@pytest.mark.parametrize("bad", ["float frame", "odd width", "short table", "8 rows",
                                 "acc too narrow", "counts too short"])
def test_equirect_kernel_refuses_bad_arrays_with_a_message(bad, kernels):
    from provider.core.sh9 import equirect_pass
    frame = np.zeros((4, 8, 3), np.uint8)
    table = np.zeros(256, np.float32)
    rows = np.zeros((6, 4), np.float32)
    acc = np.zeros((6, 24), np.float32)
    counts = np.zeros((4, 3), np.int32)
    if bad == "float frame":
        frame = frame.astype(np.float32)
    elif bad == "odd width":
        frame = np.zeros((4, 7, 3), np.uint8)
    elif bad == "short table":
        table = table[:255]
    elif bad == "8 rows":
        rows, acc = np.zeros((8, 4), np.float32), np.zeros((8, 24), np.float32)
    elif bad == "acc too narrow":
        acc = acc[:, :12].copy()
    else:
        counts = counts[:3].copy()
    with pytest.raises(ValueError):
        equirect_pass._equirect_rows(frame, table, rows, acc, counts)


def test_without_the_c_kernel_the_equirect_twin_is_chosen_at_import():
    """An install where no compiler built it: equirect_pass takes its Python twin at import
    and says so in ``KERNEL``; the projector then keeps the band path, to the same numbers.
    (A fresh interpreter: the choice is made once, at import.)"""
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    from provider.core.sh9.engine import SH9Projector
    script = """if True:
        import json, sys
        import numpy as np
        sys.modules["provider.core.sh9._equirect"] = None      # as if never built
        from provider.core.sh9 import equirect_pass
        from provider.core.sh9.engine import SH9Projector
        assert not equirect_pass.KERNEL
        assert equirect_pass._equirect_rows is equirect_pass._equirect_rows_py
        frame = np.frombuffer(sys.stdin.buffer.read(), np.uint8).reshape(128, 256, 3)
        print(json.dumps(SH9Projector(256, 128).project(frame).coefficients.tolist()))
    """
    frame = _hard_frame("a sun", 256, 128)
    repo = Path(__file__).resolve().parents[3]
    done = subprocess.run([sys.executable, "-c", script], input=frame.tobytes(),
                          capture_output=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(repo)})
    assert done.returncode == 0, done.stderr.decode()[-2000:]
    got = np.array(json.loads(done.stdout))
    want = SH9Projector(256, 128).project(frame).coefficients
    np.testing.assert_allclose(got, want, atol=ATOL * np.abs(want).max())


@pytest.mark.skipif(shutil.which("valgrind") is None,
                    reason="valgrind is not installed (apt-get install valgrind)")
def test_the_edge_bench_counts_an_equirect_frame_against_a_plain_read():
    """``shlight bench --sections edge`` counts the 1920×960 8-bit equirect frame, and each
    workload against reading its frame once (``cv2.sumElems``, counted the same way)."""
    from provider.bench import edge
    from provider.core.sh9.engine import SH9Projector
    what, _, frame = edge.edge_workloads()["equirect"]
    assert "equirect" in what and frame.shape == (960, 1920, 3) and frame.dtype == np.uint8
    small = edge.edge_frame(256, 128)
    read = edge.instructions_per_frame(edge.PlainRead(), small)
    projection = edge.instructions_per_frame(SH9Projector(256, 128), small)
    assert 0 < read < projection


def test_equirect_kernel_reads_a_curve_per_channel_across_bands(monkeypatch, kernels):
    """A camera's three curves without an absolute scale (no up row: the pair tables, one
    set a channel) on a frame of many bands of row pairs (1024×512: 256 pairs, 8 bands of
    32), its strips' sums carried from band to band: the band path's coefficients."""
    from provider.core.radiometry.response import CameraResponse
    from provider.core.sh9.engine import SH9Projector
    v = np.arange(256) / 255.0
    response = CameraResponse(np.stack([v ** 2.0, v ** 2.2, v ** 2.4], axis=1), method="table")
    frame = _hard_frame("a sun", 1024, 512)
    got, want = _both_paths(monkeypatch, lambda: SH9Projector(1024, 512, response=response),
                            frame)
    _assert_same(got, want)
    assert np.abs(got.coefficients[0]).min() > 0
