"""SH9's frame pass (one traversal, each product a sink: provider.core.framepass) gives what
the pass gave before it had sinks: coefficients, counts, lux, lights, the cube's work image
and a bracket slot, for 8/16-bit and float frames, equirect, lenses through the fold (the C
kernel's fused pass and the band pass), dense tables, and the downsampled fast path."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from framepasstools import CASES, run_case

GOLDEN = Path(__file__).resolve().parent / "data" / "frame_pass_golden.npz"

#: Counts and flags: exact whatever the CPU.
EXACT = ("negative_pixels", "nonfinite_pixels", "light_candidates", "work_complete",
         "clipped_fraction")


@pytest.fixture(scope="module")
def golden():
    with np.load(GOLDEN) as data:
        return {key: data[key] for key in data.files}


@pytest.mark.parametrize("name", list(CASES))
def test_the_pass_gives_what_it_gave_before_it_had_sinks(name, golden):
    want = {key.split("/", 1)[1]: value for key, value in golden.items()
            if key.split("/", 1)[0] == name}
    got = run_case(name)
    assert sorted(got) == sorted(want)
    for key, value in want.items():
        if key == "stats_keys":          # the same statistics, in the same order
            assert list(got[key]) == list(value)
        elif key in EXACT:
            assert got[key] == value, key
        elif key == "lights":
            assert got[key].shape == value.shape
            # float32 sums in another order (another CPU's BLAS kernel) move a light by
            # rounding only: 1e-4 of the largest value
            np.testing.assert_allclose(got[key], value, rtol=0,
                                       atol=1e-4 * max(np.abs(value).max(initial=0), 1e-30))
        else:
            # Recorded here with the C kernels and this BLAS; a float32 sum over thousands
            # of pixels taken in another order (another CPU's sgemm, the Python twins)
            # differs by a few ulps of the sum: 2e-5 of the largest value holds with margin.
            scale = max(float(np.abs(value).max(initial=0)), 1e-30)
            np.testing.assert_allclose(got[key], value, rtol=0, atol=2e-5 * scale,
                                       err_msg=key)
