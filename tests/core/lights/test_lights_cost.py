"""The lights' cheaper per-frame path computes the same sums as the brute force it replaced:
the candidates' excess irradiance at the normals by regions (linear where a normal sees all
or none of a region) against the full (normals × pixels) kernel, on regions of every shape
the extractor meets (a compact lamp, a wide panel, a region around a pole or across a
lens's edge, pixels scattered over the whole sphere)."""
import math
import threading

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from provider.core.geometry.projections import DualFisheye, Equirect
from provider.core.lights import caps
from provider.core.lights.extractor import LightExtractor


def _regions(x: LightExtractor, rng):
    """(pixels, region labels) of a spread of regions on the extractor's mid copy."""
    dirs, valid = x._dirs, np.flatnonzero(x._omega > 0)
    out_pix, out_lab = [], []

    def cap(axis, deg, label):
        axis = np.asarray(axis, np.float64) / np.linalg.norm(axis)
        pix = valid[dirs[valid] @ axis >= math.cos(math.radians(deg))]
        out_pix.append(pix)
        out_lab.append(np.full(len(pix), label))

    cap([0.3, 0.8, -0.5], 4, 1)          # a lamp
    cap([-0.6, 0.5, 0.6], 28, 2)         # a ceiling panel
    cap([0.0, 1.0, 0.0], 12, 3)          # around the pole / the zenith
    cap([1.0, 0.05, 0.0], 10, 4)         # across a dual fisheye's lens edge
    scattered = rng.choice(valid, 300, replace=False)
    out_pix.append(scattered)
    out_lab.append(np.full(300, 5))      # one "region" over the whole sphere
    pix, lab = np.concatenate(out_pix), np.concatenate(out_lab)
    _, first = np.unique(pix, return_index=True)          # a pixel in one region only
    return pix[first], lab[first]


@pytest.mark.parametrize("kernel", ["built", "twin"])
@pytest.mark.parametrize("projection", [DualFisheye(1280, 720), Equirect(512, 256)],
                         ids=["dual-fisheye", "equirect"])
def test_excess_irradiance_by_regions_is_the_brute_force_sum(projection, kernel, monkeypatch):
    """The caps' sums, through the C kernel (``_lights.excess_rows``) and its numpy twin,
    against the dense float64 kernel."""
    if kernel == "twin":
        monkeypatch.setattr(caps, "_excess_kernel", caps.excess_rows_twin)
    elif not caps.KERNEL:
        pytest.skip("the C kernels were not built (tests/core/kernels/test_kernels.py)")
    x = LightExtractor(projection)
    rng = np.random.default_rng(3)
    pix, region = _regions(x, rng)
    excess = rng.uniform(0.0, 1e4, (len(pix), 3)).astype(np.float32)
    got = x._excess_irradiance(pix, excess, region)
    want = x._brute_kernel(x._dirs[pix], x._omega[pix]) @ excess.astype(np.float64)
    # float32 directions and products in the per-pixel part (as the kernel was before):
    # a few 1e-7 relative a term, summed over ~10⁴ pixels
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-5 * np.abs(want).max())


def test_frames_in_flight_get_the_sums_they_get_alone():
    """Two frames analysed at once on one extractor (threads: the C kernel and BLAS let go
    of the GIL) each get the sums they get alone, bit for bit (the same products in the
    same order, on one BLAS thread as the engine runs them: provider.core.blas): the
    kernel's planes are its call's own, nothing is shared between frames in flight."""
    with threadpool_limits(limits=1, user_api="blas"):
        _two_frames_in_flight()


def _two_frames_in_flight():
    x = LightExtractor(DualFisheye(1280, 720))
    rng = np.random.default_rng(5)
    pix, region = _regions(x, rng)
    inputs = [rng.uniform(0.0, 1e4, (len(pix), 3)).astype(np.float32) for _ in range(2)]
    alone = [x._excess_irradiance(pix, e, region) for e in inputs]
    start = threading.Barrier(2)
    got = [[], []]

    def work(k):
        start.wait()
        for _ in range(20):
            got[k].append(x._excess_irradiance(pix, inputs[k], region))

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for k in range(2):
        assert len(got[k]) == 20
        for g in got[k]:
            np.testing.assert_array_equal(g, alone[k])
