"""Colour and absolute scale through an 8-bit camera whose tone curve is not sRGB
(docs/photometry.md, "Through an 8-bit camera"): calibrated once with ``shlight
calibrate-response BRACKET --lux E`` on one room, then ``shlight compute`` of other rooms'
stills whose exposure comes from their EXIF alone, at other ISOs and f-numbers.

The camera, the rooms and the truth are provider/bench/photometry_8bit.py's (which measures
the same cases): CameraSim's filmic curve with a shoulder that clips 2.5 EV above
mid-grey, shot and read noise, channels of their own contrast and toe; rooms none of the
nine shared panoramas is (each re-lit, turned and tinted, or analytic); the truth is the
float panorama's own light. Its stills are JPEGs without chroma subsampling (4:4:4; what
4:2:0 costs is measured in the docs) with EXIF written byte by byte (tests/exiftools.py)."""
from __future__ import annotations

import json
import subprocess
import sys

import cv2
import numpy as np
import pytest

from provider.bench.camera_sim import CameraSim
from provider.bench.photometry_8bit import (CAMERA, CAMERA_K, analytic_room,
                                            exact_illuminance_up, room, true_cct)
from provider.core.radiometry.bracket import hat_weights, merge
from provider.core.radiometry.photometry import luminance
from provider.core.radiometry.response import CameraResponse
from provider.core.radiometry.response_fit import calibrate_best

from exiftools import exposure_exif, jpeg_with_exif

FULL_CHROMA = cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444


def shlight(*args):
    return subprocess.run([sys.executable, "-m", "provider.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=300)


def message(p) -> dict:
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


def stills(folder, name, hdr, evs, n, iso, *, bias_ev=0.0, seed=0, times_off=None):
    """JPEG stills of a bracket around the metered exposure (mean luminance to mid-grey,
    K = 12.5) × 2**bias_ev at f/n, ISO iso, their exposure in EXIF alone; ``times_off``
    {index: factor}: an EXIF time that is not what the camera did."""
    cam = CameraSim(gain=CAMERA_K * (iso / 100.0) / n ** 2, seed=seed, **CAMERA)
    t0 = 12.5 * n ** 2 / (float(luminance(hdr.reshape(-1, 3)).mean()) * iso) * 2 ** bias_ev
    frames, times = cam.bracket(hdr, t0, evs)
    paths = []
    for i, (ev, f, t) in enumerate(zip(evs, frames, times)):
        path = folder / f"{name}_{ev:+g}.jpg"
        said = t * (times_off or {}).get(i, 1.0)
        jpeg_with_exif(path, exposure_exif(said, n, iso), rgb=f, sampling=FULL_CHROMA)
        paths.append(path)
    return paths


@pytest.fixture(scope="module")
def camera(tmp_path_factory):
    """camera.json from one ±4 EV bracket (2 EV steps) of one room at f/2, ISO 100, and an
    up-facing lux meter's reading; (its path, calibrate-response's output)."""
    folder = tmp_path_factory.mktemp("camera")
    hdr = room("apartment", 11)
    paths = stills(folder, "cal", hdr, (-4, -2, 0, 2, 4), 2.0, 100)
    p = shlight("calibrate-response", *paths, "--lux", exact_illuminance_up(hdr),
                "-o", folder / "camera.json")
    assert p.returncode == 0, p.stderr
    return folder / "camera.json", p


# -- the calibration ------------------------------------------------------------------------------

def test_calibrate_response_says_how_far_its_frames_disagree(camera):
    path, p = camera
    params = json.loads(path.read_text())["params"]
    stops = params["frame_disagreement_stops"]
    assert len(stops) == 5 and all(abs(v) < 0.05 for v in stops), stops
    assert "they agree within" in p.stdout and "warning" not in p.stderr
    # each channel's own trusted codes hold the codes every channel is trusted on
    lo, hi = params["trusted_codes"]
    assert all(a <= lo and b >= hi for a, b in params["trusted_codes_rgb"])


def test_a_frame_whose_exif_time_is_wrong_is_warned(tmp_path):
    """One frame of the bracket says 1/3 stop more than the camera gave it (a wrong or
    rounded EXIF): calibrate-response names it, with how far it is, and still writes."""
    hdr = room("venice", 12)
    paths = stills(tmp_path, "cal", hdr, (-4, -2, 0, 2, 4), 2.0, 100, times_off={3: 2 ** (1 / 3)})
    p = shlight("calibrate-response", *paths, "--lux", exact_illuminance_up(hdr),
                "-o", tmp_path / "camera.json")
    assert p.returncode == 0, p.stderr
    warned = [line for line in p.stderr.splitlines() if ": warning: " in line]
    assert any(line.startswith(f"shlight calibrate-response: warning: {paths[3].name} is -0.")
               and "stops" in line and "absolute scale" in line for line in warned), p.stderr
    stops = json.loads((tmp_path / "camera.json").read_text())["params"][
        "frame_disagreement_stops"]
    assert stops[3] < -0.1 and abs(stops[3]) == max(abs(v) for v in stops)


def test_calibration_keeps_no_ripple_the_frames_cannot_see():
    """A bracket of equal 2 EV steps cannot tell a curve from one rippled with a period of
    one step; the noise had set a ±15 % ripple, different per channel. The curve kept is
    within 2 % RMS of the camera's own over the codes it trusts."""
    cam = CameraSim(**CAMERA)
    hdr = room("forest", 13)
    frames, times = cam.bracket(hdr, 0.18 / float(np.median(hdr.mean(axis=-1))),
                                (-4, -2, 0, 2, 4))
    response = calibrate_best(frames, times)
    lo, hi = response.params["trusted_codes"]
    ratio = response.table[lo:hi + 1] / cam.true_response().table[lo:hi + 1]
    ratio /= np.exp(np.log(ratio).mean(axis=0))         # the curve's scale is the anchor's
    assert np.sqrt(np.mean((ratio - 1) ** 2, axis=0)).max() < 0.02


def test_each_channel_weighs_on_its_own_trusted_codes():
    w = hat_weights(8, [[10, 250], [20, 240], [40, 200]])
    assert w.shape == (256, 3)
    z = np.arange(256)
    for c, (lo, hi) in enumerate([[10, 250], [20, 240], [40, 200]]):
        inside = (z >= lo) & (z <= hi)
        assert np.array_equal(w[inside, c], np.minimum(z, 255 - z)[inside])
        assert np.all(w[~inside, c] <= 1e-3 * 128)


# -- the absolute scale ------------------------------------------------------------------------

@pytest.mark.parametrize("name,seed,n,iso,bias", [
    ("forest", 1, 5.6, 400, 0.0), ("lab", 2, 2.8, 800, 0.7), ("venice", 3, 8.0, 200, -1.3),
    ("night", 4, 2.8, 800, 0.0)])
def test_lux_of_7_shot_brackets_from_exif_alone(camera, tmp_path, name, seed, n, iso, bias):
    """±6 EV in 2 EV steps, another room, ISO and f-number than the calibration's ±4 EV:
    within 3 % of what a lux meter reads (measured: 1.6 % at worst, lab's tubes)."""
    path, _ = camera
    hdr = room(name, seed)
    paths = stills(tmp_path, name, hdr, (-6, -4, -2, 0, 2, 4, 6), n, iso, bias_ev=bias, seed=3)
    msg = message(shlight("compute", *paths, "--camera", path))
    assert msg["coefficient_units"] == "cd/m²" and msg["f_number"] == pytest.approx(n)
    assert msg["illuminance_lux"] == pytest.approx(exact_illuminance_up(hdr), rel=0.03)


@pytest.mark.parametrize("n,iso", [(5.6, 400), (2.8, 1600), (11.0, 100)])
def test_lux_of_one_still_at_another_iso_and_aperture(camera, tmp_path, n, iso):
    """A still that holds the whole room (nothing clipped, little in the toe) is as
    absolute as a bracket: the constant carries to any ISO and f-number."""
    path, _ = camera
    hdr = analytic_room()
    (one,) = stills(tmp_path, "one", hdr, (0,), n, iso, seed=4)
    msg = message(shlight("compute", one, "--camera", path))
    assert msg.get("clipped_fraction", 0) == 0
    assert msg["illuminance_lux"] == pytest.approx(exact_illuminance_up(hdr), rel=0.03)


def test_a_sample_a_shorter_frame_proves_clipped_weighs_nothing():
    """A JPEG rings at the edge of a lamp clipped in the long frames and decodes codes just
    below the top there (here 250 and 252, where the sensor clipped); the shorter frame
    measured the lamp (code 200) above what the long frame can measure, so the long
    frame's samples are clipped whatever their codes: the lamp keeps the short frame's
    light. A sample the shorter frame does not prove clipped is merged as before."""
    response = CameraSim(**CAMERA).true_response()
    response.params["trusted_codes"] = [16, 250]
    g = response.table
    short = np.array([[[200, 200, 200], [60, 60, 60]]], np.uint8)
    long_ = np.array([[[250, 252, 250], [150, 150, 150]]], np.uint8)
    assert g[200, 0] > g[250, 0] / 4                   # the short frame proves it clipped
    merged = merge([short, long_], [1.0, 4.0], response).radiance
    assert merged[0, 0] == pytest.approx(g[200], rel=1e-6)
    w = np.minimum(np.array([60, 150]), 255 - np.array([60, 150]))
    both = (w[0] * g[60] + w[1] * g[150] / 4) / w.sum()
    assert merged[0, 1] == pytest.approx(both, rel=1e-6)


# -- colour ------------------------------------------------------------------------------------

@pytest.mark.parametrize("name,seed,kelvin", [
    ("forest", 1, 2700), ("forest", 1, 6500), ("venice", 3, 4000), ("night", 4, 2700),
    ("night", 4, 5000), ("city", 5, 6500)])
def test_cct_of_tinted_rooms_through_3_shot_brackets(camera, tmp_path, name, seed, kelvin):
    """−4, 0, +4 EV of a room tinted to a blackbody: cct_k within 2 % of the float
    panorama's (measured: 1.2 % at worst). Before, a ripple of the calibrated curve,
    different per channel, put a 2,700 K room at 3,218 K."""
    path, _ = camera
    hdr = room(name, seed, kelvin)
    paths = stills(tmp_path, name, hdr, (-4, 0, 4), 4.0, 200, seed=5)
    msg = message(shlight("compute", *paths, "--camera", path))
    assert msg["cct_k"] == pytest.approx(true_cct(hdr), rel=0.02)


def test_a_response_without_trusted_codes_still_merges():
    """camera.json files from before trusted codes (and sRGB) merge as they did."""
    frames = [np.full((4, 8, 3), v, np.uint8) for v in (40, 120, 220)]
    radiance = merge(frames, [0.25, 1.0, 4.0], CameraResponse.srgb()).radiance
    assert np.all(np.isfinite(radiance)) and np.all(radiance > 0)
