"""Live radiometry (``shlight serve --camera --bracket``) against fake cameras: a fake
``picamera2`` module (on sys.path only here), a fake Ricoh Theta speaking OSC over real
HTTP, and a fake UVC capture. The fakes film an HDR panorama through a filmic curve that is
not sRGB, at the exposure they were asked for; everything else is the product."""
from __future__ import annotations

import json
import logging
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from provider.bench.camera_sim import CameraSim, auto_exposure
from provider.core.geometry import sh
from provider.core.sh9.engine import SH9Projector
from provider.live.probe.capture import Capture
from provider.live.wire.message import validate
from provider.live.sources import Frame, SourceOptions, SourceSpec
from provider.live.sources.base import Source

from fakecams.osc_camera import FakeOscCamera
from radiometrytools import sh9, small
from servertools import ServerThread, connect, poll, recv_json, recv_until, run_cli

FAKES = Path(__file__).resolve().parents[2] / "fakecams"


def camera_file(tmp_path, camera):
    path = tmp_path / "camera.json"
    path.write_text(json.dumps(camera.true_response().to_dict()))
    return str(path)


def shape_error(msg, truth):
    E = sh.sphere_irradiance(np.array(msg["coefficients"]).reshape(9, 3))
    T = sh.sphere_irradiance(truth)
    return sh.relative_rms((E * T).sum() / (E * E).sum() * E, T)


def absolute_error(msg, truth):
    return sh.irradiance_error(np.array(msg["coefficients"]).reshape(9, 3), truth)


@pytest.fixture
def picamera2(monkeypatch):
    """The fake picamera2 module, importable only during the test."""
    monkeypatch.syspath_prepend(str(FAKES))
    monkeypatch.delitem(sys.modules, "picamera2", raising=False)
    import picamera2
    picamera2.OPENED.clear()
    yield picamera2
    sys.modules.pop("picamera2", None)


# ---- Picamera2 ---------------------------------------------------------------------------------

def test_picamera2_exposure_is_divided_out_so_auto_exposure_does_not_jump(picamera2, tmp_path):
    """The fake's auto exposure hunts between two exposures 1 EV apart; every frame reports
    its ExposureTime × AnalogueGain, and the lighting stays put (measured < 1 %)."""
    hdr = small("venice")
    cam = CameraSim()
    picamera2.film(hdr, cam, hunt=4)
    with ServerThread("--source", "picamera2", "--capture-size", "128x64", "--camera",
                      camera_file(tmp_path, cam), "--change-threshold", "0") as srv, \
            connect(srv.url) as ws:
        recv_json(ws)
        seen = {}
        deadline = time.monotonic() + 30
        while len(seen) < 2 and time.monotonic() < deadline:
            msg = recv_until(ws, sh9, timeout=20)
            validate(msg)
            assert msg["radiometry"] == "calibrated" and msg["response"] == "true"
            assert msg["gain"] == pytest.approx(2.0)       # the fake's AE runs at gain 2
            seen.setdefault(round(msg["exposure_s"], 6), msg)
    assert len(seen) == 2, "the auto exposure should have moved"
    (t1, a), (t2, b) = sorted(seen.items())
    assert t2 / t1 == pytest.approx(2.0, rel=0.01)
    ca, cb = (np.array(m["coefficients"]).reshape(9, 3) for m in (a, b))
    assert sh.irradiance_error(ca, cb) < 0.02
    truth = SH9Projector(128, 64).project(hdr).coefficients
    assert absolute_error(a, truth) < 0.05


@pytest.mark.parametrize("scene", ["lab", "sky"])
def test_picamera2_bracket_merges_and_updates_every_frame(picamera2, tmp_path, scene):
    hdr = small(scene)
    cam = CameraSim()
    picamera2.film(hdr, cam)
    with ServerThread("--source", "picamera2", "--capture-size", "128x64", "--camera",
                      camera_file(tmp_path, cam), "--bracket",
                      "--change-threshold", "0") as srv, connect(srv.url) as ws:
        recv_json(ws)
        merged = [recv_until(ws, lambda m: sh9(m) and m["radiometry"] == "merged",
                             timeout=30)]
        merged += [recv_until(ws, sh9, timeout=10) for _ in range(12)]
        probe = srv.server.probes["default"]
    fake = picamera2.OPENED[-1]
    assert any(c.get("AeEnable") is False for c in fake.set_calls)
    for m in merged:
        validate(m)
        assert m["radiometry"] == "merged" and len(m["exposures_s"]) == 5
    times = merged[-1]["exposures_s"]
    assert max(times) / min(times) == pytest.approx(2 ** 12, rel=0.02)   # -9 ... +3 EV
    assert len({m["seq"] for m in merged}) == len(merged)      # a message per frame
    assert probe.frames_processed >= len(merged)
    truth = SH9Projector(128, 64).project(hdr).coefficients
    if scene == "lab":          # bare bulbs: within the 10 % (measured ~0.3 %)
        assert shape_error(merged[-1], truth) < 0.03
        assert absolute_error(merged[-1], truth) < 0.05
        assert merged[-1]["clipped_light_fraction"] == 0
    else:                       # the sun clips at -8 EV too, and the message says so
        assert 0 < merged[-1]["clipped_fraction"] < 0.01
        assert merged[-1]["clipped_light_fraction"] > 0.02


# ---- the Theta over OSC -----------------------------------------------------------------------

@pytest.mark.parametrize("api", ["2.0", "2.1"])
def test_theta_bracket_through_osc_set_options(tmp_path, api):
    hdr = small("sky")
    cam = CameraSim()
    theta = FakeOscCamera(hdr, camera=cam, api=api)
    try:
        with ServerThread("--source", theta.spec, "--camera", camera_file(tmp_path, cam),
                          "--bracket", "-4,-2,0,2,4", "--change-threshold", "0") as srv, \
                connect(srv.url) as ws:
            recv_json(ws)
            msg = recv_until(ws, lambda m: sh9(m) and m["radiometry"] == "merged", timeout=40)
            validate(msg)
            assert msg["source"] == "theta" and len(msg["exposures_s"]) == 5
            assert msg["clipped_light_fraction"] > 0.02          # the sun
            speeds = {c["shutterSpeed"] for c in theta.set_calls if "shutterSpeed" in c}
            assert len(speeds) >= 5
            assert theta.options["exposureProgram"] == 1
            truth = SH9Projector(128, 64).project(hdr).coefficients
            assert msg["exposures_s"] == sorted(msg["exposures_s"])
        poll(lambda: theta.options["exposureProgram"] == 2, what="options restored on close")
        assert "camera.getOptions" in theta.commands
    finally:
        theta.close()
    # the bracket saw far more of the light than one auto-exposed frame decoded as sRGB
    single = CameraSim().capture(hdr, auto_exposure(hdr))
    one = SH9Projector(128, 64).project(single).coefficients
    assert absolute_error(msg, truth) < sh.irradiance_error(one / auto_exposure(hdr), truth)


def test_theta_in_manual_mode_reports_its_exposure(tmp_path):
    hdr = small("apartment")
    cam = CameraSim()
    theta = FakeOscCamera(hdr, camera=cam, options={"exposureProgram": 1,
                                                     "shutterSpeed": 1 / 100, "iso": 200})
    try:
        with ServerThread("--source", theta.spec, "--camera", camera_file(tmp_path, cam)) as srv, \
                connect(srv.url) as ws:
            recv_json(ws)
            msg = recv_until(ws, sh9, timeout=20)
            assert msg["exposure_s"] == pytest.approx(0.01) and msg["gain"] == pytest.approx(2)
            assert msg["radiometry"] == "calibrated"
        commands = list(theta.commands)
        with ServerThread("--source", theta.spec) as srv, connect(srv.url) as ws:
            recv_json(ws)
            msg = recv_until(ws, sh9, timeout=20)
            assert "exposure_s" not in msg and msg["radiometry"] == "srgb-assumed"
        assert theta.commands[len(commands):] == ["camera.getLivePreview"]  # no extra command
    finally:
        theta.close()


# ---- a UVC camera through OpenCV -----------------------------------------------------------------

class FakeUVC:
    """cv2.VideoCapture of a V4L2 UVC camera: CAP_PROP_EXPOSURE in 100 µs units."""

    refuse_manual = False
    instances: list = []

    def __init__(self, target, *args):
        self.hdr = small("apartment")
        self.cam = CameraSim()
        self.auto = True
        self.exposure = 80.0          # 8 ms, what auto exposure happens to use
        self.queue = []               # frames the camera already queued (3 deep)
        FakeUVC.instances.append(self)

    def isOpened(self):
        return True

    def set(self, prop, value):
        if prop == cv2.CAP_PROP_AUTO_EXPOSURE:
            if self.refuse_manual:
                return False
            self.auto = value == 3
            return True
        if prop == cv2.CAP_PROP_EXPOSURE and not self.auto:
            self.exposure = float(round(value))
            return True
        return prop in (cv2.CAP_PROP_BUFFERSIZE, cv2.CAP_PROP_FRAME_WIDTH,
                        cv2.CAP_PROP_FRAME_HEIGHT, cv2.CAP_PROP_FOURCC)

    def get(self, prop):
        if prop == cv2.CAP_PROP_EXPOSURE:
            return self.exposure
        return 30.0 if prop == cv2.CAP_PROP_FPS else 0.0

    def read(self):
        t = auto_exposure(self.hdr) if self.auto else self.exposure * 1e-4
        self.queue.append(self.cam.capture(self.hdr, t)[..., ::-1].copy())
        return (True, self.queue.pop(0)) if len(self.queue) > 2 else (True, self.queue[0])

    def release(self):
        pass


def plug_in_fake_uvc(monkeypatch):
    """The fake camera in place of cv2.VideoCapture, and its /dev/video node "present" (the
    source checks the node exists before opening; there is none on a test machine)."""
    import provider.live.sources.opencv as opencv_source
    monkeypatch.setattr(cv2, "VideoCapture", FakeUVC)
    monkeypatch.setattr(opencv_source, "_missing_camera", lambda target: None)


def test_uvc_bracket_with_the_exposure_unit(monkeypatch):
    from provider.live.sources.opencv import OpenCVSource
    plug_in_fake_uvc(monkeypatch)
    src = OpenCVSource(0, SourceOptions(bracket=(-4, 0, 4), exposure_unit="100us"))
    src.open()
    frames = [src.read() for _ in range(6)]
    src.close()
    assert [f.info["slot"] for f in frames] == [0, 1, 2, 0, 1, 2]
    times = [f.info["exposure_s"] for f in frames[:3]]
    assert times[1] == pytest.approx(0.008) and times[2] / times[0] == pytest.approx(256, rel=0.05)
    means = [f.image.mean() for f in frames[:3]]
    assert means[0] < means[1] < means[2]          # the settled frames show their exposure
    # every frame divided by its exposure: the three agree where nothing clips
    P = SH9Projector(128, 64, response=CameraSim().true_response())
    mid = P.project(frames[1].image, exposure_s=times[1]).coefficients
    low = P.project(frames[0].image, exposure_s=times[0])
    assert low.stats["clipped_fraction"] == 0
    assert sh.irradiance_error(low.coefficients, mid) < 0.15    # -4 EV: 8-bit shadows


def test_uvc_exposure_is_reported_only_with_a_unit_and_when_plausible(monkeypatch, caplog):
    from provider.live.sources.opencv import OpenCVSource
    plug_in_fake_uvc(monkeypatch)
    src = OpenCVSource(0, SourceOptions())
    src.open()
    assert "exposure_s" not in src.read().info          # no unit: never guessed
    src = OpenCVSource(0, SourceOptions(exposure_unit="100us"))
    src.open()
    assert src.read().info["exposure_s"] == pytest.approx(0.008)
    FakeUVC.instances[-1].exposure = -6.0                # a log2 value read as 100 µs: nonsense
    with caplog.at_level(logging.WARNING, "shlight.source"):
        assert "exposure_s" not in src.read().info
    assert "not an exposure" in caplog.text


def test_uvc_that_refuses_manual_exposure_runs_unbracketed(monkeypatch, caplog):
    from provider.live.sources.opencv import OpenCVSource
    plug_in_fake_uvc(monkeypatch)
    monkeypatch.setattr(FakeUVC, "refuse_manual", True)
    src = OpenCVSource(0, SourceOptions(bracket=(-4, 0, 4), exposure_unit="100us"))
    with caplog.at_level(logging.ERROR, "shlight.source"):
        src.open()
    assert "refuses manual exposure" in caplog.text
    assert "slot" not in src.read().info


# ---- the capture thread and the command line ----------------------------------------------------

class _Cycling(Source):
    def __init__(self):
        super().__init__()
        self.n = 0

    def read(self):
        self._sleep(0.002)
        self.n += 1
        return Frame(np.zeros((2, 4, 3), np.uint8), time.time(),
                     info={"slot": self.n % 4, "n": self.n})


def test_a_slow_consumer_still_sees_every_slot_of_a_bracket():
    spec = SourceSpec("test", None, SourceOptions(), "cycling test source")
    spec.make = _Cycling
    cap = Capture(spec, name="t")
    cap.start()
    try:
        deadline = time.monotonic() + 10
        while cap.frames < 50 and time.monotonic() < deadline:
            time.sleep(0.01)
        taken = []
        while (f := cap.take()) is not None:
            taken.append(f)
        assert sorted(f.info["slot"] for f in taken) == [0, 1, 2, 3]
        assert len({f.info["n"] for f in taken}) == 4    # the newest of each, once
    finally:
        cap.stop()


@pytest.mark.parametrize("args,needle", [
    (["--bracket"], "demo (built-in animated scene) cannot set its exposure"),
    (["--source", "http://127.0.0.1:9/x.mjpg", "--bracket", "-4,0,4"], "cannot set its exposure"),
    (["--source", "0", "--bracket"], "needs --exposure-unit"),
    (["--bracket", "0,0.1"], "0.5 EV apart"),
    (["--source", "demo", "--exposure-unit", "100us"], "for UVC cameras"),
    (["--camera", "/no/such/camera.json"], "no such camera file"),
])
def test_serve_refuses_what_cannot_work_at_start(args, needle):
    p = run_cli("serve", "--port", "0", *args)
    assert p.returncode == 2 and needle in p.stderr, p.stderr
    assert "Traceback" not in p.stderr
