"""The lights' truth by caps of normals (provider/core/lights/_lights.c, issue 44) and its
Python twin (coarse_truth.truth_caps_twin), driven with random caps, some of them wrong on
purpose: for every draw either both refuse it with the same exception and message, or both
write the same sums to float32 rounding. The same for the candidates' excess at the normals
their horizon cuts (``excess_rows``, its twin caps.excess_rows_twin). The vector build (as installed) and the portable
scalar loops (SHLIGHT_SCALAR_KERNELS, what a compiler without GCC's vector extension takes)
both; on aarch64 too (scripts/arm64.sh)."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from provider.core.lights import caps, coarse_truth
from provider.core.lights.first_pass import first_pass_twin
from provider.core.lights.coarse_truth import truth_caps_twin

pytestmark = pytest.mark.skipif(
    not coarse_truth.KERNEL,
    reason="the C kernels were not built (tests/core/kernels/test_kernels.py says how)")

SETTINGS = settings(max_examples=150, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
EPS32 = 2.0 ** -24
SOURCE = Path(__file__).resolve().parents[3] / "provider" / "core"


@pytest.fixture(scope="module")
def builds(tmp_path_factory):
    """build -> truth_caps: "vector" as installed, "scalar" compiled here."""
    from setuptools import Distribution, Extension
    from setuptools.command.build_ext import build_ext

    from provider.core.lights import _lights
    out = tmp_path_factory.mktemp("scalar_lights")
    ext = Extension("_lights", [str(SOURCE / "lights" / "_lights.c")],
                    include_dirs=[str(SOURCE / "_kernels")],
                    define_macros=[("SHLIGHT_SCALAR_KERNELS", "1")])
    cmd = build_ext(Distribution({"ext_modules": [ext]}))
    cmd.build_lib, cmd.build_temp = str(out), str(out / "tmp")
    cmd.ensure_finalized()
    cmd.run()
    spec = importlib.util.spec_from_file_location("_lights", cmd.get_ext_fullpath("_lights"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return {"vector": _lights, "scalar": module}


FAULTS = ["index past P", "int32 core", "offsets end short", "offsets decrease",
          "offsets start at 1", "float32 normals", "x of 4 channels", "dw a row short",
          "out of k + 1 rows", "float64 x", "x not contiguous", "short core_at"]


@st.composite
def calls(draw):
    """The eight arguments: half of them right, half with one fault."""
    fault = draw(st.sampled_from(FAULTS)) if draw(st.booleans()) else None
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    P, caps, k = draw(st.integers(1, 300)), draw(st.integers(1, 6)), draw(st.integers(1, 9))
    x = rng.random((P, 4 if fault == "x of 4 channels" else 3), dtype=np.float32)
    if fault == "float64 x":
        x = x.astype(np.float64)
    elif fault == "x not contiguous":
        x = np.repeat(x, 2, axis=0)[::2]
    dw = rng.standard_normal((P - (fault == "dw a row short"), 3)).astype(np.float32)
    lists = []
    for name in ("core", "band"):
        sizes = rng.integers(0, 2 * P + 1, caps)      # repeats and empty caps allowed
        idx = rng.integers(0, P, int(sizes.sum())).astype(np.uint16)
        at = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int32)
        lists.append([idx, at])
    (core, core_at), (band, band_at) = lists
    if fault == "index past P" and band.size:
        band[-1] = P
    elif fault == "int32 core":
        core = core.astype(np.int32)
    elif fault == "offsets end short":
        band_at[-1] += 1
    elif fault == "offsets decrease" and caps > 1:
        core_at[1] = core_at[2] + 1 if core_at[2] < core_at[-1] else -1
    elif fault == "offsets start at 1":
        core_at[0] = 1
    elif fault == "short core_at":
        core_at = core_at[:-1]
    normals = rng.standard_normal((caps, k, 3))
    if fault == "float32 normals":
        normals = normals.astype(np.float32)
    out = np.full((caps, k + (fault == "out of k + 1 rows"), 3), np.nan)
    return x, dw, core, core_at, band, band_at, normals, out


def _call(kernel, args, written):
    """``kernel(*args)`` on copies of the arrays at the indices ``written`` (each as
    writable as given): (the exception it raised, None), or (None, (what it returned,
    *those copies))."""
    args = list(args)
    for i in written:
        if args[i] is not None:
            copy = args[i].copy()
            copy.flags.writeable = args[i].flags.writeable
            args[i] = copy
    try:
        returned = kernel(*args)
    except (ValueError, TypeError) as exc:
        return exc, None
    return None, (returned, *(args[i] for i in written))


def _refused_alike(c_err, t_err) -> bool:
    """Whether either refused the call; if so, both did, with one exception and message."""
    if c_err is None and t_err is None:
        return False
    assert (type(c_err), str(c_err)) == (type(t_err), str(t_err)), (c_err, t_err)
    return True


@pytest.mark.parametrize("build", ["vector", "scalar"])
@SETTINGS
@given(args=calls())
def test_truth_caps_and_its_twin_agree(builds, build, args):
    c_err, got = _call(builds[build].truth_caps, args, (7,))
    t_err, want = _call(truth_caps_twin, args, (7,))
    if _refused_alike(c_err, t_err):
        return
    got, want = got[1], want[1]
    x, dw, core, core_at, band, band_at, normals, _ = args
    # Float32 sums in other orders (the C's four lanes, the twin's BLAS): each sum within
    # n·2⁻²⁴ of its terms' magnitudes on either side, the band's float32 cosines within
    # 4·2⁻²⁴ of |n|·|d w|; the normals' products with the cores' sums in float64.
    bound = np.zeros(want.shape)
    for i in range(len(core_at) - 1):
        c = core[core_at[i]:core_at[i + 1]]
        mag = np.abs(dw[c]).T.astype(np.float64) @ np.abs(x[c])               # (3, 3)
        b = band[band_at[i]:band_at[i + 1]]
        rows = np.abs(normals[i]) @ np.abs(dw[b]).T.astype(np.float64)        # (k, m)
        bound[i] = (len(c) + 2) * EPS32 * (np.abs(normals[i]) @ mag) \
            + (len(b) + 6) * EPS32 * (rows @ np.abs(x[b]))
    assert np.isfinite(got).all()
    assert (np.abs(got - want) <= 2 * bound + 1e-300).all()
    # and the sums are what they stand for: Σ max(0, n·d w) x over the core and the band
    # (float64; the core's cosines are whatever the draw made them, the C takes them as
    # positive: n · Σ d w xᵀ)
    exact = np.zeros(want.shape)
    for i in range(len(core_at) - 1):
        c = core[core_at[i]:core_at[i + 1]]
        b = band[band_at[i]:band_at[i + 1]]
        d64, x64 = dw.astype(np.float64), x.astype(np.float64)
        exact[i] = normals[i] @ (d64[c].T @ x64[c]) \
            + np.maximum(normals[i] @ d64[b].T, 0.0) @ x64[b]
    assert (np.abs(got - exact) <= 2 * bound + 1e-9 * np.abs(exact)).all()


def test_the_split_truth_is_the_dense_kernels_sum():
    """The caps of a Theta S's 256 normals: a uniform sky and a single bright pixel in each
    cap's core, band and back (the three cases the split tells apart) give the dense
    kernel's irradiance."""
    from provider.core.geometry.projections import DualFisheye
    from provider.core.lights.extractor import LightExtractor
    x = LightExtractor(DualFisheye(1280, 720))
    t = x.coarse_truth
    sp = t.split
    assert sp is not None and sp.normals.shape == (32, 8, 3)
    # the band takes 41 % of the dense kernel's products (and stores none of them)
    assert 0.3 < 8 * sp.band.size / (256 * len(t.pixels)) < 0.5
    assert not hasattr(sp, "kernel") and t.kernel is None
    dirs = t.coarse.directions().reshape(-1, 3)[t.pixels]
    omega = t.coarse.solid_angle.reshape(-1)[t.pixels]
    dense = x._brute_kernel(dirs, omega)                                     # float64
    seeing = np.zeros((len(t.pixels), 3), np.float32)
    for p in (sp.core[0], sp.band[0], int(np.argmin(dirs @ sp.normals[0].sum(axis=0)))):
        seeing[:] = 0.01
        seeing[p] = (1000.0, 500.0, 250.0)
        got = sp(seeing)
        want = dense @ seeing.astype(np.float64)
        # float32 sums of ≤ 2,556 non-negative terms (a core's: signed, one term ×10⁵
        # the rest): within 1e-5 of the largest irradiance
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-5 * np.abs(want).max())


EXCESS_FAULTS = ["row past N", "negative row", "flux a row short", "dirs of 4 channels",
                 "float64 normals", "out of N + 1 rows", "int64 rows", "dirs not contiguous",
                 "out read-only"]


@st.composite
def excess_calls(draw):
    """excess_rows' five arguments: half of them right, half with one fault; directions
    of any length (the kernel takes them as given), repeated rows (each adds again)."""
    fault = draw(st.sampled_from(EXCESS_FAULTS)) if draw(st.booleans()) else None
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    n, N, k = draw(st.integers(0, 200)), draw(st.integers(1, 40)), draw(st.integers(0, 60))
    dirs = rng.standard_normal((n, 4 if fault == "dirs of 4 channels" else 3)
                               ).astype(np.float32)
    if fault == "dirs not contiguous":
        dirs = np.repeat(dirs, 2, axis=0)[::2]
    flux = rng.uniform(0, 1e3, (n - (fault == "flux a row short" and n > 0), 3)
                       ).astype(np.float32)
    if fault == "flux a row short" and n == 0:
        flux = np.zeros((1, 3), np.float32)
    normals = rng.standard_normal((N, 3))
    normals = (normals / np.linalg.norm(normals, axis=1, keepdims=True)).astype(
        np.float64 if fault == "float64 normals" else np.float32)
    rows = rng.integers(0, N, k).astype(np.int64 if fault == "int64 rows" else np.int32)
    if fault == "row past N":
        rows = np.append(rows, N).astype(rows.dtype)
    elif fault == "negative row":
        rows = np.insert(rows, 0, -1).astype(rows.dtype)
    out = rng.standard_normal((N + (fault == "out of N + 1 rows"), 3))
    if fault == "out read-only":
        out.flags.writeable = False
    return dirs, flux, normals, rows, out


@pytest.mark.parametrize("build", ["vector", "scalar"])
@SETTINGS
@given(args=excess_calls())
def test_excess_rows_and_its_twin_agree(builds, build, args):
    c_err, got = _call(builds[build].excess_rows, args, (4,))
    t_err, want = _call(caps.excess_rows_twin, args, (4,))
    if _refused_alike(c_err, t_err):
        return
    got, want = got[1], want[1]
    dirs, flux, normals, rows, out = args
    # Float32 sums of n terms in other orders (the C's four lanes, the twin's BLAS) and a
    # float32 cosine either side: within (n + 4)·2⁻²⁴ of the terms' magnitudes, twice.
    mag = np.abs(normals.astype(np.float64)) @ np.abs(dirs.astype(np.float64)).T  # (N, n)
    bound = np.zeros(out.shape)
    np.add.at(bound, rows, (len(dirs) + 4) * EPS32 * (mag[rows] @ np.abs(flux)))
    assert np.isfinite(got).all()
    assert (np.abs(got - want) <= 2 * bound + 1e-300).all()
    # and the sums are the products they stand for (float64, the same rows)
    exact = out.copy()
    np.add.at(exact, rows, np.maximum(normals.astype(np.float64) @ dirs.T.astype(np.float64),
                                      0.0)[rows] @ flux.astype(np.float64))
    assert (np.abs(got - exact) <= 2 * bound + 1e-9 * np.abs(exact)).all()


FIRST_FAULTS = ["coarse too tall", "coarse too wide", "factor 0", "Y a row short",
                "omega float64", "mid of 4 channels", "luma of 4", "mid not contiguous",
                "Y read-only", "coarse of 2 dims", "Ymax a row short", "Ymax of 2 dims"]


@st.composite
def first_pass_calls(draw):
    """first_pass's eight arguments: half of them right, half with one fault; any mid
    size and factor, a coarse copy of any size that fits (or none)."""
    fault = draw(st.sampled_from(FIRST_FAULTS)) if draw(st.booleans()) else None
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    h, w, f = draw(st.integers(1, 40)), draw(st.integers(1, 40)), draw(st.integers(1, 5))
    mid = (rng.random((h, w, 4 if fault == "mid of 4 channels" else 3)) * 100
           ).astype(np.float32)
    if fault == "mid not contiguous":
        mid = np.repeat(mid, 2, axis=1)[:, ::2]
    scale = draw(st.sampled_from([1.0, 1.0 / 16, 0.37]))
    luma = np.array([0.2126, 0.7152, 0.0722, 0.0][:4 if fault == "luma of 4" else 3],
                    np.float32)
    omega = rng.random((h, w)).astype(np.float64 if fault == "omega float64" else np.float32)
    Y = np.full((h - (fault == "Y a row short"), w), np.nan, np.float32)
    if fault == "Y read-only":
        Y.flags.writeable = False
    coarse = None
    if draw(st.booleans()) or fault in ("coarse too tall", "coarse too wide",
                                        "coarse of 2 dims"):
        hc = draw(st.integers(0, h // f)) + (fault == "coarse too tall")
        wc = draw(st.integers(0, w // f)) + (fault == "coarse too wide")
        coarse = np.full((hc, wc) if fault == "coarse of 2 dims" else (hc, wc, 3), np.nan,
                         np.float32)
    Ymax = np.full((h - (fault == "Ymax a row short"), 2) if fault == "Ymax of 2 dims"
                   else h - (fault == "Ymax a row short"), np.nan, np.float32)
    return mid, scale, luma, omega, Y, coarse, 0 if fault == "factor 0" else f, Ymax


@pytest.mark.parametrize("build", ["vector", "scalar"])
@SETTINGS
@given(args=first_pass_calls())
def test_first_pass_and_its_twin_agree(builds, build, args):
    # got, want: (total, mid, Y, coarse, Ymax)
    c_err, got = _call(builds[build].first_pass, args, (0, 4, 5, 7))
    t_err, want = _call(first_pass_twin, args, (0, 4, 5, 7))
    if _refused_alike(c_err, t_err):
        return
    mid, scale, luma, omega, _, coarse, f, _ = args
    # the scale: one float32 product a sample, the same on both sides
    np.testing.assert_array_equal(got[1], want[1])
    rgb = want[1].astype(np.float64)
    Y = rgb @ luma.astype(np.float64)
    # Y: three float32 products and two sums (OpenCV's order or the C's): 3·2⁻²⁴ of Y
    # (every term non-negative) either side
    np.testing.assert_allclose(got[2], want[2], rtol=8 * EPS32, atol=0)
    np.testing.assert_allclose(got[2], Y, rtol=4 * EPS32, atol=0)
    # the flux: float32 products Y ω summed in float64
    flux = float(Y.reshape(-1) @ omega.reshape(-1).astype(np.float64))
    assert got[0] == pytest.approx(flux, rel=1e-6, abs=1e-30)
    assert want[0] == pytest.approx(flux, rel=1e-6, abs=1e-30)
    # each row's largest Y: exactly the largest of the Y each one wrote (−inf for none)
    for run in (got, want):
        np.testing.assert_array_equal(run[4], np.max(run[2], axis=1, initial=-np.inf))
    if coarse is not None:
        hc, wc = coarse.shape[:2]
        means = rgb[:hc * f, :wc * f].reshape(hc, f, wc, f, 3).mean(axis=(1, 3))
        for c in (got[3], want[3]):
            np.testing.assert_allclose(c, means, rtol=(f * f + 2) * EPS32, atol=0)


@pytest.mark.parametrize("build", ["vector", "scalar"])
def test_a_rows_largest_y_is_never_a_nan(builds, build):
    """A NaN sample (a float frame's, not clamped) is above no threshold, so never a row's
    largest Y: the rest's largest, −inf for a row of NaN alone (C and twin)."""
    mid = np.ones((3, 4, 3), np.float32)
    mid[0, 1] = np.nan
    mid[0, 2] = 5.0
    mid[2] = np.nan
    luma = np.array([0.2126, 0.7152, 0.0722], np.float32)
    for kernel in (builds[build].first_pass, first_pass_twin):
        Y, Ymax = np.empty((3, 4), np.float32), np.empty(3, np.float32)
        kernel(mid.copy(), 1.0, luma, np.ones((3, 4), np.float32), Y, None, 1, Ymax)
        np.testing.assert_array_equal(Ymax, [np.nanmax(Y[0]), Y[1].max(), -np.inf])
        assert Ymax[0] == pytest.approx(5.0 * luma.sum(), rel=1e-6)
