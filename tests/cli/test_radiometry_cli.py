"""``shlight calibrate-response`` and ``shlight compute FRAME@SECONDS ... --camera``:
frames written by a simulated filmic camera, the real command as a subprocess."""
from __future__ import annotations

import json
import subprocess
import sys

import cv2
import numpy as np
import pytest

from provider.bench.camera_sim import CameraSim, auto_exposure
from provider.core.geometry import sh
from provider.core.sh9.engine import SH9Projector
from provider.core.radiometry.response import CameraResponse
from provider.live.wire.message import validate

from conftest import load_hdri

NOISY = dict(shot=5e-5, read=2e-4)


def shlight(*args, timeout=120):
    return subprocess.run([sys.executable, "-m", "provider.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout)


def write_bracket(folder, name, evs, cam=None, bits=8):
    """PNG frames of a panorama at EV offsets around auto exposure: ['PATH@SECONDS', ...]."""
    hdr = np.maximum(load_hdri(name), 0)
    cam = cam or CameraSim(**NOISY)
    frames, times = cam.bracket(hdr, auto_exposure(hdr), evs, bits=bits)
    out = []
    for ev, f, t in zip(evs, frames, times):
        path = folder / f"{name}_{ev:+g}.png"
        assert cv2.imwrite(str(path), np.ascontiguousarray(f[..., ::-1]))
        out.append(f"{path}@{t!r}")
    return out, hdr, cam


def message(p):
    assert p.returncode == 0, p.stderr
    msg = json.loads(p.stdout)
    validate(msg)
    return msg


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cal")
    frames, hdr, cam = write_bracket(folder, "apartment", (-4, -2, 0, 2, 4))
    p = shlight("calibrate-response", *frames, "-o", folder / "camera.json")
    return folder, frames, hdr, cam, p


def test_calibrate_response_recovers_the_camera_curve(calibrated):
    folder, _, _, cam, p = calibrated
    assert p.returncode == 0, p.stderr
    assert "debevec calibration from 5 frames" in p.stdout
    assert "decoding this camera as sRGB would be wrong" in p.stdout
    data = json.loads((folder / "camera.json").read_text())
    response = CameraResponse.from_dict(data)
    assert response.method == "debevec" and len(response.exposure_times) == 5
    assert response.curve_error(cam.true_response(), lo=16, hi=250, fit_scale=False) < 0.02
    png = cv2.imread(str(folder / "camera.png"))
    assert png is not None and png.shape[1] >= 600


def test_compute_one_frame_with_time_and_camera(calibrated):
    folder, frames, hdr, cam, _ = calibrated
    middle = frames[2]
    plain = message(shlight("compute", middle.rsplit("@", 1)[0]))
    assert plain["radiometry"] == "srgb-assumed" and "exposure_s" not in plain
    per_s = message(shlight("compute", middle))
    t = float(middle.rsplit("@", 1)[1])
    assert per_s["exposure_s"] == pytest.approx(t)
    np.testing.assert_allclose(per_s["coefficients"], np.array(plain["coefficients"]) / t,
                               rtol=1e-9)
    cal = message(shlight("compute", middle, "--camera", folder / "camera.json"))
    assert cal["radiometry"] == "calibrated" and cal["response"] == "debevec"
    # a fraction and a decimal of the same time give the same numbers
    path = middle.rsplit("@", 1)[0]
    quarter = message(shlight("compute", f"{path}@1/4", "--camera", folder / "camera.json"))
    decimal = message(shlight("compute", f"{path}@0.25", "--camera", folder / "camera.json"))
    assert quarter["exposure_s"] == 0.25 and quarter["coefficients"] == decimal["coefficients"]


def test_compute_merges_a_bracket_within_the_target(calibrated):
    """5 shots with the calibrated curve: absolute irradiance within 2 % of the HDR truth
    (measured 0.5 %), where the single sRGB-decoded frame is 10-30 % off."""
    folder, frames, hdr, _, _ = calibrated
    merged = message(shlight("compute", *frames, "--camera", folder / "camera.json"))
    assert merged["radiometry"] == "merged" and len(merged["exposures_s"]) == 5
    truth = SH9Projector(512, 256).project(hdr).coefficients
    got = np.array(merged["coefficients"]).reshape(9, 3)
    assert sh.irradiance_error(got, truth) < 0.02
    single = message(shlight("compute", frames[2]))
    assert sh.irradiance_error(np.array(single["coefficients"]).reshape(9, 3), truth) > 0.1


def test_export_takes_the_same_bracket_as_compute(calibrated):
    """`shlight export` has compute's input: the merged bracket's lighting, in three.js's
    layout (its `sh` is our radiance SH9, the whole lighting)."""
    folder, frames, _, _, _ = calibrated
    merged = message(shlight("compute", *frames, "--camera", folder / "camera.json"))
    out = message(shlight("export", *frames, "--camera", folder / "camera.json", "--to",
                          "threejs"))
    assert out["type"] == "export" and out["format"] == "threejs"
    np.testing.assert_allclose(out["sh"], merged["coefficients"], rtol=1e-9)


def test_a_sun_that_clips_in_every_exposure_shows(tmp_path):
    frames, _, cam = write_bracket(tmp_path, "sky", (-6, -4, -2, 0, 2, 4, 6))
    cal = tmp_path / "true.json"
    cal.write_text(json.dumps(cam.true_response().to_dict()))
    msg = message(shlight("compute", *frames, "--camera", cal))
    assert 0 < msg["clipped_fraction"] < 1e-3        # the disc: a few samples ...
    assert msg["clipped_light_fraction"] > 0.02      # ... and a large share of the light


def test_a_path_with_an_at_sign(tmp_path):
    img = np.full((32, 64, 3), 100, np.uint8)
    literal = tmp_path / "shot@2"                     # a file really named like a time
    assert cv2.imwrite(str(tmp_path / "tmp.png"), img)
    (tmp_path / "tmp.png").rename(literal)
    assert "exposure_s" not in message(shlight("compute", literal))
    msg = message(shlight("compute", f"{literal}@1/50"))
    assert msg["exposure_s"] == pytest.approx(0.02)
    named = tmp_path / "room@home.png"
    assert cv2.imwrite(str(named), img)
    assert "exposure_s" not in message(shlight("compute", named))


def _png(path, shape=(32, 64, 3), dtype=np.uint8, value=100):
    assert cv2.imwrite(str(path), np.full(shape, value, dtype))
    return str(path)


@pytest.mark.parametrize("case,needle", [
    ("sizes", "one static view"),
    ("missing_time", "needs its exposure time"),
    ("empty_time", "missing exposure time"),
    ("zero_time", "positive"),
    ("fraction_zero", "divides by zero"),
    ("bad_time", "no such file"),
    ("two_to_calibrate", "at least 3 frames"),
    ("not_monotone", "not monotone"),
    ("corrupt_json", "not JSON"),
    ("nan_table", "non-finite"),
    ("missing_camera", "no such camera file"),
    ("mixed_bits", "mix pixel types"),
    ("calibrate_16bit", "8-bit"),
    ("float_bracket", "uint8 or uint16"),
])
def test_bad_input_is_one_clear_line(tmp_path, case, needle):
    a, b, c = (_png(tmp_path / f"{n}.png", value=v) for n, v in (("a", 40), ("b", 90), ("c", 160)))
    wide = _png(tmp_path / "wide.png", shape=(64, 128, 3))
    deep = _png(tmp_path / "deep.png", dtype=np.uint16, value=9000)
    good = CameraResponse.gamma(2.2).to_dict()
    cam = tmp_path / "camera.json"
    if case == "not_monotone":
        good["table"]["g"][200] = 0.01
    if case == "nan_table":
        good["table"]["b"][10] = float("nan")
    cam.write_text("{not json" if case == "corrupt_json" else json.dumps(good))
    args = {
        "sizes": ["compute", f"{a}@0.01", f"{wide}@0.04"],
        "missing_time": ["compute", f"{a}@0.01", b],
        "empty_time": ["compute", f"{a}@"],
        "zero_time": ["compute", f"{a}@0", f"{b}@0.04"],
        "fraction_zero": ["compute", f"{a}@1/0"],
        "bad_time": ["compute", f"{a}@1/6o"],
        "two_to_calibrate": ["calibrate-response", f"{a}@0.01", f"{b}@0.04", "-o", cam],
        "not_monotone": ["compute", f"{a}@0.01", "--camera", cam],
        "corrupt_json": ["compute", a, "--camera", cam],
        "nan_table": ["compute", a, "--camera", cam],
        "missing_camera": ["compute", a, "--camera", tmp_path / "none.json"],
        "mixed_bits": ["compute", f"{a}@0.01", f"{deep}@0.04"],
        "calibrate_16bit": ["calibrate-response", f"{deep}@0.01", f"{deep}@0.04",
                            f"{deep}@0.16", "-o", tmp_path / "x.json"],
        "float_bracket": ["compute", f"{tmp_path / 'f.exr'}@0.01", f"{tmp_path / 'f.exr'}@0.02"],
    }[case]
    if case == "float_bracket":
        hdr = tmp_path / "f.hdr"
        cv2.imwrite(str(hdr), np.ones((32, 64, 3), np.float32))
        args = ["compute", f"{hdr}@0.01", f"{hdr}@0.02"]
    p = shlight(*args)
    assert p.returncode == 2, (p.stdout, p.stderr)
    assert needle in p.stderr, p.stderr
    assert "Traceback" not in p.stderr and p.stdout == ""
    assert len(p.stderr.strip().splitlines()) == 1 or case in ("two_to_calibrate",
                                                                "calibrate_16bit")


def test_bench_radiometry_writes_a_table_and_a_plot(tmp_path):
    p = shlight("bench", "--quick", "--sections", "radiometry", "--out", tmp_path, timeout=600)
    assert p.returncode == 0, p.stderr[-2000:]
    table = (tmp_path / "radiometry.md").read_text()
    for needle in ("1 sRGB-assumed", "1 calibrated", "7 merged", "Choosing the live default",
                   "× single-frame exact", "| sky |"):
        assert needle in table
    assert (tmp_path / "radiometry.png").stat().st_size > 10_000
