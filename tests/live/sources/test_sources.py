"""Frame sources of ``shlight serve``: the MJPEG multipart reader, the Ricoh Theta OSC
live preview (against a local fake camera speaking the OSC protocol), snapshot URLs,
sequences, the capture thread's loss and recovery, and source specifications."""
from __future__ import annotations

import io
import hashlib
import json
import re
import os
from pathlib import Path
import shutil
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import numpy as np
import pytest

from provider import InputError
from provider.live.probe.capture import Capture
from provider.live.sources import SourceError, SourceOptions, parse_source
from provider.live.sources.http import MultipartJpegReader
from provider.live.sources.theta import ThetaSource

from fakecams.osc_camera import OscHandler
from servertools import (MjpegCamera, ServerThread, coefficients, connect, jpeg_panorama,
                         poll, recv_json, recv_until)

HDRI = os.path.join(str(Path(__file__).resolve().parents[2]), "data", "hdri")
BRIDGE = os.path.join(HDRI, "bridge.exr")
SKY = os.path.join(HDRI, "sky.exr")


class Trickle(io.RawIOBase):
    """A stream that hands out at most ``step`` bytes per read (a slow network)."""

    def __init__(self, data: bytes, step: int = 7):
        self._data, self._pos, self._step = data, 0, step

    def readable(self):
        return True

    def read1(self, n=-1):
        out = self._data[self._pos:self._pos + min(self._step, n if n > 0 else self._step)]
        self._pos += len(out)
        return out

    read = read1


def _multipart(frames, boundary="frame", content_length=True, preamble=b""):
    body = preamble
    for f in frames:
        body += f"--{boundary}\r\nContent-Type: image/jpeg\r\n".encode()
        if content_length:
            body += f"Content-Length: {len(f)}\r\n".encode()
        body += b"\r\n" + f + b"\r\n"
    return body


@pytest.mark.parametrize("content_length", [True, False])
@pytest.mark.parametrize("boundary", ["frame", "---osclivepreview---"])
@pytest.mark.parametrize("step", [7, 1 << 16])
def test_multipart_reader_splits_frames(content_length, boundary, step):
    frames = [jpeg_panorama(32, (i * 40, 100, 200 - i * 40)) for i in range(4)]
    body = _multipart(frames, boundary, content_length, preamble=b"garbage\r\n")
    reader = MultipartJpegReader(Trickle(body, step))
    assert [reader.next_jpeg() for _ in frames] == frames
    with pytest.raises(SourceError, match="ended"):
        reader.next_jpeg()


def test_multipart_reader_trusts_content_length_over_markers():
    """A JPEG may hold FF D9 inside (e.g. a thumbnail in EXIF): Content-Length wins."""
    tricky = jpeg_panorama(32)[:-2] + b"\xff\xd9" + b"tail\xff\xd9"
    body = _multipart([tricky, jpeg_panorama(32)])
    reader = MultipartJpegReader(Trickle(body, 1000))
    assert reader.next_jpeg() == tricky


def test_multipart_reader_refuses_endless_garbage():
    reader = MultipartJpegReader(Trickle(b"\xff\xd8\xff" + b"\x00" * 5000, 1000),
                                 max_frame_bytes=2000)
    with pytest.raises(SourceError, match="no complete JPEG"):
        reader.next_jpeg()


# ---- a fake Ricoh Theta (Open Spherical Camera API) ----------------------------------------------------

class FakeTheta:
    """POST /osc/commands/execute, as a Theta S (api="2.0": startSession then
    camera._getLivePreview) or a Theta V/Z1 (api="2.1": camera.getLivePreview). The
    live preview is a chunked multipart MJPEG body with the Theta's boundary."""

    def __init__(self, api: str, frame: bytes, digest: tuple[str, str] | None = None):
        self.api, self.frame, self.commands = api, frame, []
        self.digest, self.refused = digest, 0
        theta = self

        class Handler(OscHandler):
            def _digest_ok(self) -> bool:
                """RFC 7616 Digest (MD5, qop=auth), as a Theta in client mode asks for."""
                auth = self.headers.get("Authorization", "")
                if not auth.startswith("Digest "):
                    return False
                f = dict(re.findall(r'(\w+)="?([^",]*)"?', auth[7:]))
                user, password = theta.digest
                md5 = lambda t: hashlib.md5(t.encode()).hexdigest()  # noqa: E731
                ha1 = md5(f"{user}:{DIGEST_REALM}:{password}")
                ha2 = md5(f"POST:{f.get('uri')}")
                want = md5(f"{ha1}:{f.get('nonce')}:{f.get('nc')}:{f.get('cnonce')}:auth:{ha2}")
                return f.get("username") == user and f.get("response") == want

            def do_POST(self):
                if self.path != "/osc/commands/execute":
                    return self._json(404, {"error": "not found"})
                cmd = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
                if theta.digest and not self._digest_ok():
                    theta.refused += 1
                    self.send_response(401)
                    self.send_header("WWW-Authenticate", f'Digest realm="{DIGEST_REALM}", '
                                     'nonce="6fa3a2b1c0", qop="auth", algorithm=MD5')
                    self.send_header("Content-Length", "0")
                    self.end_headers()
                    return
                name = cmd["name"]
                theta.commands.append(name)
                if name == "camera.startSession" and theta.api == "2.0":
                    return self._json(200, {"name": name, "state": "done",
                                            "results": {"sessionId": "SID_0001",
                                                        "timeout": 180}})
                if name == "camera.closeSession":
                    return self._json(200, {"name": name, "state": "done"})
                live = (name == "camera.getLivePreview" and theta.api == "2.1") or (
                    name == "camera._getLivePreview" and theta.api == "2.0"
                    and cmd["parameters"].get("sessionId") == "SID_0001")
                if not live:
                    return self._json(400, {"name": name, "state": "error", "error": {
                        "code": "unknownCommand", "message": "Command executed is unknown."}})
                self._live_preview((theta.frame for _ in range(200)), 0.05)

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        threading.Thread(target=self.httpd.serve_forever, daemon=True,
                         kwargs={"poll_interval": 0.05}).start()

    @property
    def spec(self):
        return f"theta://127.0.0.1:{self.httpd.server_address[1]}"

    def close(self):
        self.httpd.shutdown()
        self.httpd.server_close()


@pytest.mark.parametrize("api", ["2.0", "2.1"])
def test_theta_live_preview(api):
    frame = jpeg_panorama(64, lamp=True)
    cam = FakeTheta(api, frame)
    try:
        src = ThetaSource(cam.spec, SourceOptions(timeout=5))
        src.open()
        try:
            assert src.api_used == api
            for _ in range(3):
                f = src.read()
                assert f.jpeg == frame
                assert f.decoded().shape == (32, 64, 3)
        finally:
            src.close()
        if api == "2.0":
            assert cam.commands[:3] == ["camera.getLivePreview", "camera.startSession",
                                        "camera._getLivePreview"]
            assert cam.commands[-1] == "camera.closeSession"
        else:
            assert cam.commands == ["camera.getLivePreview"]
        # the whole way: shlight serve --source theta://...
        with ServerThread("--source", cam.spec) as srv, connect(srv.url) as ws:
            recv_json(ws)
            msg = recv_until(ws, lambda m: m["type"] == "sh9" and not m["stale"], timeout=20)
            assert msg["source"] == "theta"
    finally:
        cam.close()


DIGEST_REALM = "RICOH THETA Z1"


def test_theta_client_mode_digest_auth():
    """In client mode the Theta answers 401 with a Digest challenge: credentials in the URL
    are used; a wrong password is one clear error, not a traceback or a hang."""
    frame = jpeg_panorama(64)
    cam = FakeTheta("2.1", frame, digest=("THETAYL00100001", "00100001"))
    try:
        host = cam.spec[len("theta://"):]
        src = ThetaSource(f"theta://THETAYL00100001:00100001@{host}", SourceOptions(timeout=5))
        src.open()
        try:
            assert src.read().jpeg == frame
        finally:
            src.close()
        assert cam.refused >= 1  # the challenge really was answered
        bad = ThetaSource(f"theta://THETAYL00100001:wrong@{host}", SourceOptions(timeout=5))
        with pytest.raises(SourceError, match="refused the credentials"):
            bad.open()
        bad.close()
        with pytest.raises(SourceError, match="USER:PASSWORD"):  # no credentials at all
            ThetaSource(cam.spec, SourceOptions(timeout=5)).open()
    finally:
        cam.close()


def test_theta_api_option_is_checked():
    with pytest.raises(InputError):
        parse_source("theta://192.168.1.1?api=3.0")
    with pytest.raises(InputError):
        parse_source("theta://")


# ---- snapshot URLs, sequences, files that come and go ---------------------------------------------------

def test_snapshot_url_is_polled():
    frame = jpeg_panorama(64)

    class Handler(BaseHTTPRequestHandler):
        hits = 0

        def log_message(self, *args):
            pass

        def do_GET(self):
            Handler.hits += 1
            self.send_response(200)
            self.send_header("Content-Type", "image/jpeg")
            self.send_header("Content-Length", str(len(frame)))
            self.end_headers()
            self.wfile.write(frame)

    httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    try:
        url = f"http://127.0.0.1:{httpd.server_address[1]}/snap.jpg"
        with ServerThread("--source", url, "--fps", "10") as srv, connect(srv.url) as ws:
            recv_json(ws)
            assert not recv_until(ws, lambda m: m["type"] == "sh9", timeout=20)["stale"]
            poll(lambda: Handler.hits >= 5, timeout=20, what="repeated snapshots")
    finally:
        httpd.shutdown()
        httpd.server_close()


def test_sequence_changes_reach_clients(tmp_path):
    shutil.copy(BRIDGE, tmp_path / "a.exr")
    shutil.copy(SKY, tmp_path / "b.exr")
    with ServerThread("--source", str(tmp_path / "*.exr"), "--fps", "5", "--smoothing", "5",
                      "--change-threshold", "0.01") as srv, connect(srv.url) as ws:
        recv_json(ws)
        seen = []
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and len(seen) < 4:
            m = recv_until(ws, lambda m: m["type"] == "sh9" and not m["resent"], timeout=20)
            c = coefficients(m)
            if not seen or not np.allclose(c, seen[-1], rtol=1e-9):
                seen.append(c)
        assert len(seen) >= 4                     # a, b, a, b: the loop came round
        np.testing.assert_allclose(seen[0], seen[2], rtol=1e-9)
        np.testing.assert_allclose(seen[1], seen[3], rtol=1e-9)
        assert not np.allclose(seen[0], seen[1])


def test_capture_loses_and_recovers_a_file(tmp_path):
    path = tmp_path / "pano.exr"
    shutil.copy(BRIDGE, path)
    spec = parse_source(str(path), SourceOptions(fps=20))
    cap = Capture(spec, name="t", backoff_min=0.05, backoff_max=0.2)
    cap.start()
    try:
        poll(lambda: cap.state == "live" and cap.take() is not None, what="live")
        os.remove(path)
        poll(lambda: cap.state == "lost", what="lost")
        assert "cannot read" in cap.reason
        shutil.copy(SKY, path)
        poll(lambda: cap.state == "live", what="reconnected")
        cap.take()
        frame = poll(cap.take, what="a frame after reconnecting")
        assert frame.image.shape == (256, 512, 3)
        assert cap.reconnects >= 1
    finally:
        cap.stop()
    assert cap._thread is not None and not cap._thread.is_alive()


def test_capture_keeps_only_the_newest_frame():
    frame = jpeg_panorama(32)
    with MjpegCamera(frame, fps=100) as cam:
        cap = Capture(parse_source(cam.url), name="t")
        cap.start()
        try:
            poll(lambda: cap.frames >= 20, what="frames")
            taken = cap.take()
            assert taken is not None and taken.jpeg == frame
            # no backlog: right after a take there is at most the one newest frame
            assert cap.take() is None or cap.take() is None
        finally:
            cap.stop()


@pytest.mark.parametrize("spec, kind", [
    ("demo", "demo"), ("0", "camera"), ("camera:2", "camera"), ("/dev/video0", "camera"),
    ("picamera2", "picamera2"), ("http://cam/stream.mjpg", "mjpeg"),
    ("rtsp://cam/live", "opencv"), ("opencv:foo", "opencv"), ("theta://192.168.1.1", "theta"),
    ("ws://127.0.0.1:8765/?probe=x", "relay"), (BRIDGE, "image"), (HDRI, "sequence"),
])
def test_parse_source_kinds(spec, kind):
    assert parse_source(spec).kind == kind


@pytest.mark.parametrize("spec", ["", "ftp://x", "/no/such/file.exr", "/no/such/dir/*.png"])
def test_parse_source_refuses(spec):
    with pytest.raises(InputError):
        parse_source(spec)


def test_redacted_descriptions():
    spec = parse_source("http://user:pw@cam/stream?token=abc")
    assert "pw" not in spec.description and "abc" not in spec.description


def _write_video(path, frames=10, fps=20):
    import cv2
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (64, 32))
    assert writer.isOpened()
    for i in range(frames):
        img = np.full((32, 64, 3), 40 + 20 * i, np.uint8)
        writer.write(img)
    writer.release()


def test_video_file_loops(tmp_path):
    path = tmp_path / "clip.avi"
    _write_video(path)
    with ServerThread("--source", str(path), "--change-threshold", "0") as srv, \
            connect(srv.url) as ws:
        recv_json(ws)
        first = recv_until(ws, lambda m: m["type"] == "sh9", timeout=20)
        assert first["source"] == "video"
        # 10 frames at 20 fps: well past the end, frames still come (looped), fresh
        poll(lambda: srv.server.probes["default"].frames_processed >= 25, timeout=30,
             what="frames beyond the end of the clip")
        assert not recv_until(ws, lambda m: m["type"] == "sh9")["stale"]


def test_video_played_once_goes_stale_but_keeps_serving(tmp_path):
    path = tmp_path / "clip.avi"
    _write_video(path, frames=5)
    with ServerThread("--source", str(path), "--no-loop", "--keepalive", "0.2",
                      "--stale-after", "0.5") as srv, connect(srv.url) as ws:
        recv_json(ws)
        stale = recv_until(ws, lambda m: m["type"] == "sh9" and m["stale"], timeout=20)
        assert len(stale["coefficients"]) == 27
        assert srv.server.probes["default"].capture.state == "finished"
        again = recv_until(ws, lambda m: m["type"] == "sh9", timeout=5)
        assert again["stale"] and again["seq"] > stale["seq"]


def test_files_that_are_not_frames_are_refused_at_start(tmp_path):
    for name in ("broken.mp4", "notes.txt"):
        path = tmp_path / name
        path.write_bytes(b"this is not a video")
        with pytest.raises(InputError, match="cannot open"):
            parse_source(str(path))
