"""A real ball in a real frame: ``shlight locate-ball``, ``--ball X,Y,R|auto`` for
``compute``, and every input option (exposure, rotation, --camera, brackets, lights) with the
light-probe projections as with the others."""
from __future__ import annotations

import json
import math
import subprocess
import sys

import cv2
import numpy as np
import pytest

from provider.bench.probes import ball_in_room, render_probe, srgb8
from provider.core.geometry import sh
from provider.core.registration.ball import locate_ball
from provider.core.sh9.bracket_projection import BracketProjector, project_bracket
from provider.core.sh9.engine import SH9Projector
from provider.core.geometry.projections_probe import AngularMap, CubeCross, MirrorBall
from provider.core.radiometry.response import CameraResponse
from provider.live.wire.message import validate

from conftest import load_hdri

BALL = (331.4, 212.7, 118.3)    # x, y, radius in a 640×480 webcam frame


def shlight(*args, timeout=120):
    return subprocess.run([sys.executable, "-m", "provider.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout)


def webcam_frame(name="apartment", ball=BALL, size=(640, 480)):
    """A float frame: the room behind (the panorama's front, dimmed) with a chrome ball in
    it, anti-aliased on its edge (the bench's own composite); and the panorama."""
    hdr = np.maximum(load_hdri(name), 0)
    return ball_in_room(hdr, ball, size), hdr


@pytest.fixture(scope="module")
def frame():
    return webcam_frame()


@pytest.mark.parametrize("scene,ball,encode", [
    ("apartment", BALL, "float"), ("apartment", BALL, "srgb8"),
    ("sky", (200.6, 260.2, 150.7), "srgb8"), ("night", (400.2, 200.9, 90.2), "float")])
def test_locate_ball_finds_the_circle_to_a_fraction_of_a_pixel(scene, ball, encode):
    img, _ = webcam_frame(scene, ball)
    if encode == "srgb8":
        img = srgb8(img / np.percentile(img, 99))
    c = locate_ball(img)
    assert math.hypot(c.x - ball[0], c.y - ball[1]) < 0.5
    assert abs(c.radius - ball[2]) < 0.5
    assert c.edge_points > 200 and c.edge_rms < 0.5


@pytest.mark.parametrize("scene,ball,encode", [
    ("lab", BALL, "float"), ("forest", (200.6, 260.2, 150.7), "srgb8"),
    ("bridge", (400.2, 200.9, 90.2), "float")])
def test_a_circle_that_is_off_says_it_is_weak(scene, ball, encode):
    """Dark rooms and a ball against a background like it (lab, forest, bridge): the circle
    may be off, but then it is weak (too few rays agree on its edge), never silently wrong;
    `shlight bench --sections probes` counts this on every panorama."""
    img, _ = webcam_frame(scene, ball)
    if encode == "srgb8":
        img = srgb8(img / np.percentile(img, 99))
    c = locate_ball(img)
    if max(math.hypot(c.x - ball[0], c.y - ball[1]), abs(c.radius - ball[2])) > 1.0:
        assert c.weak and c.as_dict()["weak"] is True
    assert "--ball X,Y,R" in c.weak_note() and str(c.edge_points) in c.weak_note()


def test_locate_ball_command_warns_of_a_weak_circle(tmp_path):
    img, _ = webcam_frame("lab", BALL)
    path = tmp_path / "lab.hdr"
    cv2.imwrite(str(path), img[..., ::-1])
    p = shlight("locate-ball", path)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert out["weak"] is True and out["edge_points"] < 360
    assert "shlight locate-ball: warning: only" in p.stderr and "--ball X,Y,R" in p.stderr
    p = shlight("compute", path, "--projection", "mirrorball", "--ball", "auto")
    assert p.returncode == 0 and "shlight compute: warning: only" in p.stderr


def test_locate_ball_command_prints_the_circle_and_refuses_a_frame_without_one(frame, tmp_path):
    img, _ = frame
    path = tmp_path / "ball.png"
    cv2.imwrite(str(path), srgb8(img / np.percentile(img, 99))[..., ::-1])
    p = shlight("locate-ball", path)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert abs(out["x"] - BALL[0]) < 0.5 and abs(out["radius"] - BALL[2]) < 0.5
    assert out["width"] == 640 and len(out["ball"].split(",")) == 3
    assert out["weak"] is False and "warning" not in p.stderr
    flat = tmp_path / "flat.png"
    cv2.imwrite(str(flat), np.full((240, 320, 3), 90, np.uint8))
    p = shlight("locate-ball", flat)
    assert p.returncode == 2 and "no ball found" in p.stderr and "Traceback" not in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1


def test_compute_with_ball_auto_gives_the_lighting_of_the_panorama(frame, tmp_path):
    img, hdr = frame
    path = tmp_path / "ball.hdr"              # Radiance RGBE: linear, as the HDR frame
    cv2.imwrite(str(path), img[..., ::-1])
    auto = shlight("compute", path, "--projection", "mirrorball", "--ball", "auto")
    given = shlight("compute", path, "--projection", "mirrorball",
                    "--ball", ",".join(map(str, BALL)))
    for p in (auto, given):
        assert p.returncode == 0, p.stderr
        validate(json.loads(p.stdout))
    assert "ball found" in auto.stderr
    truth = SH9Projector(hdr.shape[1], hdr.shape[0]).project(hdr).coefficients
    a = np.array(json.loads(auto.stdout)["coefficients"]).reshape(9, 3)
    g = np.array(json.loads(given.stdout)["coefficients"]).reshape(9, 3)
    assert sh.irradiance_error(g, truth) < 1e-2
    # The rim maps the whole sphere behind the ball into its last pixel: a circle found
    # within half a pixel moves the lighting by a few per cent (README, "Light probes").
    assert sh.irradiance_error(a, truth) < 5e-2


@pytest.mark.parametrize("args,needle", [
    (["--ball", "1,2"], "X,Y,R"),
    (["--ball", "100,10,50"], "outside"),
    (["--ball-unseen", "120"], "[0, 90)"),
    (["--ball-distance", "0.5"], "more than 1"),
    (["--fov", "200"], "(0, 180)"),
])
def test_bad_ball_options_are_one_line(frame, tmp_path, args, needle):
    path = tmp_path / "small.png"
    cv2.imwrite(str(path), np.full((64, 64, 3), 90, np.uint8))
    p = shlight("compute", path, "--projection", "mirrorball", *args)
    assert p.returncode == 2 and needle in p.stderr and "Traceback" not in p.stderr


def test_ball_option_with_another_projection_is_refused(tmp_path):
    path = tmp_path / "p.png"
    cv2.imwrite(str(path), np.full((32, 64, 3), 90, np.uint8))
    p = shlight("compute", path, "--ball", "auto")
    assert p.returncode == 2 and "mirrorball or angular" in p.stderr


# -- every input option with the probe projections ---------------------------------------

@pytest.fixture(scope="module")
def probes():
    """(projection, float image rendered from the lab panorama, the panorama's SH9)."""
    hdr = np.maximum(load_hdri("lab"), 0)
    truth = SH9Projector(hdr.shape[1], hdr.shape[0]).project(hdr).coefficients
    out = []
    for p in (MirrorBall(256, 256), AngularMap(256, 256), CubeCross(4 * 48, 3 * 48)):
        out.append((p, render_probe(hdr, p), truth))
    return out


def project(p, image, **options):
    return SH9Projector(p.width, p.height, p.name, **options).project(image)


def test_exposure_and_rotation_with_probe_projections(probes):
    R = sh.rotation_from_euler(30, -20, 10)
    for p, img, truth in probes:
        plain = project(p, img).coefficients
        assert sh.irradiance_error(plain, truth) < 1e-2, p.name
        assert np.allclose(project(p, img, exposure=4.0).coefficients, 4 * plain, rtol=1e-5)
        assert np.allclose(project(p, img, rotation=R).coefficients,
                           sh.rotate_coefficients(plain, R), rtol=1e-6, atol=1e-9)


def test_camera_response_and_brackets_with_probe_projections(probes):
    """8-bit frames through a gamma-2.2 camera: decoded with --camera (not sRGB), and a
    bracket of three exposures merged, give the HDR lighting."""
    cam = CameraResponse.gamma(2.2)
    top = cam.table if cam.table.ndim == 1 else cam.table[:, 0]
    for p, img, truth in probes:
        scale = 0.5 / np.percentile(img[img > 0], 99)
        times = (0.25, 1.0, 4.0)

        def shot(t):   # the camera: radiance × time -> the code whose value is nearest
            v = np.clip(img * scale * t, 0, top[-1])
            return np.searchsorted(top, v).clip(0, 255).astype(np.uint8)
        one = project(p, shot(1.0), response=cam).coefficients
        clipped = project(p, np.minimum(img * scale, top[-1]).astype(np.float32)).coefficients
        assert sh.irradiance_error(one, clipped) < 0.02, p.name     # one frame: clips
        srgb = project(p, shot(1.0)).coefficients
        assert sh.irradiance_error(srgb, clipped) > 0.05, p.name    # not decoded as sRGB
        proj = SH9Projector(p.width, p.height, p.name, response=cam)
        merged = project_bracket(proj, [shot(t) for t in times], np.array(times))
        assert sh.irradiance_error(merged.coefficients / scale, truth) < 0.02, p.name
        live = BracketProjector(proj, times)
        for slot, t in enumerate(times):
            r = live.push(slot, shot(t), t)
        assert sh.irradiance_error(r.coefficients / scale, truth) < 0.02, p.name


def test_lights_find_the_sun_in_a_ball_and_an_angular_map():
    hdr = np.maximum(load_hdri("sky"), 0)
    pano = SH9Projector(hdr.shape[1], hdr.shape[0], lights="auto").project(hdr)
    assert pano.lights
    sun = pano.lights[0].direction
    for p in (MirrorBall(384, 384), AngularMap(384, 384)):
        r = project(p, render_probe(hdr, p), lights="auto")
        assert r.lights, p.name
        assert float(np.dot(r.lights[0].direction, sun)) > math.cos(math.radians(3)), p.name


def test_a_live_probe_with_ball_auto_finds_the_ball_then_keeps_its_projector(frame, tmp_path,
                                                                           caplog):
    """``shlight serve --projection mirrorball --ball auto``: the probe locates the ball in
    the first frame that shows one, builds the projector for it once, and rejects a frame
    without a ball in one clear line (the server lives on); a circle few rays agree on is
    used, with a warning in the log."""
    from provider.core.errors import InputError
    from provider.live.probe.pipeline import Probe
    from provider.live.sources import Frame, SourceOptions, parse_source
    img, hdr = frame
    path = tmp_path / "ball.hdr"
    cv2.imwrite(str(path), img[..., ::-1])
    probe = Probe("ball", parse_source(str(path), SourceOptions()), projection="mirrorball",
                  engine_options={"ball": "auto"})
    with pytest.raises(InputError, match="no ball found"):
        probe._project(Frame(np.full((480, 640, 3), 0.3, np.float32), 0.0))
    r = probe._project(Frame(img, 1.0))
    truth = SH9Projector(hdr.shape[1], hdr.shape[0]).project(hdr).coefficients
    assert sh.irradiance_error(r.coefficients, truth) < 5e-2
    projector = probe._projectors[(640, 480)]
    assert projector.window is not None
    probe._project(Frame(img, 2.0))
    assert probe._projectors[(640, 480)] is projector
    assert "weak" not in caplog.text and "rays agree" not in caplog.text
    # a faint rim: the probe serves it and says in the log that the circle may be off
    dark, _ = webcam_frame("lab", BALL)
    weak = Probe("lab", parse_source(str(path), SourceOptions()), projection="mirrorball",
                 engine_options={"ball": "auto"})
    weak._project(Frame(dark, 0.0))
    warned = [r for r in caplog.records if r.levelname == "WARNING" and "rays agree" in r.message]
    assert len(warned) == 1 and "probe lab: only" in warned[0].message
    assert weak.health()["ball"]["weak"] is True and weak.health()["ball"]["frame"] == [640, 480]
    assert probe.health()["ball"]["weak"] is False
