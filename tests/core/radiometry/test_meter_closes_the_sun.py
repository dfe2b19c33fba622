"""Issue 31 part 4: a lux meter closes the clipped sun. One auto-exposed 8-bit frame of the
sunny panorama (tests/data/hdri/sky.exr: a sun ~30,000× the mean) by the simulated filmic
camera, absolute units from camera.json (calibrate-response --lux) and the still's EXIF, and
an up-facing meter's reading: ``shlight compute FRAME --camera --lux E``."""
from __future__ import annotations

import numpy as np
import pytest

from provider.core.geometry.projections import Equirect
from provider.core.sh9.engine import SH9Projector
from provider.core.sh9.meter import close_clipped, up_weights

from photometrytools import (exact_illuminance_up, facing_reading, message, relative_rms,
                             scene, shlight, write_bracket)


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
    assert after["lights"] >= 1 and "closed" in p.stderr and "neutral" in p.stderr


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
    assert c.camera_lux == pytest.approx(np.pi, rel=1e-5)   # a float32 sum over the frame
    assert c.closed_lux == pytest.approx(np.pi, rel=1e-5) and c.direction[1] > 0.9
    cos = up_weights(Equirect(64, 32))[0]
    added = ((out - rad)[..., 1] * cos).sum()
    assert added == pytest.approx(np.pi, rel=1e-5)


# -- where the meter faces, and a chroma meter's colour (part A of issue 31's follow-up) -------

def test_parse_facing_and_meter_colour():
    from provider.core.errors import InputError
    from provider.core.sh9.meter import parse_facing, parse_meter_colour
    assert np.allclose(parse_facing("up"), [0, 1, 0]) and parse_facing("SUN") == "sun"
    assert np.allclose(parse_facing("0,0"), [0, 0, -1])          # the panorama's front
    assert np.allclose(parse_facing("90,0"), [1, 0, 0])          # u = 0.75 looks along +X
    assert np.allclose(parse_facing("0,90"), [0, 1, 0], atol=1e-12)
    for bad in ("north", "10", "10,95", "nan,3"):
        with pytest.raises(InputError, match="--lux-facing"):
            parse_facing(bad)
    assert parse_meter_colour("5600") == (5600.0, 0.0)
    assert parse_meter_colour("3200,0.004") == (3200.0, 0.004)
    for bad in ("warm", "500", "5600,0.2", "1,2,3"):
        with pytest.raises(InputError, match="--lux-cct"):
            parse_meter_colour(bad)


def test_a_facing_chroma_meter_is_matched_in_lux_and_colour():
    """After the closure the frame explains what the meter read: its lux through the
    meter's own cosine, and (with a chroma meter) its CCT and Duv."""
    from provider.core.radiometry.colour_temperature import cct_duv
    from provider.core.radiometry.photometry import luminance
    from provider.core.sh9.meter import parse_facing
    rad = np.full((32, 64, 3), 1.0, np.float32)
    clipped = np.zeros((32, 64), bool)
    clipped[14:16, 20:23] = True                 # a blob a few degrees above the horizon
    weights = up_weights(Equirect(64, 32))
    _, omega, dirs = weights
    normal = dirs[14:16, 20:23].reshape(-1, 3).mean(axis=0)
    normal /= np.linalg.norm(normal)
    az = np.degrees(np.arctan2(normal[0], -normal[2]))
    el = np.degrees(np.arcsin(normal[1]))
    facing = parse_facing(f"{az},{el}")
    assert np.allclose(facing, normal)
    out, c = close_clipped(rad, clipped, weights, lux=40.0, facing=facing,
                           colour=(2500.0, 0.003))
    w = np.maximum(dirs @ facing, 0) * omega
    seen = np.tensordot(w, out.astype(np.float64), axes=([0, 1], [0, 1]))
    assert float(luminance(seen)) == pytest.approx(40.0, rel=1e-5)
    cct, duv = cct_duv(seen)
    assert cct == pytest.approx(2500.0, rel=2e-3) and duv == pytest.approx(0.003, abs=2e-4)
    assert c.colour[0] > c.colour[1] > c.colour[2]          # a warm sun: red over blue
    assert np.allclose(c.facing, facing) and c.warning == ""
    # the same blob for an up-facing meter: warned (grazing), and closed neutral
    out, c = close_clipped(rad, clipped, weights, lux=4.0)
    assert "grazing" in c.warning and np.allclose(c.colour, 1.0)
    # "sun": the meter faces the largest clipped blob
    out, c = close_clipped(rad, clipped, weights, lux=40.0, facing="sun")
    assert np.dot(c.facing, normal) > np.cos(np.radians(1)) and c.closed_lux > 0


def test_wide_clipped_region_is_not_taken_for_the_sun_silently():
    rad = np.ones((32, 64, 3), np.float32)
    clipped = np.zeros((32, 64), bool)
    clipped[:8] = True                            # a clipped sky: the top quarter
    _, c = close_clipped(rad, clipped, up_weights(Equirect(64, 32)), lux=20.0, facing="sun")
    assert "AZ,EL" in c.warning


def test_dawn_meter_toward_the_sun_with_its_colour_closes_within_10_percent(camera,
                                                                            tmp_path):
    """The low sun (4° up, its clipped blob 3-23°): an up-facing plain lux meter leaves it
    far off and is warned; one held toward the sun (its direction said 5° off) that also
    reads CCT closes it within 10 % RMS over all normals."""
    hdr = scene("dawn")
    truth = SH9Projector(hdr.shape[1], hdr.shape[0], "equirect").project(
        hdr.astype(np.float32)).coefficients
    (frame,) = write_bracket(tmp_path, "dawn", hdr, (0,), n=8.0, iso=100, ext="jpg")
    h, w = hdr.shape[:2]
    r, c = np.unravel_index(np.argmax(hdr.sum(axis=2)), (h, w))
    sun = Equirect(w, h).directions()[r, c]
    az = np.degrees(np.arctan2(sun[0], -sun[2]))
    el = np.degrees(np.arcsin(sun[1])) + 5.0
    up = shlight("compute", frame, "--camera", camera, "--lux", exact_illuminance_up(hdr))
    assert "grazing" in up.stderr and "--lux-facing" in up.stderr
    lux, (cct, duv) = facing_reading(hdr, sun)
    p = shlight("compute", frame, "--camera", camera, "--lux", lux,
                "--lux-facing", f"{az:.1f},{el:.1f}", "--lux-cct", f"{cct:.0f},{duv:.4f}")
    after = message(p)
    assert "coloured R:G:B" in p.stderr
    plain = relative_rms(np.reshape(message(up)["coefficients"], (9, 3)), truth)
    closed = relative_rms(np.reshape(after["coefficients"], (9, 3)), truth)
    assert closed < 0.10 < plain, (plain, closed)
    assert np.dot(after["meter_facing"], sun) > np.cos(np.radians(6))


def test_meter_options_need_lux_and_parse_in_one_line(tmp_path):
    (frame,) = write_bracket(tmp_path, "f", scene("sky"), (0,), n=8.0, iso=100, ext="jpg")
    for args, text in ((("--lux-facing", "sun"), "is for --lux"),
                       (("--lux", 1000, "--lux-facing", "east"), "--lux-facing east"),
                       (("--lux", 1000, "--lux-cct", "99"), "--lux-cct 99")):
        p = shlight("compute", frame, *args)
        assert p.returncode == 2 and text in p.stderr and "Traceback" not in p.stderr


def test_the_meters_weights_are_built_once_per_projection():
    """A live meter closes every frame: its pixel weights (0.4 s to build at 1920×960) are
    built once per projector (its projection and rotation), kept read-only, and equal to
    up_weights."""
    from provider.core.sh9.meter import _meter_weights
    projector = SH9Projector(64, 32, "equirect")
    first = _meter_weights(projector, Equirect(64, 32))
    assert _meter_weights(projector, Equirect(64, 32)) is first      # a new frame, same shape
    assert not first[0].flags.writeable and not first[2].flags.writeable
    for got, want in zip(first, up_weights(Equirect(64, 32))):
        np.testing.assert_array_equal(got, want)
    turned = np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]], float)
    rotated = SH9Projector(64, 32, "equirect", rotation=turned)
    assert _meter_weights(rotated, Equirect(64, 32)) is not first
    np.testing.assert_allclose(_meter_weights(rotated, Equirect(64, 32))[0],
                               up_weights(Equirect(64, 32), turned)[0])


def test_the_projector_says_its_up_cosine_weights():
    """SH9Projector.up_cosine_weights (public: what the meter's up illuminance reads from a
    projector): up_weights of its frame, in its rotation, built once; None for a downsampled
    projection (its frames are not the weights' pixels)."""
    projector = SH9Projector(64, 32, "equirect")
    weights = projector.up_cosine_weights
    assert weights is projector.up_cosine_weights and weights.dtype == np.float32
    np.testing.assert_allclose(weights, up_weights(Equirect(64, 32))[0].reshape(-1), rtol=1e-6)
    turned = np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]], float)
    np.testing.assert_allclose(SH9Projector(64, 32, rotation=turned).up_cosine_weights,
                               up_weights(Equirect(64, 32), turned)[0].reshape(-1),
                               rtol=1e-6, atol=1e-9)
    assert SH9Projector(64, 64, "fisheye", downsample=2).up_cosine_weights is None
