"""``serve --lux``: a metered live frame costs one decode and one projection (of the closed
frame), whose pass also sums the up-facing illuminance; the closure is the only extra work.
Counted on the real projector of a probe built by the real ``shlight serve`` code, fed real
frames by the real image source (review of issue 31's meter)."""
from __future__ import annotations

import collections

import numpy as np
import pytest

from provider.core.sh9 import meter as meter_module
from provider.core.sh9.engine import SH9Projector

from photometrytools import exact_illuminance_up, scene, write_bracket


@pytest.fixture
def counted(monkeypatch):
    """Calls of the projector's passes, counted by wrapping the real methods: ``project``,
    ``_project_frame`` by pixel type (the engine's decoding pass), ``up_illuminance`` (a
    second pass over a frame's pixels) and the meter's own decode (``apply_lut``)."""
    calls = collections.Counter()

    def wrap(owner, name, key=None):
        real = getattr(owner, name)

        def counting(*args, **kwargs):
            calls[key(*args) if key else name] += 1
            return real(*args, **kwargs)
        monkeypatch.setattr(owner, name, counting)
    wrap(SH9Projector, "project")
    wrap(SH9Projector, "up_illuminance")
    wrap(SH9Projector, "_project_frame",
         lambda self, frame, *a: f"pass over a {frame.dtype} frame")
    wrap(meter_module, "apply_lut", lambda *a: "meter decode")
    return calls


def _probe(*argv):
    from provider.cli import build_parser
    from provider.cli.serve import build_server
    server = build_server(build_parser().parse_args(["serve", "--port", "0", *argv]))
    return server.probes["default"]


def _frames(probe, n):
    """``n`` frames from the probe's own source (its spec: the file with its EXIF exposure)."""
    source = probe.spec.make()
    source.open()
    try:
        return [source.read() for _ in range(n)]
    finally:
        source.close()


def test_a_metered_live_frame_is_decoded_and_projected_once(camera, tmp_path,  # noqa: F811
                                                            counted):
    hdr = scene("sky")
    (path,) = write_bracket(tmp_path, "sun", hdr, (0,), n=8.0, iso=100, ext="jpg")
    lux = exact_illuminance_up(hdr)
    probe = _probe("--source", str(path), "--camera", str(camera), "--lux", str(lux),
                   "--lights", "auto")
    frames = _frames(probe, 3)
    results = [probe._project(frame) for frame in frames]
    for r in results:     # closed, with the lux of the closed frame from the same pass
        assert r.stats["meter_closed_lux"] > 0.5 * lux and r.lights
        assert r.stats["illuminance_lux"] == pytest.approx(lux, rel=0.05)
        assert r.stats["coefficient_units"] == "cd/m²" and r.stats["radiometry"] == "calibrated"
    assert counted == {"project": 3, "meter decode": 3, "pass over a float32 frame": 3}, counted

    # a meter that reads less than the camera sees closes nothing: still one projection
    counted.clear()
    dim = _probe("--source", str(path), "--camera", str(camera), "--lux", "1e-3")
    (result,) = [dim._project(frame) for frame in frames[:1]]
    assert result.stats["meter_closed_lux"] == 0
    assert counted == {"project": 1, "meter decode": 1, "pass over a float32 frame": 1}, counted


def test_a_metered_frame_keeps_what_the_camera_saw(camera, tmp_path):  # noqa: F811
    """The closed frame's statistics of the frame as captured are those of its plain
    projection (clipping, the share of light clipped, units, exposure), and its coefficients
    differ from it only by the closure (where the meter closes nothing: not at all)."""
    hdr = scene("sky")
    (path,) = write_bracket(tmp_path, "sun", hdr, (0,), n=8.0, iso=100, ext="jpg")
    plain_probe = _probe("--source", str(path), "--camera", str(camera))
    (frame,) = _frames(plain_probe, 1)
    plain = plain_probe._project(frame)
    dim = _probe("--source", str(path), "--camera", str(camera),
                 "--lux", "1e-3")._project(frame)
    bright = _probe("--source", str(path), "--camera", str(camera),
                    "--lux", str(exact_illuminance_up(hdr)))._project(frame)
    for key in ("radiometry", "response", "coefficient_units"):
        assert dim.stats[key] == bright.stats[key] == plain.stats[key], key
    for key in ("clipped_fraction", "clipped_light_fraction", "exposure_s", "f_number",
                "illuminance_lux"):
        assert dim.stats[key] == pytest.approx(plain.stats[key], rel=1e-5), key
        if key != "illuminance_lux":
            assert bright.stats[key] == pytest.approx(plain.stats[key], rel=1e-5), key
    np.testing.assert_allclose(dim.coefficients, plain.coefficients, rtol=1e-5, atol=1e-9)
    assert bright.stats["clipped_light_fraction"] > 0.01
    assert bright.coefficients[0, 0] > 2 * plain.coefficients[0, 0]


def test_a_metered_lens_frame_keeps_the_share_of_light_clipped(camera):  # noqa: F811
    """On a lens projection (a fisheye looking up: no separable weights) what the closure put
    into L00 is taken back out with the projector's own L00 weights over the closed pixels:
    the metered frame says the share of light the camera clipped as its plain projection
    does, while its coefficients hold the closed light."""
    from provider.core.sh9.meter import project_with_meter
    from provider.live.probe.camerafile import load_camera
    projector = SH9Projector(128, 128, "fisheye", response=load_camera(camera))
    frame = np.full((128, 128, 3), 60, np.uint8)
    y, x = np.mgrid[0:128, 0:128]
    frame[(y - 50) ** 2 + (x - 70) ** 2 <= 36] = 255      # a clipped sun 20-odd ° from zenith
    plain = projector.project(frame, exposure_s=0.01)
    metered, closure = project_with_meter(projector, [frame], [0.01], 1.0, None,
                                          10 * plain.stats["illuminance_lux"])
    assert closure.closed_lux > 0 and closure.pixels.size == np.count_nonzero(frame[..., 0] == 255)
    assert plain.stats["clipped_light_fraction"] > 0.01
    for key in ("clipped_fraction", "clipped_light_fraction"):
        assert metered.stats[key] == pytest.approx(plain.stats[key], rel=1e-5), key
    assert metered.coefficients[0, 0] > 2 * plain.coefficients[0, 0]
