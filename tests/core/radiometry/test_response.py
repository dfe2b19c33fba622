"""The camera response and bracket maths (provider.core.radiometry.response, provider.core.radiometry.bracket)
with a simulated filmic camera (provider.bench.camera_sim) on the real panoramas.

Tolerances are the measured values (``shlight bench --sections radiometry``) with a margin.
"""
from __future__ import annotations

import copy
import json
from functools import lru_cache

import numpy as np
import pytest

from provider import InputError
from provider.bench.camera_sim import CameraSim, auto_exposure
from provider.core.radiometry import bracket as B
from provider.core.radiometry import response as R
from provider.core.geometry import sh
from provider.core.sh9.engine import SH9Projector

from conftest import load_hdri


@lru_cache(maxsize=None)
def panorama(name):
    return np.maximum(np.nan_to_num(load_hdri(name)), 0).astype(np.float32)


NOISY = dict(shot=5e-5, read=2e-4)


@lru_cache(maxsize=None)
def calibrated(name, noisy=True):
    cam = CameraSim(**NOISY) if noisy else CameraSim()
    hdr = panorama(name)
    frames, times = cam.bracket(hdr, auto_exposure(hdr), (-4, -2, 0, 2, 4), seed=5)
    return cam, R.calibrate(frames, times)


def sh_errors(rad, hdr):
    """(absolute, shape) relative RMS SH9 irradiance error against the HDR truth."""
    P = SH9Projector(hdr.shape[1], hdr.shape[0])
    E = sh.sphere_irradiance(P.project(rad.astype(np.float32)).coefficients)
    T = sh.sphere_irradiance(P.project(hdr).coefficients)
    s = (E * T).sum() / (E * E).sum()
    return sh.relative_rms(E, T), sh.relative_rms(s * E, T)


def synthetic_scene(h=64, w=128, seed=0):
    """A smooth HDR test scene spanning ~10 stops, plus a small very bright patch."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w] / np.array([h, w])[:, None, None]
    base = 0.18 * 2.0 ** (10 * (x - 0.5))[..., None] * np.array([1.0, 0.9, 0.8])
    base = base * (1 + 0.2 * np.sin(6 * y))[..., None]
    base[:4, :4] = 5000.0
    return (base * (1 + 0.01 * rng.standard_normal(base.shape))).astype(np.float32)


# -- tables ------------------------------------------------------------------------------------

def test_srgb_table_matches_engine():
    from provider.core.sh9.engine import srgb_to_linear
    r = R.CameraResponse.srgb()
    assert r.bits == 8 and r.method == "srgb" and r.channels_identical
    np.testing.assert_allclose(r.table[:, 0], srgb_to_linear(np.arange(256) / 255), rtol=0)
    assert r.lut().shape == (256,)
    r16 = R.CameraResponse.srgb(16)
    assert r16.table.shape == (65536, 3)
    np.testing.assert_allclose(r16.table[::257, 1], r.table[:, 1], rtol=1e-12)


def test_gamma_table_anchored_at_mid_grey():
    r = R.CameraResponse.gamma(2.2)
    assert r.table[118, 0] == pytest.approx(0.18)
    assert r.table[255, 2] == pytest.approx(0.18 / (118 / 255) ** 2.2)
    with pytest.raises(R.ResponseError):
        R.CameraResponse.gamma(-1)


def test_sim_true_curve_is_not_srgb_and_hits_mid_grey():
    cam = CameraSim()
    tr = cam.true_response()
    assert np.allclose(tr.table[118], 0.18, rtol=1e-9)
    assert not tr.channels_identical
    # decoding this camera as sRGB is wrong by > 10 % over codes 16..250
    assert R.CameraResponse.srgb().curve_error(tr, lo=16, hi=250, fit_scale=False) > 0.10
    # round trip of the tone curve
    X = np.array([[0.001, 0.18, 1.5]]).T.repeat(3, 1)
    np.testing.assert_allclose(cam.inverse_tone(cam.tone(X)), X, rtol=1e-9)


def test_16bit_tables_and_frames():
    cam = CameraSim()
    hdr = synthetic_scene()
    t = auto_exposure(hdr)
    f16 = cam.capture(hdr, t, bits=16)
    assert f16.dtype == np.uint16
    tr16 = cam.true_response(bits=16)
    lin = tr16.linearise(f16, t)
    ok = (f16 > 2000) & (f16 < 63000)
    np.testing.assert_allclose(lin[ok], hdr[ok], rtol=2e-3)
    # an 8-bit calibration serves a 16-bit stream through to_bits(16)
    r16 = cam.true_response().to_bits(16)
    assert r16.bits == 16
    np.testing.assert_allclose(r16.table[::257], cam.true_response().table, rtol=1e-9)
    np.testing.assert_allclose(r16.table[30000], tr16.table[30000], rtol=2e-3)
    with pytest.raises(R.ResponseError, match="to_bits"):
        cam.true_response().linearise(f16, t)


# -- calibration -------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["apartment", "lab", "night"])
@pytest.mark.parametrize("noisy", [False, True])
def test_calibration_recovers_known_non_srgb_curve(name, noisy):
    """Debevec (150 samples, λ 50) on a 5-shot bracket: codes 16..250 within 2 % of the true
    curve with the mid-grey normalisation alone (measured: 0.2-1.4 %)."""
    cam, cal = calibrated(name, noisy)
    tr = cam.true_response()
    assert cal.method == "debevec"
    assert cal.curve_error(tr, lo=16, hi=250, fit_scale=False) < 0.02
    np.testing.assert_allclose(cal.table[118], 0.18, rtol=0.01)
    cal.validate()
    assert np.all(np.diff(cal.table, axis=0) > 0)  # strictly increasing after the repair


def test_robertson_also_runs_but_is_less_accurate():
    cam = CameraSim()
    hdr = panorama("apartment")
    frames, times = cam.bracket(hdr, auto_exposure(hdr), (-4, -2, 0, 2, 4))
    rob = R.calibrate(frames, times, "robertson")
    deb = R.calibrate(frames, times, "debevec")
    tr = cam.true_response()
    e_rob = rob.curve_error(tr, lo=16, hi=250, fit_scale=False)
    e_deb = deb.curve_error(tr, lo=16, hi=250, fit_scale=False)
    assert np.all(np.isfinite(rob.table)) and e_rob < 0.10
    assert e_deb < e_rob


# -- merging ------------------------------------------------------------------------------------

@pytest.mark.parametrize("name,limit", [("apartment", 0.02), ("bridge", 0.02), ("venice", 0.03),
                                        ("dawn", 0.03), ("night", 0.03), ("lab", 0.10)])
def test_merge_accuracy_on_panoramas(name, limit):
    """7 shots 2 EV apart merged with the calibrated curve meet the issue's targets
    (measured 0.2-0.8 %), and beat the single frame by far."""
    cam, cal = calibrated(name)
    hdr = panorama(name)
    t0 = auto_exposure(hdr)
    frames, times = cam.bracket(hdr, t0, (-6, -4, -2, 0, 2, 4, 6), seed=7)
    m = B.merge(frames, times, cal)
    assert m.radiance.dtype == np.float32 and m.radiance.shape == hdr.shape
    a, s = sh_errors(m.radiance, hdr)
    assert s <= limit and a <= limit + 0.02  # absolute too: the exposure time is known
    single_a, _ = sh_errors(cal.linearise(frames[3], times[3]), hdr)
    assert a < single_a
    # the linear live path agrees with the exact hat merge
    p = B.merge_partition(frames, times, cal)
    a_p, s_p = sh_errors(p.radiance, hdr)
    assert s_p <= limit


def test_sun_is_reported_as_clipped_in_every_frame():
    cam, cal = calibrated("sky")
    hdr = panorama("sky")
    frames, times = cam.bracket(hdr, auto_exposure(hdr), (-6, -4, -2, 0, 2, 4, 6))
    m = B.merge(frames, times, cal)
    assert m.clipped_fraction > 0  # the disc: light never measured, and we say so
    _, s = sh_errors(m.radiance, hdr)
    assert s > 0.2
    # clipped samples carry the shortest frame's clip level (a lower bound), not 0
    clipped = np.minimum.reduce(frames) == 255
    np.testing.assert_allclose(m.radiance[clipped], (cal.table[255] / min(times))[
        np.nonzero(clipped)[2]], rtol=1e-5)


def test_two_exposures_agree_after_normalisation():
    """Where neither frame clips (codes 20..235 in both), radiance per second of exposure
    agrees between frames 2 EV apart, with the true and with the calibrated curve."""
    cam, cal = calibrated("apartment")
    hdr = panorama("apartment")
    t = auto_exposure(hdr)
    (a, b), (ta, tb) = cam.bracket(hdr, t, (-1, 1), seed=3)
    ok = (a >= 20) & (a <= 235) & (b >= 20) & (b <= 235)
    assert ok.mean() > 0.3
    for resp, tol in ((cam.true_response(), 0.01), (cal, 0.02)):
        ra, rb = resp.linearise(a, ta), resp.linearise(b, tb)
        ratio = rb[ok] / ra[ok]
        assert abs(np.median(ratio) - 1) < tol
        assert abs(ra[ok].sum() / rb[ok].sum() - 1) < tol
    # sRGB decoding of the same frames does not agree: the curve is wrong
    s = R.CameraResponse.srgb()
    r = s.linearise(b, tb)[ok].sum() / s.linearise(a, ta)[ok].sum()
    assert abs(r - 1) > 0.1


def test_clipped_sample_taken_from_other_frames():
    tr = CameraSim().true_response()
    hdr = synthetic_scene()
    cam = CameraSim()
    t = auto_exposure(hdr)
    frames, times = cam.bracket(hdr, t, (-6, -3, 0, 3))
    m = B.merge(frames, times, tr)
    long_clipped = (frames[-1] == 255) & (frames[0] < 200) & (frames[0] > 30)
    assert long_clipped.sum() > 100
    np.testing.assert_allclose(m.radiance[long_clipped], hdr[long_clipped], rtol=0.02)
    assert m.clipped_fraction == pytest.approx(np.mean(np.minimum.reduce(frames) == 255))


def test_linear_bracket_weights_partition_unity():
    cal = CameraSim().true_response()
    times = [0.001 * 4 ** k for k in range(5)]
    w = B.partition_weights(cal, times)
    # a noise-free radiance ramp: the weights of the codes it produces sum to 1
    cam = CameraSim()
    L = np.geomspace(1e-3, 1e4, 4000)[:, None].repeat(3, 1)[None]
    frames = [cam.capture(L, ti) for ti in times]
    total = sum(wi[f[0], [0, 1, 2]] for wi, f in zip(w, frames))
    # longest frame above code ~30, shortest below the shoulder
    inside = (L[0, :, 0] * max(times) > 0.02) & (L[0, :, 0] * min(times) < 1.5)
    np.testing.assert_allclose(total[inside], 1.0, atol=0.03)
    lb = B.LinearBracket(cal, times)
    out = sum(lb.linearise(i, f, ti) for i, (f, ti) in enumerate(zip(frames, times)))
    np.testing.assert_allclose(out[0][inside], L[0][inside], rtol=0.03)
    # the per-slot tables are at t = 1: the exposure only scales
    np.testing.assert_allclose(lb.linearise(2, frames[2], times[2]),
                               R.apply_lut(frames[2], lb.slot_table(2)) / times[2], rtol=1e-6)


def test_merge_opencv_runs_with_calibrated_curve():
    cam = CameraSim()
    hdr = synthetic_scene()
    frames, times = cam.bracket(hdr, auto_exposure(hdr), (-2, 0, 2))
    out = B.merge_opencv(frames, times, cam.true_response())
    assert out.shape == hdr.shape and np.all(np.isfinite(out))


def test_merge_16bit():
    cam = CameraSim()
    hdr = synthetic_scene()
    frames, times = cam.bracket(hdr, auto_exposure(hdr), (-4, 0, 4), bits=16)
    m = B.merge(frames, times, cam.true_response(bits=16))
    ok = np.max(frames, axis=0) < 65535
    np.testing.assert_allclose(m.radiance[ok], hdr[ok], rtol=0.01, atol=1e-4)
    p = B.merge_partition(frames, times, cam.true_response(bits=16))
    ok = (frames[0] < 60000) & (frames[-1] > 3000)
    np.testing.assert_allclose(p.radiance[ok], hdr[ok], rtol=0.01)


# -- camera.json ---------------------------------------------------------------------------------

def test_dict_round_trip_is_json():
    _, cal = calibrated("apartment")
    d = cal.to_dict()
    text = json.dumps(d, allow_nan=False)
    back = R.CameraResponse.from_dict(json.loads(text))
    np.testing.assert_array_equal(back.table, cal.table)
    assert back.method == "debevec" and back.exposure_times == cal.exposure_times
    assert d["version"] == R.FORMAT_VERSION and len(d["table"]["g"]) == 256
    assert back.params["samples"] == cal.params["samples"]


def _good_dict():
    return R.CameraResponse.gamma(2.0).to_dict()


@pytest.mark.parametrize("mutate,match", [
    (lambda d: d["table"]["r"].__setitem__(100, 0.0), "not monotone"),
    (lambda d: d["table"]["g"].__setitem__(5, float("nan")), "non-finite"),
    (lambda d: d["table"]["b"].__setitem__(0, -1.0), "negative"),
    (lambda d: d["table"].pop("b"), "'r', 'g' and 'b'"),
    (lambda d: d["table"].__setitem__("r", d["table"]["r"][:100]), "256 numbers"),
    (lambda d: d["table"]["r"].__setitem__(3, "x"), "not a number"),
    (lambda d: d.__setitem__("version", 99), "version"),
    (lambda d: d.__setitem__("format", "something"), "not a camera response"),
    (lambda d: d.__setitem__("bits", 12), "bits"),
    (lambda d: d.__setitem__("method", "magic"), "unknown response method"),
    (lambda d: d.__setitem__("exposure_times", [0.01, -1]), "positive"),
    (lambda d: d["table"].__setitem__("g", [0.5] * 256), "flat"),
])
def test_corrupt_camera_dict_is_rejected(mutate, match):
    d = copy.deepcopy(_good_dict())
    mutate(d)
    with pytest.raises(R.ResponseError, match=match):
        R.CameraResponse.from_dict(d)


def test_not_a_dict():
    with pytest.raises(R.ResponseError, match="JSON object"):
        R.CameraResponse.from_dict([1, 2, 3])


# -- bad input -----------------------------------------------------------------------------------

def _frames(n=3, shape=(8, 16, 3), dtype=np.uint8):
    rng = np.random.default_rng(0)
    return [rng.integers(0, 200, shape).astype(dtype) for _ in range(n)]


def test_frames_of_different_sizes():
    f = _frames()
    f[1] = f[1][:, :8]
    with pytest.raises(R.ResponseError, match="one static view"):
        B.merge(f, [1, 2, 4], R.CameraResponse.srgb())
    with pytest.raises(R.ResponseError, match="one static view"):
        R.calibrate(f, [1, 2, 4])


@pytest.mark.parametrize("times,match", [
    ([0.01, None, 0.04], "number"), ([0.01, 0.0, 0.04], "positive"),
    ([0.01, -0.02, 0.04], "positive"), ([0.01, float("nan"), 0.04], "positive"),
    ([0.01, float("inf"), 0.04], "positive"), ([0.01, 0.02], "3 frames but 2"),
    (None, "missing")])
def test_missing_zero_negative_time(times, match):
    with pytest.raises(R.ResponseError, match=match):
        B.merge(_frames(), times, R.CameraResponse.srgb())


def test_fewer_than_three_frames_to_calibrate():
    with pytest.raises(R.ResponseError, match="at least 3 frames"):
        R.calibrate(_frames(2), [0.01, 0.04])


def test_calibration_needs_distinct_times():
    with pytest.raises(R.ResponseError, match="1 EV"):
        R.calibrate(_frames(3), [0.01, 0.01, 0.01])


def test_16bit_mixed_with_8bit():
    f = _frames()
    f[2] = f[2].astype(np.uint16) * 257
    with pytest.raises(R.ResponseError, match="mix pixel types"):
        B.merge(f, [1, 2, 4], R.CameraResponse.srgb())
    with pytest.raises(R.ResponseError, match="mix pixel types"):
        R.calibrate(f, [1, 2, 4])


def test_16bit_calibration_and_wrong_response_depth():
    f = _frames(3, dtype=np.uint16)
    with pytest.raises(R.ResponseError, match="8-bit"):
        R.calibrate(f, [1, 2, 4])
    with pytest.raises(R.ResponseError, match="16-bit response"):
        B.merge(f, [1, 2, 4], R.CameraResponse.srgb())


def test_wrong_shapes_and_types():
    with pytest.raises(R.ResponseError, match="H×W×3"):
        B.merge([np.zeros((4, 4), np.uint8)] * 3, [1, 2, 4], R.CameraResponse.srgb())
    with pytest.raises(R.ResponseError, match="uint8 or uint16"):
        B.merge([np.zeros((4, 4, 3), np.float32)] * 3, [1, 2, 4], R.CameraResponse.srgb())
    with pytest.raises(R.ResponseError, match="no frames"):
        B.merge([], [], R.CameraResponse.srgb())
    with pytest.raises(R.ResponseError, match="256 or 65536"):
        R.CameraResponse(np.linspace(0, 1, 100))
    with pytest.raises(R.ResponseError, match="not monotone"):
        R.CameraResponse(np.linspace(1, 0, 256))


def test_response_errors_are_input_errors():
    """The CLI prints an InputError as one line: every radiometry error is one."""
    assert issubclass(R.ResponseError, InputError)


@pytest.mark.parametrize("text,seconds", [("1/60", 1 / 60), ("0.004", 0.004), ("2", 2.0),
                                          (".5", 0.5), ("1/2.5", 0.4), (" 1 / 8 ", 0.125)])
def test_parse_seconds(text, seconds):
    assert R.parse_seconds(text) == pytest.approx(seconds)


@pytest.mark.parametrize("text,match", [("0", "positive"), ("0/5", "positive"),
                                        ("1/0", "divides by zero"), ("", "not a number"),
                                        ("abc", "not a number"), ("-1", "not a number"),
                                        ("1/60s", "not a number")])
def test_parse_seconds_refuses(text, match):
    with pytest.raises(R.ResponseError, match=match):
        R.parse_seconds(text)


def test_shared_curve_for_one_channel_lut():
    g = R.CameraResponse.gamma(2.2)
    s, dev = g.shared()
    assert dev < 1e-12 and s.channels_identical and s.lut().shape == (256,)
    s, dev = CameraSim().true_response().shared()
    assert dev > 0.1  # this simulated camera's channels differ: keep per-channel tables
