"""Registration in the live service (docs/contract.md §13): `shlight serve --marker` puts the
marker's pose in every message once it is known, measured off the frame path; `shlight
register theta://HOST` takes a still through OSC camera.takePicture (the fake OSC camera)."""
from __future__ import annotations

import json
import subprocess
import sys

import cv2
import numpy as np
import pytest

from fakecams.osc_camera import FakeOscCamera
from marker_scene import composite, marker_grid, random_pose, rotation_error_deg, scene, to_srgb8
from provider.core.errors import InputError
from provider.core.geometry.projections import make_projection
from provider.live.wire.message import validate
from servertools import ServerThread, connect, health, metric, poll, recv_until

MARKER = "aruco:DICT_4X4_50:7"


@pytest.fixture(scope="module")
def still():
    """A 1920×960 JPEG with the marker at a known pose, and that pose."""
    proj = make_projection("equirect", 1920, 960)
    base = scene("apartment", proj)
    R, t = random_pose(np.random.default_rng(21), (1.0, 1.5), max_tilt_deg=40)
    white = 0.8 * float(base.reshape(-1, 3).mean(0) @ [0.2126, 0.7152, 0.0722])
    rgb = to_srgb8(composite(base, proj, marker_grid(), R, t, 0.2), white)
    ok, buf = cv2.imencode(".jpg", rgb[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, 92])
    return buf.tobytes(), R, t


def test_every_message_carries_the_registration_once_known(tmp_path, still):
    data, R, t = still
    path = tmp_path / "room.jpg"
    path.write_bytes(data)
    with ServerThread("--source", str(path), "--fps", "5", "--keepalive", "0.2",
                      "--marker", MARKER, "--marker-size", "0.2",
                      "--register-every", "0.3") as srv:
        with connect(srv.url) as ws:
            msg = recv_until(ws, lambda m: m.get("type") == "sh9" and "registration" in m,
                             timeout=60, what="a message with registration")
            validate(msg)
            reg = msg["registration"]
            assert reg["marker"] == MARKER and reg["marker_id"] == "7"
            assert rotation_error_deg(np.reshape(reg["rotation"], (3, 3)), R) < 1.0
            assert np.allclose(reg["position"], t, atol=0.02)
            assert reg["age_s"] >= 0 and reg["levelled"] is False
            # Later messages average more frames of the unmoved marker.
            later = recv_until(ws, lambda m: m.get("registration", {}).get("frames", 0) >= 2,
                               timeout=60, what="an averaged registration")
            assert rotation_error_deg(np.reshape(later["registration"]["rotation"], (3, 3)), R) < 1.0


def test_a_source_without_the_marker_sends_lighting_without_registration(tmp_path, caplog):
    """...and says so: one log line for the streak of misses, the misses in /healthz and
    /metrics (before, a marker never found said nothing anywhere)."""
    caplog.set_level("INFO", logger="shlight")
    proj = make_projection("equirect", 512, 256)
    rgb = to_srgb8(scene("lab", proj), 1.0)
    path = tmp_path / "empty.png"
    cv2.imwrite(str(path), rgb[..., ::-1])
    with ServerThread("--source", str(path), "--fps", "5", "--keepalive", "0.2",
                      "--marker", MARKER, "--marker-size", "0.2",
                      "--register-every", "0.2") as srv:
        with connect(srv.url) as ws:
            for _ in range(6):
                msg = recv_until(ws, lambda m: m.get("type") == "sh9", timeout=30)
                assert "registration" not in msg
        registrar = srv.server.probes["default"].registrar
        poll(lambda: registrar.misses >= 3, 60, what="three misses")     # it did look
        reg = health(srv.http)["probes"]["default"]["registration"]
        assert reg["found"] is False and reg["misses"] >= 3 and reg["missing"] >= 3
        assert reg["marker"] == MARKER and reg["age_s"] is None
        assert metric(srv.http, "shlight_registration_misses_total", probe="default") >= 3
        assert metric(srv.http, "shlight_registration_found", probe="default") == 0
    said = [r.getMessage() for r in caplog.records if "not found in the frame" in r.getMessage()]
    assert len(said) == 1 and MARKER in said[0], said


@pytest.mark.parametrize("argv,words", [
    (["--marker", MARKER], "--marker-size"),
    (["--marker-size", "0.2"], "--marker SPEC"),
    (["--marker", "aruco:NOPE:1", "--marker-size", "0.2"], "unknown ArUco dictionary"),
    (["--marker", MARKER, "--marker-size", "0.2", "--register-every", "0"], "--register-every"),
])
def test_bad_registration_options_are_refused_at_start(argv, words):
    with pytest.raises(InputError, match=words):
        ServerThread("--source", "demo", *argv)


def test_register_takes_a_still_from_a_theta(still):
    data, R, t = still
    cam = FakeOscCamera(np.ones((32, 64, 3), np.float32))
    cam.still = data
    try:
        out = subprocess.run([sys.executable, "-m", "provider.cli", "register", cam.spec,
                              "--marker", MARKER, "--marker-size", "0.2"],
                             capture_output=True, text=True, timeout=120)
    finally:
        cam.close()
    assert out.returncode == 0, out.stderr
    assert "camera.takePicture" in cam.commands and "status" in cam.commands
    got = json.loads(out.stdout)
    assert rotation_error_deg(np.reshape(got["rotation"], (3, 3)), R) < 1.0
    assert np.allclose(got["position"], t, atol=0.02)
