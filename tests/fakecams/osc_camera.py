"""A fake Ricoh Theta over Wi-Fi (Open Spherical Camera API 2.1 or 2.0) that films an HDR
panorama: its live preview renders 8-bit JPEG frames at the exposure its options say
(shutterSpeed × iso/100 in manual mode, exposureProgram 1; median at mid-grey in auto mode),
through a filmic tone curve that is not sRGB. ``camera.getOptions`` and
``camera.setOptions`` work as on the camera (a speed it does not support is an error).
Real HTTP on loopback; every frame is rendered when it is sent."""
from __future__ import annotations

import json
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import cv2
import numpy as np

from provider.bench.camera_sim import CameraSim, auto_exposure

SPEEDS = [1 / 8000, 1 / 6400, 1 / 5000, 1 / 4000, 1 / 3200, 1 / 2500, 1 / 2000, 1 / 1600,
          1 / 1250, 1 / 1000, 1 / 800, 1 / 640, 1 / 500, 1 / 400, 1 / 320, 1 / 250, 1 / 200,
          1 / 160, 1 / 125, 1 / 100, 1 / 80, 1 / 60, 1 / 50, 1 / 40, 1 / 30, 1 / 25, 1 / 20,
          1 / 15, 1 / 13, 1 / 10, 1 / 8, 1 / 6, 1 / 5, 0.25, 0.3, 0.4, 0.5, 0.625, 0.8, 1.0,
          1.3, 1.6, 2.0, 2.5, 3.2, 4.0, 5.0, 6.0, 8.0, 10.0, 13.0, 15.0, 20.0, 25.0, 30.0,
          60.0]


class OscHandler(BaseHTTPRequestHandler):
    """What the fake OSC cameras' request handlers share (this one and tests/live/sources/test_sources.py's
    FakeTheta): JSON answers and the live preview stream."""
    protocol_version = "HTTP/1.1"

    def log_message(self, *args):
        pass

    def _json(self, status, obj):
        body = json.dumps(obj).encode()
        self.send_response(status)
        self.send_header("Content-Type", "application/json;charset=utf-8")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def _live_preview(self, frames, period: float):
        """The answer to getLivePreview, as a Theta sends it: a chunked multipart MJPEG body
        with the Theta's boundary, one JPEG of ``frames`` (bytes each) every ``period``
        seconds, until ``frames`` ends or the client goes away."""
        self.send_response(200)
        self.send_header("Content-Type",
                         "multipart/x-mixed-replace; boundary=\"---osclivepreview---\"")
        self.send_header("Transfer-Encoding", "chunked")
        self.end_headers()
        try:
            for frame in frames:
                part = (b"---osclivepreview---\r\nContent-type: image/jpeg\r\n"
                        b"Content-Length: " + str(len(frame)).encode()
                        + b"\r\n\r\n" + frame + b"\r\n")
                self.wfile.write(f"{len(part):x}\r\n".encode() + part + b"\r\n")
                self.wfile.flush()
                time.sleep(period)
        except OSError:
            pass


class FakeOscCamera:
    def __init__(self, hdr, *, camera=None, api="2.1", fps=40.0, size=(128, 64),
                 options=None):
        self.hdr = cv2.resize(np.maximum(hdr, 0).astype(np.float32), size,
                              interpolation=cv2.INTER_AREA)
        self.camera = camera or CameraSim()
        self.api, self.fps = api, fps
        self.options = {"exposureProgram": 2, "shutterSpeed": 0, "iso": 0,
                        "shutterSpeedSupport": SPEEDS, "isoSupport": [100, 125, 160, 200,
                                                                       400, 800, 1600]}
        self.options.update(options or {})
        self.defaults = dict(self.options)      # what a power cycle brings back
        #: What POST /osc/state reports (OSC's camera state; Theta X names its temperatures).
        self.state = {"batteryLevel": 0.82, "_batteryState": "disconnect", "_boardTemp": 41.5}
        self.generation = 0                      # a power cycle ends the streams of before
        self.state_calls = 0
        self.commands, self.set_calls = [], []
        #: The JPEG that camera.takePicture "takes" (None: the command is unknown).
        self.still: bytes | None = None
        self._lock = threading.Lock()
        cam = self

        class Handler(OscHandler):
            def _error(self, name, code, message):
                self._json(400, {"name": name, "state": "error",
                                 "error": {"code": code, "message": message}})

            def do_POST(self):
                cmd = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
                name, params = cmd["name"], cmd.get("parameters") or {}
                cam.commands.append(name)
                if cam.api == "2.0" and name not in ("camera.startSession",) and \
                        params.get("sessionId", "SID_0001") != "SID_0001":
                    return self._error(name, "invalidSessionId", "bad session")
                if name == "camera.startSession" and cam.api == "2.0":
                    return self._json(200, {"name": name, "state": "done",
                                            "results": {"sessionId": "SID_0001"}})
                if name == "camera.closeSession":
                    return self._json(200, {"name": name, "state": "done"})
                if name == "camera.getOptions":
                    with cam._lock:
                        opts = {k: cam.options[k] for k in params.get("optionNames", [])
                                if k in cam.options}
                    return self._json(200, {"name": name, "state": "done",
                                            "results": {"options": opts}})
                if name == "camera.setOptions":
                    new = params.get("options") or {}
                    if "shutterSpeed" in new and new["shutterSpeed"] not in SPEEDS + [0]:
                        return self._error(name, "invalidParameterValue", "shutterSpeed")
                    with cam._lock:
                        cam.options.update(new)
                        cam.set_calls.append(dict(new))
                    return self._json(200, {"name": name, "state": "done"})
                if name == "camera.takePicture" and cam.still is not None:
                    return self._json(200, {"name": name, "state": "inProgress", "id": "7"})
                live = (name == "camera.getLivePreview" and cam.api == "2.1") or (
                    name == "camera._getLivePreview" and cam.api == "2.0")
                if not live:
                    return self._error(name, "unknownCommand", "Command executed is unknown.")
                self._live_preview(cam.frames(), 1.0 / cam.fps)

            def do_GET(self):          # the still camera.takePicture gave the URL of
                if self.path != "/files/still.jpg" or cam.still is None:
                    return self._json(404, {})
                self.send_response(200)
                self.send_header("Content-Type", "image/jpeg")
                self.send_header("Content-Length", str(len(cam.still)))
                self.end_headers()
                self.wfile.write(cam.still)

        class StatusHandler(Handler):   # /osc/commands/status: the picture is ready
            def do_POST(self):
                if self.path == "/osc/state":
                    self.rfile.read(int(self.headers.get("Content-Length") or 0))
                    cam.state_calls += 1     # not a command (/osc/commands/execute)
                    return self._json(200, {"fingerprint": "FIG_0001", "state": cam.state})
                if self.path != "/osc/commands/status":
                    return Handler.do_POST(self)
                self.rfile.read(int(self.headers["Content-Length"]))
                cam.commands.append("status")
                url = f"http://127.0.0.1:{cam.httpd.server_address[1]}/files/still.jpg"
                key = "fileUrl" if cam.api == "2.1" else "fileUri"
                return self._json(200, {"name": "camera.takePicture", "state": "done",
                                        "results": {key: url}})

        self.closed = False
        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), StatusHandler)
        self.httpd.daemon_threads = True
        threading.Thread(target=self.httpd.serve_forever, daemon=True,
                         kwargs={"poll_interval": 0.05}).start()

    def exposure(self) -> float:
        """t·gain of the frame rendered now."""
        with self._lock:
            o = dict(self.options)
        if o["exposureProgram"] == 1 and o["shutterSpeed"] and o["iso"]:
            return o["shutterSpeed"] * o["iso"] / 100.0
        return auto_exposure(self.hdr)

    def frames(self):
        """The live preview's JPEGs, each rendered when it is sent, until close() or a power
        cycle."""
        generation = self.generation
        while not self.closed and self.generation == generation:
            yield self.render()

    def forget(self, *, drop_stream: bool = False):
        """The camera slept or was power-cycled: its options are its defaults again; with
        ``drop_stream`` the live preview ends too (the client must reconnect)."""
        with self._lock:
            self.options = dict(self.defaults)
        if drop_stream:
            self.generation += 1

    def render(self) -> bytes:
        rgb = self.camera.capture(self.hdr, self.exposure())
        ok, data = cv2.imencode(".jpg", np.ascontiguousarray(rgb[..., ::-1]),
                                [cv2.IMWRITE_JPEG_QUALITY, 98])
        assert ok
        return data.tobytes()

    @property
    def spec(self) -> str:
        return f"theta://127.0.0.1:{self.httpd.server_address[1]}"

    def close(self):
        self.closed = True
        self.httpd.shutdown()
        self.httpd.server_close()
