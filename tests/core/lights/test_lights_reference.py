"""The lights a frame yields stay what they were when the per-frame path was made cheaper
(tests/data/lights_reference.npz, recorded by tests/lightrefstools.py before that work):
the lit Theta room through a tracker, bundled panoramas through equirect and through the
Theta fold (float and 8-bit), a sun 10⁴ × its sky, a Pi camera's fisheye with its ground fill,
and frames with no light. The Theta cases were recorded again when its detection copy went
from 4 × 4 to 5 × 5 blocks (issue 44, 2026-11-30): the same candidates, levels and lights in
every frame; directions within 0.34° (0.08° but for the bridge's), irradiance and flux
within 0.7 % of the largest, errors within 2.3e-4."""
import numpy as np
import pytest

from lightrefstools import REFERENCE, cases, flatten, run_case

CASES = cases()

# What may move: float rounding only. The detection copy and the truth are float32 sums over
# ~30k pixels whose order a BLAS or a vectorised rewrite may change (a few 1e-7 relative a
# sum), and directions are unit vectors from such sums; the decisions (which candidates,
# which lights, keys, levels, chains) must be identical.
RTOL = 1e-4          # of the array's largest magnitude (irradiance, flux, ambient)
DIR_ATOL = 1e-5      # unit-vector components: ~0.0006°
DEG_ATOL = 1e-3      # spreads and disc radii, degrees
ERR_ATOL = 1e-5      # relative RMS errors (fractions)
EXACT = ("level", "ident", "candidates")


@pytest.fixture(scope="module")
def reference():
    with np.load(REFERENCE) as z:
        return dict(z)


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_lights_of_a_frame_are_unchanged(name, reference):
    build, frames = CASES[name]
    got = flatten(name, run_case(build, frames))
    want = {k: v for k, v in reference.items() if k.startswith(name + "/")}
    assert set(got) == set(want)
    for key, w in want.items():
        g, kind = got[key], key.rsplit("/", 1)[1]
        assert g.shape == w.shape, key
        if kind in EXACT:
            np.testing.assert_array_equal(g, w, err_msg=key)
        elif kind == "direction":
            np.testing.assert_allclose(g, w, rtol=0, atol=DIR_ATOL, err_msg=key)
        elif kind in ("spread_deg", "angular_radius_deg"):
            np.testing.assert_allclose(g, w, rtol=0, atol=DEG_ATOL, err_msg=key)
        elif kind == "errors":
            np.testing.assert_allclose(g, w, rtol=0, atol=ERR_ATOL, err_msg=key)
        else:
            scale = float(np.abs(w).max()) if w.size else 0.0
            np.testing.assert_allclose(g, w, rtol=0, atol=RTOL * scale + 1e-30, err_msg=key)
