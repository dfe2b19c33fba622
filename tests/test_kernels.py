"""The C kernels (setup.py) are built, and compute what the numpy/OpenCV paths compute.

The test command installs a C compiler where one is missing (scripts/test.sh), so a kernel
that did not build is a failure here, not a silent fall back to the slower path."""
from __future__ import annotations

import numpy as np
import pytest

from provider.core.radiometry import blocks

BUILD_HINT = ("the C kernels were not built: install a C compiler and Python's headers "
              "(Debian: gcc python3-dev) and rerun `bash scripts/setup.sh test`")


def test_kernels_are_built():
    assert blocks.KERNEL, BUILD_HINT


def _tables():
    rng = np.random.default_rng(3)
    srgb = ((np.arange(256) / 255.0) ** 2.2).astype(np.float32)
    per_channel = (srgb[:, None] * rng.uniform(0.5, 2.0, 3)).astype(np.float32)
    return {"shared": srgb, "per_channel": per_channel.reshape(256, 1, 3)}


@pytest.mark.parametrize("table", ["shared", "per_channel"])
@pytest.mark.parametrize("factor", [1, 2, 3, 4, 8])
def test_decode_blocks_equals_lut_and_area_resize(table, factor):
    rng = np.random.default_rng(factor)
    frame = rng.integers(0, 256, (67, 93, 3), dtype=np.uint8)
    frame[5:9, 10:20] = 255                                   # a clipped lamp
    t = _tables()[table]
    got = blocks.decode_blocks(frame, t, factor)
    ref = blocks.decode_blocks(frame, t, factor, kernel=False)
    assert got.shape == (67 // factor, 93 // factor, 3) and got.dtype == np.float32
    np.testing.assert_allclose(got, ref, rtol=3e-7, atol=1e-9)
    # The blocks' means, from first principles (float64).
    lin = t.reshape(256, -1)[frame.astype(np.intp), np.arange(3) if t.size > 256 else 0]
    h, w = 67 // factor, 93 // factor
    means = lin[:h * factor, :w * factor].reshape(h, factor, w, factor, 3).mean(axis=(1, 3))
    np.testing.assert_allclose(got, means, rtol=1e-6)


def test_decode_blocks_reads_a_window_and_writes_into_out():
    rng = np.random.default_rng(7)
    frame = rng.integers(0, 256, (40, 64, 3), dtype=np.uint8)
    view = frame[4:36, 8:56]                                  # strided rows
    out = np.full((16, 24, 3), -1.0, np.float32)
    t = _tables()["shared"]
    assert blocks.decode_blocks(view, t, 2, out) is out
    np.testing.assert_allclose(out, blocks.decode_blocks(view.copy(), t, 2, kernel=False),
                               rtol=3e-7)


@pytest.mark.parametrize("bad", ["float frame", "factor 0", "short table", "wrong out"])
def test_decode_blocks_refuses_bad_arrays_with_a_message(bad):
    frame = np.zeros((8, 8, 3), np.uint8)
    t, factor, out = _tables()["shared"], 2, None
    if bad == "float frame":
        frame = frame.astype(np.float32)
    elif bad == "factor 0":
        factor = 0
    elif bad == "short table":
        t = t[:100]
    else:
        out = np.zeros((3, 4, 3), np.float32)
    with pytest.raises(ValueError):
        blocks.decode_blocks(frame, t, factor, out)
