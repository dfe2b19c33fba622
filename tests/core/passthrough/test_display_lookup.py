"""The display lookup (provider/core/passthrough/display.py, docs/contract.md §15): the 256 entries
of g⁻¹ every passthrough consumer renders a hologram through, and how they are read. Its
consumers' tests (tests/clients/three/test_three_passthrough.py, tests/clients/unity/test_unity_passthrough.py) compare
three.js's and Unity's lookups with this one; here it is checked against the table itself, on
the simulated headset's filmic curve (channels that differ, a crushed black: g(0) > 0) and
on sRGB, 8 and 16 bits.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from provider.bench.camera_sim import CameraSim
from provider.bench.headset_sim import HEADSET_CAMERA
from provider.core.passthrough import display_codes, display_lookup
from provider.core.passthrough.fit import codes_of
from provider.core.radiometry.response import CameraResponse, ResponseError

CAMERAS = {"headset": lambda: CameraSim(**HEADSET_CAMERA).true_response(),
           "srgb": CameraResponse.srgb, "srgb16": lambda: CameraResponse.srgb(16)}


@pytest.fixture(params=sorted(CAMERAS))
def camera(request):
    return CAMERAS[request.param]()


def test_the_entries_are_g_inverse_at_log_spaced_exposures_over_the_codes_range(camera):
    """lo is log2 of the smallest g_c(1), hi of the largest g_c(top); entry k of channel c is
    g_c⁻¹(2^(lo + (hi − lo)·k/255)) / top, the table read as numpy's interp reads it: the first
    entry is code 1 in the channel that reaches lowest, the last the top code in all three."""
    g, top = camera.table, camera.table.shape[0] - 1
    lookup = display_lookup(camera)
    assert lookup.lo == math.log2(g[1].min()) and lookup.hi == math.log2(g[-1].max())
    x = 2.0 ** (lookup.lo + (lookup.hi - lookup.lo) * np.arange(256) / 255)
    np.testing.assert_allclose(lookup.table, codes_of(g, np.repeat(x[:, None], 3, 1)) / top,
                               rtol=0, atol=1e-12)
    assert lookup.table[0, int(np.argmin(g[1]))] * top == pytest.approx(1.0, abs=1e-9)
    assert (lookup.table[-1] == 1.0).all()
    assert (np.diff(lookup.table, axis=0) >= 0).all()


def test_reading_the_lookup_costs_under_a_tenth_of_a_code(camera):
    """Between entries the lookup is linear in log2 X: from the first entry up, the code it gives
    is the table's own g⁻¹ within 0.1 code (of 255; a 16-bit table's codes scaled), but within
    one entry of a channel's own clip g_c(top) or floor g_c(0), a kink the shared grid of
    entries cuts: there within half a code. A clipped exposure is the top code."""
    g, top = camera.table, camera.table.shape[0] - 1
    lookup = display_lookup(camera)
    step = (lookup.hi - lookup.lo) / 255
    rng = np.random.default_rng(7)
    x = 2.0 ** rng.uniform(lookup.lo, lookup.hi + 1.0, (20000, 3))
    err = np.abs(display_codes(lookup, x) - codes_of(g, x) / top) * 255
    kinks = np.zeros(x.shape, bool)
    for edge in (g[0], g[-1]):
        kinks |= np.abs(np.log2(x) - np.log2(np.maximum(edge, 1e-30))) < step
    print(f"\n{lookup.hi - lookup.lo:.1f} stops, {step:.3f} stop an entry, worst {err[~kinks].max():.4f} "
          f"code ({err[kinks].max(initial=0):.3f} at a channel's clip or floor)")
    assert err[~kinks].max() < 0.1
    assert err[kinks].max(initial=0) < 0.5
    assert (display_codes(lookup, 2.0 ** lookup.hi * np.array([[1.0, 1.5, 40.0]])) == 1.0).all()


def test_below_the_first_entry_it_runs_linearly_to_code_zero(camera):
    """Under X_0 = 2^lo the lookup is entry 0 · X / X_0 (a shader's log2 would run to −∞): 0 at
    X = 0, half of entry 0 at X_0 / 2, continuous at X_0; the table read directly would clamp
    to code 0 below g(0), which a hologram in the dark must not show as a black step."""
    lookup = display_lookup(camera)
    x0 = 2.0 ** lookup.lo
    f = np.array([0.0, 1e-6, 0.25, 0.5, 0.999999])
    got = display_codes(lookup, np.repeat((f * x0)[:, None], 3, 1))
    np.testing.assert_allclose(got, f[:, None] * lookup.table[0], rtol=1e-9, atol=1e-15)
    at = display_codes(lookup, np.full((1, 3), x0))
    np.testing.assert_allclose(at[0], lookup.table[0], rtol=1e-9)
    assert (display_codes(lookup, np.full((1, 3), -1.0)) == 0).all()


def test_a_table_with_no_range_is_refused_and_a_dip_is_read_as_its_running_maximum():
    """No positive g(1) in any channel, or g(top) not above it: refused in one line. A table that
    dips (not what camera.json holds, which a consumer may be handed) is read as its running
    maximum, as Unity's Sh9PassthroughCamera reads it."""
    with pytest.raises(ResponseError, match="no range"):
        display_lookup(np.zeros((256, 3)))
    with pytest.raises(ResponseError, match="no range"):
        display_lookup(np.full((256, 3), 0.5))
    g = CameraResponse.srgb().table.copy()
    dipped = g.copy()
    dipped[200] = g[150]
    want = display_lookup(np.maximum.accumulate(dipped, axis=0))
    got = display_lookup(dipped)
    assert (got.table == want.table).all() and (got.lo, got.hi) == (want.lo, want.hi)
