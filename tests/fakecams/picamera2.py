"""A fake ``picamera2`` module: a Raspberry Pi camera that films an HDR panorama.

Only on ``sys.path`` inside the tests that use it (``monkeypatch.syspath_prepend``). It
renders 8-bit frames of the panorama given to :func:`film` at the exposure it was asked
for (ExposureTime µs × AnalogueGain), through a filmic tone curve that is not sRGB
(:class:`provider.bench.camera_sim.CameraSim`), in Picamera2's "RGB888" byte order (B, G,
R), and reports each frame's metadata. Like the real pipeline, controls take effect
``LATENCY`` frames after ``set_controls``. Its auto exposure puts the median at mid-grey
with an analogue gain of 2; ``hunt`` makes it alternate between two exposures 1 EV apart
(an auto exposure that cannot make up its mind).
"""
from __future__ import annotations

import threading
import time

import cv2
import numpy as np

from provider.bench.camera_sim import CameraSim, auto_exposure

LATENCY = 2
SCENE = {"hdr": None, "camera": CameraSim(), "fps": 60.0, "hunt": 0}
OPENED: list = []


def film(hdr, camera=None, fps=60.0, hunt=0):
    """What the camera sees from now on (linear HDR, H×W×3 RGB)."""
    SCENE.update(hdr=np.maximum(hdr, 0).astype(np.float32), camera=camera or CameraSim(),
                 fps=fps, hunt=hunt)


class _Request:
    def __init__(self, arrays, metadata):
        self._arrays, self._metadata, self.released = arrays, metadata, False

    def make_array(self, name):
        return self._arrays[name]

    def get_metadata(self):
        return dict(self._metadata)

    def release(self):
        self.released = True


class Picamera2:
    camera_controls = {"ExposureTime": (60, 2_000_000, 20_000), "AnalogueGain": (1.0, 16.0, 1.0),
                       "AeEnable": (False, True, True)}

    def __init__(self, camera_num=0):
        self.camera_num = camera_num
        self.size = (640, 480)
        self.started = False
        self.controls = {"AeEnable": True}
        self.pending = []                       # (frame number it applies at, controls)
        self.frame = 0
        self.set_calls = []
        self._lock = threading.Lock()
        OPENED.append(self)

    def create_video_configuration(self, main=None, controls=None, **_):
        return {"main": dict(main or {}), "controls": dict(controls or {})}

    def configure(self, config):
        assert config["main"].get("format") == "RGB888"
        self.size = tuple(config["main"].get("size", self.size))
        self.controls.update(config["controls"])

    def start(self):
        self.started = True

    def stop(self):
        self.started = False

    def close(self):
        self.started = False

    def set_controls(self, controls):
        with self._lock:
            self.set_calls.append(dict(controls))
            self.pending.append((self.frame + LATENCY, dict(controls)))

    def _exposure(self):
        hdr = SCENE["hdr"]
        if self.controls.get("AeEnable", True):
            total = auto_exposure(hdr)
            if SCENE["hunt"] and (self.frame // SCENE["hunt"]) % 2:
                total *= 0.5
            return total / 2, 2.0, True             # AE: half the time, analogue gain 2
        return (self.controls.get("ExposureTime", 20_000) * 1e-6,
                float(self.controls.get("AnalogueGain", 1.0)), False)

    def capture_request(self, *_args, **_kw):
        assert self.started, "capture before start()"
        time.sleep(1.0 / SCENE["fps"])
        with self._lock:
            self.frame += 1
            for when, c in [p for p in self.pending if p[0] <= self.frame]:
                self.controls.update(c)
            self.pending = [p for p in self.pending if p[0] > self.frame]
            t, gain, ae = self._exposure()
        md = {"ExposureTime": max(int(round(t * 1e6)), 1), "AnalogueGain": gain,
              "DigitalGain": 1.0, "AeLocked": ae, "SensorTimestamp": time.monotonic_ns()}
        w, h = self.size
        hdr = cv2.resize(SCENE["hdr"], (w, h), interpolation=cv2.INTER_AREA)
        rgb = SCENE["camera"].capture(hdr, md["ExposureTime"] * 1e-6 * gain)
        return _Request({"main": np.ascontiguousarray(rgb[..., ::-1])}, md)

    def capture_array(self, name="main"):
        request = self.capture_request()
        try:
            return request.make_array(name)
        finally:
            request.release()
