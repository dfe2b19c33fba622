"""SH9's frame pass (one traversal, each product a sink: provider.core.framepass) gives what
the pass gave before it had sinks: coefficients, counts, lux, lights, the cube's work image
and a bracket slot, for 8/16-bit and float frames, equirect, lenses through the fold (the C
kernel's fused pass and the band pass), dense tables, and the downsampled fast path; over
the C kernels and their Python twins (the ``kernels`` fixture)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from framepasstools import CASES, frame_of, run_case
from provider.core.framepass.sinks import Sink, Sinks
from provider.core.framepass.traversal import FramePass, LutBands
from provider.core.sh9.engine import SH9Projector

GOLDEN = Path(__file__).resolve().parents[1] / "data" / "frame_pass_golden.npz"

#: Counts and flags: exact whatever the CPU.
EXACT = ("negative_pixels", "nonfinite_pixels", "light_candidates", "work_complete",
         "clipped_fraction")


@pytest.fixture(scope="module")
def golden():
    with np.load(GOLDEN) as data:
        return {key: data[key] for key in data.files}


@pytest.mark.parametrize("name", list(CASES))
def test_the_pass_gives_what_it_gave_before_it_had_sinks(name, golden, kernels):
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


class Rows(Sink):
    """A product that keeps every band it is fed: what a new sink would see."""

    def __init__(self, all_columns=False, needs_bands=True):
        self.all_columns, self.needs_bands = all_columns, needs_bands
        self.starts, self.finishes, self.bands = 0, 0, []

    def start(self, frame, table, stats):
        self.starts += 1

    def band(self, lin, r0, raw, columns):
        self.bands.append((r0, lin.copy(), columns))

    def finish(self, stats):
        self.finishes += 1


@pytest.mark.parametrize("dtype", ["uint8", "uint16", "float32-bad"])
def test_a_sink_is_fed_every_row_once_in_order(dtype):
    projector = SH9Projector(160, 80, "equirect")
    frame = frame_of(dtype, 160, 80)
    rows, stats = Rows(), {"negative_pixels": 0, "nonfinite_pixels": 0}
    FramePass(projector._strategies()).run(projector, frame, Sinks(rows=rows), stats)
    assert (rows.starts, rows.finishes) == (1, 1)
    assert [r0 for r0, _, _ in rows.bands] == [0, 32, 64]
    whole = np.concatenate([lin for _, lin, _ in rows.bands])
    assert np.array_equal(whole, projector.decode(frame, {}))     # the decode, band by band
    if dtype == "float32-bad":
        assert (stats["nonfinite_pixels"], stats["negative_pixels"]) == (3, 1)   # −inf: nonfinite


def test_a_sink_that_needs_every_column_turns_the_spans_off():
    projector = SH9Projector(192, 128, "fisheye")
    assert projector._spans is not None        # the lens leaves a third of the frame unseen
    frame = frame_of("uint16", 192, 128)
    spans, every = Rows(), Rows(all_columns=True)
    FramePass(projector._strategies()).run(projector, frame, Sinks(spans=spans), {})
    FramePass(projector._strategies()).run(projector, frame, Sinks(every=every), {})
    assert all(columns is None for _, _, columns in every.bands)
    assert np.array_equal(np.concatenate([lin for _, lin, _ in every.bands]),
                          projector.decode(frame, {}))
    for (r0, lin, columns), (_, full, _) in zip(spans.bands, every.bands):
        seen = np.zeros(lin.shape[1], bool)
        for a, b in columns:
            seen[a:b] = True
        assert np.array_equal(lin[:, seen], full[:, seen]) and not lin[:, ~seen].any()


def test_a_fused_kernel_is_taken_only_where_no_other_sink_needs_bands(kernels):
    projector = SH9Projector(192, 128, "fisheye", lights="auto")
    frame = frame_of("uint8", 192, 128)
    sinks = projector._sinks(frame, None, None, False)
    fp = FramePass(projector._strategies())
    assert type(fp.strategy(frame, sinks)).__name__ == "FoldDecode"
    assert sinks.lights is not None and sinks.lights.image is not None
    banded = Sinks(**sinks.named, rows=Rows())
    assert isinstance(fp.strategy(frame, banded), LutBands)
    rows = Rows(needs_bands=False)        # copes without: left unfed by the fused kernel
    fp.run(projector, frame, Sinks(**sinks.named, rows=rows), {})
    assert rows.bands == [] and (rows.starts, rows.finishes) == (1, 1)
