"""Issue 31 part 4: a lux meter closes the clipped sun. One auto-exposed 8-bit frame of the
sunny panorama (tests/data/hdri/sky.exr: a sun ~30,000× the mean) by the simulated filmic
camera, absolute units from camera.json (calibrate-response --lux) and the still's EXIF, and
an up-facing meter's reading: ``shlight compute FRAME --camera --lux E``."""
from __future__ import annotations

import numpy as np
import pytest

from provider.core.geometry import sh
from provider.core.geometry.projections import Equirect
from provider.core.sh9.engine import SH9Projector
from provider.core.sh9.meter import close_clipped, up_weights

from test_photometry_31 import (exact_illuminance_up, message, scene, shlight,
                                write_bracket)


def relative_rms(coefficients, truth_coefficients) -> float:
    """Relative RMS irradiance error over the sphere of normals."""
    e, t = sh.sphere_irradiance(np.asarray(coefficients)), sh.sphere_irradiance(truth_coefficients)
    return float(np.sqrt(np.mean((e - t) ** 2)) / np.sqrt(np.mean(t ** 2)))


@pytest.fixture(scope="module")
def camera(tmp_path_factory):
    folder = tmp_path_factory.mktemp("meter")
    hdr = scene("apartment")
    paths = write_bracket(folder, "cal", hdr, (-4, -2, 0, 2, 4), n=2.0, iso=100)
    p = shlight("calibrate-response", *paths, "--lux", exact_illuminance_up(hdr),
                "-o", folder / "camera.json")
    assert p.returncode == 0, p.stderr
    return folder / "camera.json"


def test_meter_closes_the_clipped_sun(camera, tmp_path):
    hdr = scene("sky")
    truth = SH9Projector(hdr.shape[1], hdr.shape[0], "equirect").project(
        hdr.astype(np.float32)).coefficients
    (frame,) = write_bracket(tmp_path, "sun", hdr, (0,), n=8.0, iso=100, ext="jpg")
    lux = exact_illuminance_up(hdr)
    before = message(shlight("compute", frame, "--camera", camera))
    p = shlight("compute", frame, "--camera", camera, "--lux", lux, "--lights", "auto")
    after = message(p)
    missed = relative_rms(np.reshape(before["coefficients"], (9, 3)), truth)
    closed = relative_rms(np.reshape(after["coefficients"], (9, 3)), truth)
    assert missed > 0.4                     # the clipped sun: most of the light is missing
    assert closed < 0.10, (missed, closed)
    assert after["meter_lux"] == pytest.approx(lux)
    assert after["meter_closed_lux"] > 0.5 * lux
    assert after["illuminance_lux"] == pytest.approx(lux, rel=0.05)
    # the region it went to is where the sun is: within 15° of the brightest pixel
    h, w = hdr.shape[:2]
    r, c = np.unravel_index(np.argmax(hdr.sum(axis=2)), (h, w))
    sun = Equirect(w, h).directions()[r, c]
    assert np.dot(after["meter_direction"], sun) > np.cos(np.radians(15))
    assert after["lights"] >= 1 and "the meter closed" in p.stderr


def test_meter_needs_absolute_units(tmp_path):
    (frame,) = write_bracket(tmp_path, "rel", scene("sky"), (0,), n=8.0, iso=100, ext="jpg")
    p = shlight("compute", frame, "--lux", 1000)
    assert p.returncode == 2 and "absolute units" in p.stderr and "Traceback" not in p.stderr


def test_a_meter_below_the_camera_closes_nothing():
    rad = np.ones((32, 64, 3), np.float32)
    clipped = np.zeros((32, 64), bool)
    clipped[2:4, 10:12] = True
    out, c = close_clipped(rad, clipped, up_weights(Equirect(64, 32)), lux=1.0)
    assert c.closed_lux == 0 and "nothing to close" in c.note and out is rad
    # a uniform sky of 1 cd/m² gives π lux; a meter at 2π closes π in the clipped blob
    out, c = close_clipped(rad, clipped, up_weights(Equirect(64, 32)), lux=2 * np.pi)
    assert c.camera_lux == pytest.approx(np.pi, rel=1e-6)
    assert c.closed_lux == pytest.approx(np.pi, rel=1e-6) and c.direction[1] > 0.9
    cos = up_weights(Equirect(64, 32))[0]
    added = ((out - rad)[..., 1] * cos).sum()
    assert added == pytest.approx(np.pi, rel=1e-5)
