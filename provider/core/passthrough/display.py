"""The display lookup: what a consumer's shader renders a hologram through (docs/contract.md §15).

A hologram of linear colour C (the sphere's units) is shown as its real replica's code
z_c = g_c⁻¹(exposure · wb_c · C_c), g_c the fitted inverse response. A shader cannot invert a
table, so every consumer (three.js's ``passthroughLut``, Unity's ``Sh9PassthroughCamera``)
holds g⁻¹ as the same 256 entries, read the same way; this module is that definition, and the
consumers' tests compare them to it.

* Entries at sensor exposures X_k = 2^(lo + (hi − lo)·k/255), k = 0..255, lo = log2 of the
  smallest positive g_c(1) over the channels (code 1: the lookup spends its entries on the
  codes' own range, not on the stops below code 1), hi = log2 of the largest g_c(top).
  Entry k of channel c is g_c⁻¹(X_k) / top, g⁻¹ the table read as numpy's ``interp`` reads
  it (linear, clamped to codes 0 and top).
* Read at t = (log2 X − lo) / (hi − lo) · 255: between entries linear in t (a bilinear
  256-texel texture sampled at texel centres); below X_0 linear in X down to code 0 (entry 0
  · X / X_0: the toe, where log2 would run off to −∞); above X_255 the last entry, the top
  code.

For a table of 8-bit codes the entries are about 0.05 stop apart; reading them gives the
table's own g⁻¹ within a tenth of a code, half a code within one entry of a channel's own clip
or floor, a kink the shared entries cut (tests/core/passthrough/test_display_lookup.py).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..radiometry.response import CameraResponse, ResponseError
from .fit import codes_of

#: Entries of the lookup (a 256 × 1 texture in the shaders).
LUT_SIZE = 256


class DisplayLookup(NamedTuple):
    """The lookup: ``table`` (256, 3) code / top per channel, ``lo`` and ``hi`` log2 of the
    sensor exposure at the first and the last entry."""

    table: np.ndarray
    lo: float
    hi: float


def display_lookup(camera) -> DisplayLookup:
    """The display lookup (module doc) of ``camera``: a :class:`CameraResponse` or its table
    g (codes, 3), non-decreasing. Raises :class:`ResponseError` for a table with no range
    (no positive g(1), or g(top) not above it)."""
    g = camera.table if isinstance(camera, CameraResponse) else np.asarray(camera, np.float64)
    if g.ndim != 2 or g.shape[1] != 3 or g.shape[0] < 2:
        raise ResponseError(f"a display lookup needs a table (codes, 3), got shape {g.shape}")
    # a table that dips (not a camera.json's) is read as its running maximum, as Unity reads it
    g = np.maximum.accumulate(g, axis=0)
    top = g.shape[0] - 1
    first = g[1][g[1] > 0]
    last = float(g[-1].max())
    if first.size == 0 or not last > first.min():
        raise ResponseError("the camera's table has no range: g(1) must be positive and below g(top)")
    lo, hi = math.log2(float(first.min())), math.log2(last)
    x = 2.0 ** (lo + (hi - lo) * np.arange(LUT_SIZE) / (LUT_SIZE - 1))
    return DisplayLookup(codes_of(g, np.repeat(x[:, None], 3, 1)) / top, lo, hi)


def display_codes(lookup: DisplayLookup, x) -> np.ndarray:
    """What a shader shows through ``lookup`` for sensor exposures ``x`` (..., 3) (the linear
    colour × exposure × wb): code / top in [0, 1] per channel (module doc)."""
    table, lo, hi = lookup
    x = np.maximum(np.asarray(x, np.float64), 0.0)
    t = (np.log2(np.maximum(x, 1e-30)) - lo) / (hi - lo) * (LUT_SIZE - 1)
    t = np.clip(t, 0, LUT_SIZE - 1)
    k = np.arange(LUT_SIZE, dtype=np.float64)
    read = np.stack([np.interp(t[..., c], k, table[:, c]) for c in range(3)], -1)
    # the toe: below X_0 the entry 0 is scaled by X / X_0 (1 at and above X_0)
    return read * np.minimum(x * 2.0 ** -lo, 1.0)
