"""Calibration on real photographs (tests/data/bracket_stlouis: four exposures of a night
view by a real camera, CC BY-SA 3.0, see its README): the curve ``calibrate-response``
writes explains its own frames at least as well as assuming sRGB in every code range and
better in the mid-tones, it says so, and bad calibration input is one line, exit 2, no
camera.json."""
from __future__ import annotations

import json
import os
from pathlib import Path

import cv2
import numpy as np
import pytest

from provider.core.radiometry.images import read_image
from provider.core.radiometry.response import CameraResponse
from provider.core.radiometry.response_fit import (CODE_RANGES, calibrate_best, disagreement,
                                                   extrapolate)

from servertools import run_cli

DATA = os.path.join(str(Path(__file__).resolve().parents[2]), "data", "bracket_stlouis")
BRACKET = (("ev-4.72.jpg", "1/30"), ("ev-1.82.jpg", "1/4"), ("ev+1.51.jpg", "2.5"),
           ("ev+4.09.jpg", "15"))
TIMES = [1 / 30, 0.25, 2.5, 15.0]


@pytest.fixture(scope="module")
def real_frames():
    return [read_image(os.path.join(DATA, f)) for f, _ in BRACKET]


@pytest.fixture(scope="module")
def calibrated(real_frames):
    return calibrate_best(real_frames, TIMES)


def test_real_bracket_curve_explains_its_frames_at_least_as_well_as_srgb(calibrated):
    q = calibrated.params["quality"]
    for name, _, _ in CODE_RANGES:
        mine, srgb = q["curve"][name], q["srgb"][name]
        assert mine["pairs"] > 1000, name
        assert mine["median"] <= srgb["median"] * 1.001, (name, mine, srgb)
        assert mine["p90"] <= srgb["p90"] * 1.001, (name, mine, srgb)
    # the mid-tones, where most light is: far better (sRGB is 148 % off here, a JPEG tone
    # curve is not sRGB)
    assert q["curve"]["mid-tones"]["median"] < 0.5 * q["srgb"]["mid-tones"]["median"]
    lo, hi = calibrated.params["trusted_codes"]
    assert 1 <= lo < 64 and 192 < hi <= 254
    assert calibrated.params["fit"]["beats_srgb"]
    assert np.all(np.diff(calibrated.table, axis=0) > 0)       # monotone, every code


def test_disagreement_is_zero_for_the_curve_that_made_the_frames():
    """The measure itself: frames made by a known curve agree exactly with that curve, and
    a wrong curve (sRGB for a gamma 1.6 camera) is caught in every code range it reaches."""
    rng = np.random.default_rng(2)
    radiance = np.exp(rng.uniform(-5, 2, (120, 160, 3)))
    times = np.array([1 / 8, 1 / 4, 1 / 2, 1, 2])
    gamma = 1.6
    frames = [np.clip(np.round(255 * np.clip(radiance * t, 0, 1) ** (1 / gamma)), 0, 255)
              .astype(np.uint8) for t in times]
    true = CameraResponse.gamma(gamma).table
    exact = disagreement(true, frames, times)
    wrong = disagreement(CameraResponse.srgb().table, frames, times)
    for name in ("shadows", "mid-tones", "highlights"):
        assert exact[name]["median"] < 0.02, (name, exact[name])     # code rounding only
        assert wrong[name]["median"] > 2 * exact[name]["median"], name


def test_robust_fit_recovers_the_curve_despite_pixels_no_curve_explains():
    """The fit on all pixel pairs (``_pairs_l1``) recovers a known curve to within 1 % where
    a third of the view is film fog (one code whatever the exposure: no curve can explain
    those pairs, and a least-squares fit on them is pulled towards them)."""
    from provider.core.radiometry.response_fit import L1_LAMBDAS, _pairs_l1, pair_histograms
    rng = np.random.default_rng(2)
    radiance = np.exp(rng.uniform(-5, 2, (120, 160, 3)))
    times = np.array([1 / 8, 1 / 4, 1 / 2, 1, 2])
    frames = [np.clip(np.round(255 * np.clip(radiance * t, 0, 1) ** (1 / 1.6)), 0, 255)
              .astype(np.uint8) for t in times]
    fog = rng.random((120, 160)) < 0.35
    for f in frames:
        f[fog] = 30 + rng.integers(-1, 2, (int(fog.sum()), 3))
    true = CameraResponse.gamma(1.6).table
    pairs = pair_histograms(np.stack([f.reshape(-1, 3) for f in frames]), times)
    for lam in L1_LAMBDAS:
        r = _pairs_l1(pairs, lam)[40:231] / true[40:231]
        r /= np.exp(np.log(r).mean(axis=0))
        assert np.sqrt(np.mean((r - 1) ** 2)) < 0.01, lam
        assert np.all(np.diff(_pairs_l1(pairs, lam)[40:231], axis=0) > 0), lam


def test_extrapolation_beyond_the_trusted_codes_is_monotone():
    table = np.repeat(np.linspace(0.01, 1, 256)[:, None] ** 2, 3, axis=1)
    table[:20] = 0.5            # garbage below the trusted range
    table[240:] = 1e-3          # and above
    for shape in ("log-linear", "srgb"):
        out = extrapolate(table, 20, 239, shape=shape)
        assert np.all(np.diff(out, axis=0) > 0), shape
        assert np.allclose(out[20:240], table[20:240], rtol=1e-12)


def test_calibrate_response_reports_how_well_the_curve_explains_real_frames(tmp_path):
    out = tmp_path / "camera.json"
    res = run_cli("calibrate-response", *(f"{DATA}/{f}@{t}" for f, t in BRACKET),
                  "-o", str(out), timeout=180)
    assert res.returncode == 0, res.stderr
    assert "how well the curve explains its frames" in res.stdout
    assert "trusted codes" in res.stdout and "mid-tones" in res.stdout
    data = json.loads(out.read_text())
    assert data["params"]["quality"]["curve"]["mid-tones"]["pairs"] > 0
    assert (tmp_path / "camera.png").exists()


def _refused(res, *words, not_written=()):
    assert res.returncode == 2, (res.stdout, res.stderr)
    assert "Traceback" not in res.stderr
    lines = [l for l in res.stderr.strip().splitlines() if not l.endswith("...")]
    assert len(lines) == 1, res.stderr
    for w in words:
        assert w in lines[0], lines[0]
    for path in not_written:
        assert not os.path.exists(path), path
    return lines[0]


@pytest.fixture(scope="module")
def bad_frames(tmp_path_factory):
    d = tmp_path_factory.mktemp("badcal")
    cv2.imwrite(str(d / "black.png"), np.zeros((40, 60, 3), np.uint8))
    cv2.imwrite(str(d / "white.png"), np.full((40, 60, 3), 255, np.uint8))
    rng = np.random.default_rng(0)
    cv2.imwrite(str(d / "same.png"), rng.integers(20, 230, (40, 60, 3), dtype=np.uint8))
    return d


@pytest.mark.parametrize("extra, words", [
    (["--method", "debevec", "--lambda", "nan"], ["--lambda", "finite"]),
    (["--method", "debevec", "--lambda", "inf"], ["--lambda", "finite"]),
    (["--method", "debevec", "--lambda", "0"], ["--lambda", "above 0"]),
    (["--method", "debevec", "--lambda", "-3"], ["--lambda", "above 0"]),
    (["--lambda", "50"], ["--lambda", "--method auto"]),
    (["--samples", "0"], ["--samples", "at least 10"]),
    (["--samples", "100000000"], ["--samples 100000000", "pixels"]),
])
def test_calibrate_response_refuses_bad_options_before_writing(tmp_path, extra, words):
    out = tmp_path / "camera.json"
    res = run_cli("calibrate-response", *(f"{DATA}/{f}@{t}" for f, t in BRACKET),
                  "-o", str(out), *extra, timeout=60)
    _refused(res, *words, not_written=(out, tmp_path / "camera.png"))


@pytest.mark.parametrize("frames, words", [
    (["black.png@1/100", "black.png@1/50", "black.png@1/25"], ["no frame has a usable code"]),
    (["white.png@1/100", "white.png@1/50", "white.png@1/25"], ["no frame has a usable code"]),
    (["same.png@1/100", "same.png@1/50", "same.png@1/25"], ["do not get brighter"]),
])
def test_calibrate_response_refuses_frames_no_curve_can_come_from(tmp_path, bad_frames,
                                                                  frames, words):
    out = tmp_path / "camera.json"
    res = run_cli("calibrate-response", *(str(bad_frames / f) for f in frames), "-o", str(out))
    _refused(res, *words, not_written=(out,))


def test_calibrate_response_refuses_an_output_in_a_missing_folder(tmp_path):
    out = tmp_path / "nowhere" / "camera.json"
    res = run_cli("calibrate-response", *(f"{DATA}/{f}@{t}" for f, t in BRACKET), "-o", str(out))
    _refused(res, "no folder", not_written=(out,))


def test_calibrate_response_warns_when_no_curve_beats_srgb_everywhere(calibrated):
    """What a person reads when the chosen curve is worse than sRGB in some code range."""
    from provider.cli.calibrate import quality_lines
    params = json.loads(json.dumps(calibrated.params))
    assert not any(l.startswith("warning") for l in quality_lines(calibrated))
    params["fit"]["beats_srgb"] = False
    params["quality"]["curve"]["shadows"]["median"] = \
        params["quality"]["srgb"]["shadows"]["median"] + 0.1
    worse = CameraResponse(calibrated.table, method="debevec", params=params)
    warning = [l for l in quality_lines(worse) if l.startswith("warning")]
    assert len(warning) == 1 and "worse in: shadows)" in warning[0], warning
