"""`threejs` and `webxr` exports proven with three.js's OWN code (npm three@0.187.0 in node).

tests/node/threejs_eval.mjs runs SphericalHarmonics3.fromArray(sh).getIrradianceAt and
three's XREstimatedLight (fed through a stand-in XRSession/XRFrame: the interface the WebXR
polyfill provides). scripts/test.sh installs three (npm ci --prefix tests/node); without
node or three these tests are skipped with what is missing.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

import consumers as cs
from provider.core.conventions import formats as cv
from provider.core.geometry import sh
from provider.verify import contract
from provider.verify.export_vectors import AXES, OBLIQUE_LIGHT, hemisphere_sh, white

pytestmark = pytest.mark.skipif(cs.three_available() is not None,
                                reason=str(cs.three_available()))

NORMALS = np.vstack([np.eye(3), -np.eye(3)])
RGB = np.array([1.0, 0.5, 0.25])
TOL = 2e-4


def expected(axis):
    return 0.5 * (1 + NORMALS @ axis)[:, None] * RGB[None, :]


def test_three_is_the_pinned_revision():
    out = cs.run_three({"mode": "sh", "sh": [0.0] * 27, "normals": [[0, 1, 0]]})
    pinned = json.loads((cs.NODE_DIR / "package.json").read_text())["dependencies"]["three"]
    assert pinned == "0.187.0" and out["revision"] == "187"   # the revision cited in the code


@pytest.mark.parametrize("name", list(AXES))
def test_threejs_light_probe_lights_the_right_side(name):
    a = AXES[name]
    ex = cv.export(hemisphere_sh(a), "threejs")
    assert len(ex["sh"]) == 27 and ex["quantity"] == "radiance"
    shown = cs.three_shown(ex["sh"], NORMALS)
    i_lit = int(np.argmin(np.linalg.norm(NORMALS - a, axis=1)))
    assert int(np.argmax(shown[:, 0])) == i_lit
    np.testing.assert_allclose(shown, expected(a), rtol=TOL, atol=TOL)   # 0 opposite


def test_threejs_with_directional_lights():
    d, e = OBLIQUE_LIGHT
    amb = hemisphere_sh(AXES["+y"])
    total = amb + cv.light_sh(d, e)
    ex = cv.export(total, "threejs", lights=[(d, e)])
    np.testing.assert_allclose(np.reshape(ex["sh"], (9, 3)), total, atol=1e-12)
    (dl,) = ex["directionalLights"]
    direct = cs.lambert_directional(NORMALS, dl["position"], np.array(dl["color"]) * dl["intensity"])
    np.testing.assert_allclose(cs.three_shown(ex["sh_ambient"], NORMALS) + direct,
                               white(amb, [(d, e)], NORMALS), rtol=TOL, atol=TOL)
    # 'sh' alone: the whole lighting in SH9
    np.testing.assert_allclose(cs.three_shown(ex["sh"], NORMALS),
                               sh.irradiance(total, NORMALS) / math.pi, rtol=TOL, atol=TOL)


@pytest.mark.parametrize("name", list(AXES))
def test_webxr_through_threes_xr_estimated_light(name):
    a = AXES[name]
    ex = cv.export(hemisphere_sh(a), "webxr")
    assert ex["primaryLightDirection"] == {"x": 0.0, "y": 1.0, "z": 0.0, "w": 0.0}
    assert ex["primaryLightIntensity"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
    shown, out = cs.three_xr_shown(ex, NORMALS)
    assert out["estimationStarted"] and out["probeIntensity"] == 1.0
    np.testing.assert_allclose(shown, expected(a), rtol=TOL, atol=TOL)


@pytest.mark.parametrize("name", list(AXES))
def test_webxr_primary_light_through_xr_estimated_light(name):
    """+Y ambient plus a directional light (irradiance > 1: three splits it into colour ×
    intensity) from each axis, rendered as XREstimatedLight builds it."""
    d, e = AXES[name], np.array([4.0, 2.0, 1.0])
    amb = hemisphere_sh(AXES["+y"])
    ex = cv.export(amb + cv.light_sh(d, e), "webxr", lights=[(d, e)])
    np.testing.assert_allclose(np.reshape(ex["sphericalHarmonicsCoefficients"], (9, 3)), amb,
                               atol=1e-12)
    shown, out = cs.three_xr_shown(ex, NORMALS)
    np.testing.assert_allclose(shown, white(amb, [(d, e)], NORMALS), rtol=TOL, atol=TOL)
    # what three.js touched: the interface a polyfill must provide (README)
    touched = set(out["accessed"])
    for member in ("'requestLightProbe' in XRSession", "XRSession.preferredReflectionFormat",
                   "XRSession.requestAnimationFrame", "XRFrame.session", "XRFrame.getLightEstimate",
                   "XRLightEstimate.sphericalHarmonicsCoefficients",
                   "XRLightEstimate.primaryLightDirection", "XRLightEstimate.primaryLightIntensity"):
        assert member in touched, member


def test_golden_vectors_through_three():
    """The committed threejs and webxr vectors, read by three.js, show 'white'."""
    for case in json.loads(contract.VECTORS_PATH.read_text())["exports"]:
        n = np.reshape(case["normals"], (-1, 3))
        want = np.reshape(case["white"], (-1, 3))
        tol = TOL * max(np.abs(want).max(), 1)
        t = case["threejs"]
        shown = cs.three_shown(t["sh_ambient"] if case["lights"] else t["sh"], n)
        for dl in t.get("directionalLights", ()):
            shown += cs.lambert_directional(n, dl["position"], np.array(dl["color"]) * dl["intensity"])
        assert np.abs(shown - want).max() <= tol, (case["name"], "threejs")
        if case["lights"]:
            sh9 = np.reshape(case["white_sh9"], (-1, 3))
            assert np.abs(cs.three_shown(t["sh"], n) - sh9).max() <= tol, case["name"]
        shown, _ = cs.three_xr_shown(case["webxr"], n)
        assert np.abs(shown - want).max() <= tol, (case["name"], "webxr")
