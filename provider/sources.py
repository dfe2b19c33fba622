"""Frame sources for ``shlight serve``, and the capture thread that reads them.

A *source* is a small blocking object with three methods: :meth:`Source.open` connects,
:meth:`Source.read` blocks until the next :class:`Frame` arrives and returns it, and
:meth:`Source.close` lets go. A source raises :class:`SourceError` when it loses its
camera or stream, and :class:`SourceFinished` at the end of a video that does not loop.

:class:`Capture` runs a source in a background thread, so that slow or hung I/O never
blocks the event loop. It keeps only the newest frame (no backlog: a slow consumer sees
fewer frames, never older ones), reports the source as connected or lost, and after a
failure builds a *fresh* source object and reconnects with exponential backoff (an
OpenCV capture whose ``read()`` failed once does not recover: DESIGN.md §8). A read
that hangs (OpenCV on a dropped network stream) is detected by a watchdog: the stuck
thread is abandoned and a new attempt starts.

Source specifications (``--source SPEC`` or ``--probe NAME=SPEC``)::

    demo                        built-in animated scene (the default)
    PATH.exr | .hdr | .png ...  one image, re-read whenever the file changes
    'DIR/*.exr' | DIR           an image sequence (sorted), looped
    PATH.mp4 | .avi | .mkv ...  a video file, looped (--no-loop: play once)
    0 | camera:0 | /dev/video0  a camera (e.g. a Ricoh Theta in USB live mode)
    picamera2[:N]               a Raspberry Pi camera through Picamera2
    http[s]://...               MJPEG over HTTP (multipart/x-mixed-replace), or a JPEG
                                snapshot URL polled at --fps; credentials as USER:PASS@
    rtsp://... | opencv:TARGET  anything cv2.VideoCapture opens (FFmpeg back end)
    theta://[USER:PASS@]HOST[:PORT][?api=2.0|2.1]
                                a Ricoh Theta over Wi-Fi: Open Spherical Camera live
                                preview (HTTP Digest auth in client mode)
    ws[s]://HOST:PORT/[?probe=NAME&token=T]
                                relay: the coefficients of another ``shlight serve``

Only the standard library, OpenCV and ``websockets`` are used.
"""
from __future__ import annotations

import collections
import glob
import json
import logging
import math
import os
import re
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
from dataclasses import dataclass, field

import cv2
import numpy as np

from .engine import InputError

log = logging.getLogger("shlight.source")

VIDEO_EXTENSIONS = (".mp4", ".m4v", ".mov", ".avi", ".mkv", ".webm", ".mjpeg", ".mjpg",
                    ".mpg", ".mpeg", ".ts", ".wmv", ".flv", ".ogv")
USER_AGENT = "shlight"


class SourceError(Exception):
    """The source lost its camera or stream (the message says why); it will be re-created."""


class SourceFinished(Exception):
    """A finite source (a video played once) has no more frames."""


class _Interrupted(Exception):
    """The capture is stopping."""


@dataclass
class Frame:
    """One frame from a source.

    ``image`` is an (H, W, 3) RGB array (uint8, uint16 or float: the engine's frame
    contract). MJPEG sources deliver ``jpeg`` bytes instead and the consumer decodes only
    the frames it uses (:meth:`decoded`), so that frames skipped under load cost nothing.
    A relay delivers ready-made ``lighting`` (an :class:`~provider.engine.SH9Result`).
    ``time`` is the unix time of capture (arrival, for network streams).
    """

    image: np.ndarray | None
    time: float
    jpeg: bytes | None = None
    lighting: object = None
    info: dict = field(default_factory=dict)

    def decoded(self) -> np.ndarray:
        """The RGB image, decoding ``jpeg`` on first use; :class:`InputError` if corrupt."""
        if self.image is None and self.jpeg is not None:
            bgr = cv2.imdecode(np.frombuffer(self.jpeg, np.uint8), cv2.IMREAD_COLOR)
            if bgr is None:
                raise InputError(f"corrupt JPEG frame ({len(self.jpeg)} bytes)")
            self.image = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
        if self.image is None:
            raise InputError("frame has no image")
        return self.image


@dataclass
class SourceOptions:
    """Options shared by the sources (each uses the ones that apply to it)."""

    fps: float | None = None          # pace of demo/files; polling rate of snapshot URLs
    loop: bool = True                 # videos and sequences
    timeout: float = 5.0              # seconds: connect/read timeout, hang detection
    capture_size: tuple[int, int] | None = None   # cameras: requested (width, height)
    fourcc: str | None = None         # cameras: e.g. "MJPG"
    theta_api: str = "auto"           # "auto", "2.0" or "2.1"


class Source:
    """Base class: a blocking frame reader (see the module docstring)."""

    #: Frames per second the source is expected to deliver (None: unknown, e.g. a camera).
    nominal_fps: float | None = None

    def __init__(self):
        self._stop = threading.Event()

    def open(self) -> None:
        """Connect; raise :class:`SourceError` (or ``OSError``) on failure."""

    def read(self) -> Frame:
        """Block until the next frame and return it."""
        raise NotImplementedError

    def close(self) -> None:
        """Release the camera, file or connection (called after any failure too)."""

    def interrupt(self) -> None:
        """Ask a blocked :meth:`read` to give up soon (called from another thread)."""
        self._stop.set()

    def _sleep(self, seconds: float) -> None:
        if seconds > 0 and self._stop.wait(seconds):
            raise _Interrupted()


class _Pacer:
    """Releases a caller at a steady rate without bursts after a pause."""

    def __init__(self, fps: float):
        self.interval = 1.0 / fps
        self._next = None

    def wait(self, source: Source) -> None:
        now = time.monotonic()
        if self._next is None:
            self._next = now
        source._sleep(self._next - now)
        self._next = max(self._next + self.interval, time.monotonic() - self.interval)


# ---- the built-in demo scene -----------------------------------------------------------------

class DemoSource(Source):
    """An animated HDR panorama, so that a new user sees lighting change with no camera.

    256×128 float32 linear radiance (equirect, DESIGN.md §1): a blue sky over brown
    ground, a sun circling the horizon once every ``period`` seconds, and a warm red lamp
    at +X that switches on and off every ``switch`` seconds.
    """

    def __init__(self, width: int = 256, height: int = 128, fps: float = 30.0,
                 period: float = 20.0, switch: float = 3.0):
        super().__init__()
        self.width, self.height, self.period, self.switch = width, height, period, switch
        self.nominal_fps = fps
        self._pacer = _Pacer(fps)
        v = (np.arange(height) + 0.5) / height
        u = (np.arange(width) + 0.5) / width
        theta = np.pi * v[:, None]
        phi = 2 * np.pi * (u[None, :] - 0.5)
        self._dirs = np.stack(np.broadcast_arrays(
            np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)),
            axis=-1).astype(np.float32)                                    # (H, W, 3)
        up = self._dirs[..., 1:2]
        zenith, horizon = np.array([0.20, 0.38, 0.85]), np.array([0.85, 0.90, 1.00])
        ground = np.array([0.22, 0.17, 0.12])
        sky = horizon + (zenith - horizon) * np.sqrt(np.clip(up, 0, 1))
        earth = ground * (0.5 + 0.5 * np.clip(1 + up, 0, 1))
        blend = np.clip(up * 20 + 0.5, 0, 1)                                # soft horizon
        self._base = (earth + (sky - earth) * blend).astype(np.float32)
        self._t0 = time.time()

    def _disc(self, direction, radius_deg: float, softness_deg: float) -> np.ndarray:
        """Soft-edged disc mask (H, W, 1) around ``direction``."""
        cos_d = self._dirs @ np.asarray(direction, np.float32)
        inner, outer = math.radians(radius_deg), math.radians(radius_deg + softness_deg)
        w = (cos_d - math.cos(outer)) / (math.cos(inner) - math.cos(outer))
        return np.clip(w, 0, 1)[..., None]

    def render(self, t: float) -> np.ndarray:
        """The scene ``t`` seconds after the start (a new array)."""
        az = 2 * math.pi * t / self.period
        el = math.radians(35)
        sun = (math.cos(el) * math.sin(az), math.sin(el), -math.cos(el) * math.cos(az))
        img = self._base + self._disc(sun, 4.0, 1.5) * np.float32([180, 165, 140])
        img += self._disc(sun, 12.0, 10.0) * np.float32([1.5, 1.3, 1.0])    # glow
        if int(t // self.switch) % 2 == 0:                                 # the lamp
            lamp = (math.cos(math.radians(10)), math.sin(math.radians(10)), 0.0)
            img += self._disc(lamp, 9.0, 2.0) * np.float32([60, 14, 4])
        return img

    def read(self) -> Frame:
        self._pacer.wait(self)
        now = time.time()
        return Frame(self.render(now - self._t0), now)


# ---- files ---------------------------------------------------------------------------------------

def _read_image(path: str) -> np.ndarray:
    from .io import read_image
    return read_image(path)


class ImageSource(Source):
    """One image file, delivered at ``fps`` and re-read whenever its modification time
    changes (another program may rewrite it; write it atomically, e.g. with a rename)."""

    def __init__(self, path: str, fps: float = 2.0):
        super().__init__()
        self.path, self.nominal_fps = path, fps
        self._pacer = _Pacer(fps)
        self._image, self._mtime = None, None

    def open(self) -> None:
        self._load()

    def _load(self) -> None:
        try:
            st = os.stat(self.path)
        except OSError as exc:
            raise SourceError(f"cannot read {self.path}: {exc.strerror}") from None
        # The modification time alone misses a file replaced (renamed over) within the
        # file system's timestamp granularity: the inode and size tell those apart.
        mtime = (st.st_mtime_ns, st.st_size, st.st_ino, st.st_dev)
        if mtime != self._mtime:
            try:
                self._image = _read_image(self.path)
                self._mtime = mtime
            except InputError as exc:
                if self._image is None:
                    raise SourceError(str(exc)) from None
                log.debug("%s: keeping the previous image (%s)", self.path, exc)

    def read(self) -> Frame:
        self._pacer.wait(self)
        self._load()
        return Frame(self._image, time.time(), info={"path": self.path})


class SequenceSource(Source):
    """Image files matching a glob (or all images in a directory), in name order, at
    ``fps``; looped (the glob is expanded again at every loop, so new files join)."""

    def __init__(self, pattern: str, fps: float = 1.0, loop: bool = True):
        super().__init__()
        self.pattern, self.loop, self.nominal_fps = pattern, loop, fps
        self._pacer = _Pacer(fps)
        self._paths: list[str] = []
        self._index = 0

    @staticmethod
    def expand(pattern: str) -> list[str]:
        from .io import IMAGE_EXTENSIONS
        if os.path.isdir(pattern):
            pattern = os.path.join(pattern, "*")
        return sorted(p for p in glob.glob(pattern)
                      if p.lower().endswith(IMAGE_EXTENSIONS) and os.path.isfile(p))

    def open(self) -> None:
        self._paths = self.expand(self.pattern)
        if not self._paths:
            raise SourceError(f"no image files match {self.pattern}")

    def read(self) -> Frame:
        self._pacer.wait(self)
        if self._index >= len(self._paths):
            if not self.loop:
                raise SourceFinished()
            self.open()
            self._index = 0
        path = self._paths[self._index]
        self._index += 1
        try:
            image = _read_image(path)
        except InputError as exc:
            raise SourceError(str(exc)) from None
        return Frame(image, time.time(), info={"path": path})


# ---- OpenCV captures -------------------------------------------------------------------------------

def _bgr_to_rgb(img: np.ndarray) -> np.ndarray:
    if img.ndim == 2:
        return cv2.cvtColor(img, cv2.COLOR_GRAY2RGB)
    if img.shape[2] == 4:
        return cv2.cvtColor(img, cv2.COLOR_BGRA2RGB)
    return cv2.cvtColor(img, cv2.COLOR_BGR2RGB)


class VideoFileSource(Source):
    """A video file through ``cv2.VideoCapture``, paced at its own frame rate (or ``fps``),
    looped unless ``loop`` is false."""

    def __init__(self, path: str, fps: float | None = None, loop: bool = True):
        super().__init__()
        self.path, self.loop, self._fps = path, loop, fps
        self._cap = None
        self._pacer = None

    def open(self) -> None:
        self._cap = cv2.VideoCapture(self.path)
        if not self._cap.isOpened():
            raise SourceError(f"OpenCV cannot open the video {self.path}")
        fps = self._fps or self._cap.get(cv2.CAP_PROP_FPS)
        self.nominal_fps = fps if fps and 0 < fps < 1000 else 30.0
        self._pacer = _Pacer(self.nominal_fps)

    def read(self) -> Frame:
        self._pacer.wait(self)
        ok, img = self._cap.read()
        if not ok:
            if not self.loop:
                raise SourceFinished()
            self._cap.set(cv2.CAP_PROP_POS_FRAMES, 0)
            ok, img = self._cap.read()
            if not ok:
                raise SourceError(f"cannot read a frame from {self.path}")
        return Frame(_bgr_to_rgb(img), time.time())

    def close(self) -> None:
        if self._cap is not None:
            self._cap.release()


class OpenCVSource(Source):
    """A camera (index or device path) or a network stream (RTSP, HTTP, ...) read by
    ``cv2.VideoCapture``.

    Streams open with the FFmpeg back end and ``timeout`` as both open and read timeout
    (honoured only at open time and only by FFmpeg/GStreamer: DESIGN.md §8); a read that
    hangs anyway is caught by the :class:`Capture` watchdog.
    """

    def __init__(self, target, options: SourceOptions):
        super().__init__()
        self.target, self.options = target, options
        self._cap = None

    def open(self) -> None:
        t, ms = self.target, int(self.options.timeout * 1000)
        if isinstance(t, int) or t.startswith("/dev/"):
            cap = cv2.VideoCapture(t)
            if self.options.fourcc:
                cap.set(cv2.CAP_PROP_FOURCC, cv2.VideoWriter_fourcc(*self.options.fourcc[:4]))
            if self.options.capture_size:
                cap.set(cv2.CAP_PROP_FRAME_WIDTH, self.options.capture_size[0])
                cap.set(cv2.CAP_PROP_FRAME_HEIGHT, self.options.capture_size[1])
            cap.set(cv2.CAP_PROP_BUFFERSIZE, 1)     # the newest frame, not a queue of old ones
        else:
            cap = cv2.VideoCapture(t, cv2.CAP_FFMPEG, [cv2.CAP_PROP_OPEN_TIMEOUT_MSEC, ms,
                                                       cv2.CAP_PROP_READ_TIMEOUT_MSEC, ms])
        self._cap = cap
        if not cap.isOpened():
            raise SourceError(f"OpenCV cannot open {_redact(str(t))}")
        fps = cap.get(cv2.CAP_PROP_FPS)
        self.nominal_fps = fps if fps and 0 < fps < 1000 else None

    def read(self) -> Frame:
        if self._stop.is_set():
            raise _Interrupted()
        ok, img = self._cap.read()
        if not ok or img is None:
            raise SourceError("no frame (read failed)")
        return Frame(_bgr_to_rgb(img), time.time())

    def close(self) -> None:
        if self._cap is not None:
            self._cap.release()


class Picamera2Source(Source):
    """A Raspberry Pi camera through Picamera2 (OpenCV has no libcamera back end).

    Picamera2's "RGB888" format arrives in B, G, R byte order (DESIGN.md §8): it is
    swapped here.
    """

    def __init__(self, index: int, options: SourceOptions):
        super().__init__()
        self.index, self.options = index, options
        self._cam = None

    def open(self) -> None:
        try:
            from picamera2 import Picamera2
        except ImportError:
            raise SourceError("picamera2 is not installed (on Raspberry Pi OS: "
                              "sudo apt install python3-picamera2)") from None
        self._cam = Picamera2(self.index)
        size = self.options.capture_size or (1280, 960)
        controls = {}
        if self.options.fps:  # --fps caps the sensor rate: a slow edge core is not flooded
            frame_us = int(round(1e6 / self.options.fps))
            controls["FrameDurationLimits"] = (frame_us, frame_us)
        config = self._cam.create_video_configuration(main={"format": "RGB888", "size": size},
                                                      controls=controls)
        self._cam.configure(config)
        self._cam.start()

    def read(self) -> Frame:
        if self._stop.is_set():
            raise _Interrupted()
        bgr = self._cam.capture_array("main")
        return Frame(np.ascontiguousarray(bgr[..., 2::-1]), time.time())

    def close(self) -> None:
        if self._cam is not None:
            try:
                self._cam.stop()
                self._cam.close()
            except Exception:  # noqa: BLE001 - best effort on a camera that is gone
                pass


# ---- MJPEG over HTTP (cameras, Pi streamers) and the Theta's OSC live preview --------------------

_CONTENT_LENGTH = re.compile(rb"(?im)^content-length[ \t]*:[ \t]*(\d+)[ \t]*\r?$")
_SOI, _EOI = b"\xff\xd8\xff", b"\xff\xd9"


class MultipartJpegReader:
    """JPEG frames out of an MJPEG HTTP body (``multipart/x-mixed-replace``).

    Real cameras are loose about the multipart syntax (the Theta's boundary is
    ``---osclivepreview---`` with or without the leading dashes), so the reader does not
    rely on the boundary: a part's ``Content-Length`` header, when present, gives the
    JPEG's size after its start-of-image marker (FF D8 FF); otherwise the JPEG runs to
    the next end-of-image marker (FF D9). ``stream`` is a file-like object (an
    ``http.client.HTTPResponse``: chunked transfer encoding is undone by it); a read that
    times out raises ``TimeoutError``.
    """

    def __init__(self, stream, max_frame_bytes: int = 16 << 20, chunk: int = 1 << 16):
        self._stream, self.max_frame_bytes, self._chunk = stream, max_frame_bytes, chunk
        self._read = getattr(stream, "read1", None) or stream.read
        self._buf = bytearray()

    def next_jpeg(self) -> bytes:
        while True:
            jpeg = self._extract()
            if jpeg is not None:
                return jpeg
            if len(self._buf) > self.max_frame_bytes:
                raise SourceError(f"no complete JPEG in {len(self._buf)} bytes of the stream")
            data = self._read(self._chunk)
            if not data:
                raise SourceError("the stream ended")
            self._buf += data

    def _extract(self) -> bytes | None:
        buf = self._buf
        soi = buf.find(_SOI)
        if soi < 0:
            if len(buf) > 4096:          # boundary lines and headers only: keep the tail
                del buf[:-4096]
            return None
        lengths = _CONTENT_LENGTH.findall(bytes(buf[max(0, soi - 2048):soi]))
        if lengths:
            end = soi + int(lengths[-1])
            if end > len(buf):
                return None
        else:
            eoi = buf.find(_EOI, soi + 3)
            if eoi < 0:
                return None
            end = eoi + 2
        jpeg = bytes(buf[soi:end])
        del buf[:end]
        return jpeg


def _split_credentials(url: str) -> tuple[str, str | None, str | None]:
    """(url without user:password@, user, password)."""
    parts = urllib.parse.urlsplit(url)
    if parts.username is None:
        return url, None, None
    host = parts.hostname or ""
    if ":" in host:
        host = f"[{host}]"
    netloc = host + (f":{parts.port}" if parts.port else "")
    clean = urllib.parse.urlunsplit((parts.scheme, netloc, parts.path, parts.query, parts.fragment))
    return (clean, urllib.parse.unquote(parts.username),
            urllib.parse.unquote(parts.password or ""))


def _redact(url: str) -> str:
    """The URL for logs: no password, no token."""
    clean, user, _ = _split_credentials(url)
    parts = urllib.parse.urlsplit(clean)
    query = "&".join(q if not q.lower().startswith("token=") else "token=***"
                     for q in parts.query.split("&")) if parts.query else ""
    return urllib.parse.urlunsplit(parts._replace(query=query))


def _opener(url: str, user: str | None, password: str | None):
    """An urllib opener answering Basic and Digest challenges with the credentials."""
    handlers = []
    if user is not None:
        mgr = urllib.request.HTTPPasswordMgrWithDefaultRealm()
        mgr.add_password(None, url, user, password or "")
        handlers += [urllib.request.HTTPDigestAuthHandler(mgr),
                     urllib.request.HTTPBasicAuthHandler(mgr)]
    return urllib.request.build_opener(*handlers)


def _http_error_text(exc: urllib.error.HTTPError) -> str:
    try:
        body = exc.read(2048).decode("utf-8", "replace").strip()
    except Exception:  # noqa: BLE001
        body = ""
    return f"HTTP {exc.code} {exc.reason}" + (f": {body[:200]}" if body else "")


class MjpegHttpSource(Source):
    """An MJPEG stream over HTTP (``multipart/x-mixed-replace``), read with the standard
    library and our own :class:`MultipartJpegReader` so that a stalled stream times out
    (socket timeout) instead of hanging. A URL that answers with a single JPEG is polled
    as a snapshot URL at ``fps`` (default 5)."""

    def __init__(self, url: str, options: SourceOptions):
        super().__init__()
        self.url, user, password = _split_credentials(url)
        self.options = options
        self._open = _opener(self.url, user, password).open
        self._resp, self._reader, self._snapshot_pacer = None, None, None

    def _get(self):
        req = urllib.request.Request(self.url, headers={"User-Agent": USER_AGENT})
        try:
            return self._open(req, timeout=self.options.timeout)
        except urllib.error.HTTPError as exc:
            raise SourceError(f"{_redact(self.url)}: {_http_error_text(exc)}") from None
        except urllib.error.URLError as exc:
            raise SourceError(f"{_redact(self.url)}: {exc.reason}") from None

    def open(self) -> None:
        self._resp = self._get()
        ctype = self._resp.headers.get_content_type()
        if ctype.startswith("multipart/"):
            self._reader = MultipartJpegReader(self._resp)
        elif ctype.startswith("image/"):
            self._snapshot_pacer = _Pacer(self.options.fps or 5.0)
            self.nominal_fps = self.options.fps or 5.0
        else:
            raise SourceError(f"{_redact(self.url)} sends {ctype}, neither MJPEG "
                              f"(multipart/x-mixed-replace) nor an image; for a video stream "
                              f"use opencv:{_redact(self.url)}")

    def read(self) -> Frame:
        if self._reader is not None:
            return Frame(None, time.time(), jpeg=self._reader.next_jpeg())
        self._snapshot_pacer.wait(self)
        if self._resp is None:
            self._resp = self._get()
        try:
            data = self._resp.read()
        finally:
            self._resp.close()
            self._resp = None
        return Frame(None, time.time(), jpeg=data)

    def close(self) -> None:
        if self._resp is not None:
            self._resp.close()


class OscCommandError(SourceError):
    """An Open Spherical Camera command answered with an error."""

    def __init__(self, command: str, code: str, message: str):
        super().__init__(f"{command}: {code}: {message}")
        self.code = code


class ThetaSource(Source):
    """A Ricoh Theta over Wi-Fi: the Open Spherical Camera live preview (DESIGN.md §8).

    Every command is ``POST /osc/commands/execute`` with ``{"name", "parameters"}``. API
    2.1 (Theta V/Z1, and an S switched to 2.1): ``camera.getLivePreview``. API 2.0 (the
    Theta S default): ``camera.startSession`` gives a ``sessionId``, then
    ``camera._getLivePreview {sessionId}``. ``api="auto"`` tries 2.1 and falls back to
    2.0 when the camera rejects the command. The reply is an endless MJPEG multipart body
    of equirect frames (S/SC: 640×320 at 10 fps). In client mode the camera asks for
    HTTP Digest auth: give ``theta://USER:PASSWORD@HOST``.
    """

    EXECUTE = "/osc/commands/execute"

    def __init__(self, url: str, options: SourceOptions):
        super().__init__()
        parts = urllib.parse.urlsplit(url)
        query = urllib.parse.parse_qs(parts.query)
        self.api = query.get("api", [options.theta_api])[0]
        if self.api not in ("auto", "2.0", "2.1"):
            raise InputError(f"theta source: api must be 2.0, 2.1 or auto, got {self.api!r}")
        scheme = "https" if parts.scheme.endswith("s") and parts.scheme != "theta" else "http"
        base = urllib.parse.urlunsplit((scheme, parts.netloc, "", "", ""))
        self.base, user, password = _split_credentials(base)
        self.options = options
        self._open = _opener(self.base, user, password).open
        self._resp, self._reader, self._session = None, None, None
        self.api_used = None

    def _execute(self, name: str, parameters: dict, *, stream: bool = False,
                 timeout: float | None = None):
        body = json.dumps({"name": name, "parameters": parameters}).encode()
        req = urllib.request.Request(self.base + self.EXECUTE, data=body, method="POST", headers={
            "Content-Type": "application/json;charset=utf-8", "Accept": "*/*",
            "X-XSRF-Protected": "1", "User-Agent": USER_AGENT})
        try:
            resp = self._open(req, timeout=timeout or self.options.timeout)
        except urllib.error.HTTPError as exc:
            if exc.code == 401:  # client mode: Digest auth refused or not given
                raise SourceError(
                    f"{self.base}: the camera refused the credentials (HTTP 401); in client "
                    "mode give theta://USER:PASSWORD@HOST (user: the serial number, e.g. "
                    "THETAYL00100001; password: its digits)") from None
            try:
                err = json.loads(exc.read(4096) or b"{}").get("error") or {}
            except ValueError:
                err = {}
            raise OscCommandError(name, str(err.get("code", f"HTTP {exc.code}")),
                                  str(err.get("message", exc.reason))) from None
        except urllib.error.URLError as exc:
            raise SourceError(f"{self.base}: {exc.reason}") from None
        if stream:
            return resp
        with resp:
            try:
                reply = json.loads(resp.read(1 << 20))
            except ValueError:
                raise SourceError(f"{name}: the camera's answer is not JSON") from None
        if reply.get("state") == "error":
            err = reply.get("error") or {}
            raise OscCommandError(name, str(err.get("code")), str(err.get("message")))
        return reply

    def _preview(self, resp) -> None:
        ctype = resp.headers.get_content_type()
        if not ctype.startswith("multipart/"):
            resp.close()
            raise SourceError(f"live preview answered {ctype}, not multipart MJPEG")
        self._resp, self._reader = resp, MultipartJpegReader(resp)

    def open(self) -> None:
        if self.api in ("auto", "2.1"):
            try:
                self._preview(self._execute("camera.getLivePreview", {}, stream=True))
                self.api_used = "2.1"
                return
            except OscCommandError as exc:
                if self.api == "2.1":
                    raise
                log.debug("%s: getLivePreview refused (%s); trying API 2.0", self.base, exc)
        reply = self._execute("camera.startSession", {})
        self._session = (reply.get("results") or {}).get("sessionId")
        if not self._session:
            raise SourceError("camera.startSession gave no sessionId")
        self._preview(self._execute("camera._getLivePreview", {"sessionId": self._session},
                                    stream=True))
        self.api_used = "2.0"

    def read(self) -> Frame:
        return Frame(None, time.time(), jpeg=self._reader.next_jpeg())

    def close(self) -> None:
        if self._resp is not None:
            self._resp.close()
        if self._session:
            try:  # frees the camera for the next session; the camera may be gone
                self._execute("camera.closeSession", {"sessionId": self._session}, timeout=1.0)
            except Exception:  # noqa: BLE001
                pass
            self._session = None


# ---- relay: another provider's coefficients ---------------------------------------------------------

_RELAY_STATS = ("compute_ms", "clipped_fraction", "order_error", "error_estimate",
                "coverage_sr", "negative_energy_fraction", "negative_pixels",
                "nonfinite_pixels", "order", "min_irradiance", "ringing", "window_cutoff")


class RelaySource(Source):
    """Subscribes to another ``shlight serve`` and re-serves its coefficients (edge device →
    PC → many headsets). Frames carry ready-made lighting, timed by the upstream frame
    time, so latency figures stay end-to-end. The probe is ``?probe=NAME`` (default: the
    upstream's first probe); ``?token=`` is passed on. Upstream messages marked stale are
    not relayed as fresh: this probe then goes stale too."""

    def __init__(self, url: str, options: SourceOptions):
        super().__init__()
        self.url, self.options = url, options
        query = urllib.parse.parse_qs(urllib.parse.urlsplit(url).query)
        self.probe = query.get("probe", [None])[0]
        self._ws = None

    def open(self) -> None:
        from websockets.sync.client import connect
        try:
            ws = connect(self.url, open_timeout=self.options.timeout,
                         close_timeout=1, compression=None, max_size=1 << 20,
                         user_agent_header=USER_AGENT)
            # Held open across read() calls, not in a with-block: enter it by hand (newer
            # websockets warn about connect() used outside a context manager).
            self._ws = ws.__enter__()
        except Exception as exc:  # noqa: BLE001 - refused, HTTP 401/404, timeout...
            raise SourceError(f"{_redact(self.url)}: {exc}") from None
        hello = self._recv()
        if hello.get("type") != "hello":
            raise SourceError("the upstream did not say hello")
        if self.probe is None:
            probes = hello.get("probes") or ["default"]
            self.probe = probes[0]
        self._ws.send(json.dumps({"type": "subscribe", "probe": self.probe}))

    def _recv(self) -> dict:
        from websockets.exceptions import ConnectionClosed
        try:
            text = self._ws.recv(timeout=self.options.timeout)
        except TimeoutError:
            raise SourceError(f"no message from upstream in {self.options.timeout:g} s") from None
        except ConnectionClosed as exc:
            raise SourceError(f"upstream closed the connection ({exc})") from None
        try:
            msg = json.loads(text)
        except ValueError:
            raise SourceError("upstream sent something that is not JSON") from None
        return msg if isinstance(msg, dict) else {}

    def read(self) -> Frame:
        from .engine import SH9Result
        while True:
            if self._stop.is_set():
                raise _Interrupted()
            msg = self._recv()
            kind = msg.get("type")
            if kind == "error":
                raise SourceError(f"upstream error: {msg.get('error')}: {msg.get('detail', '')}")
            if kind != "sh9" or msg.get("stale") or msg.get("probe") != self.probe:
                continue
            try:
                coeffs = np.asarray(msg["coefficients"], np.float64).reshape(9, 3)
                mats = np.asarray(msg["matrices"], np.float64).reshape(3, 4, 4)
                t = float(msg["time"])
            except (KeyError, TypeError, ValueError):
                raise SourceError("upstream sent a malformed sh9 message") from None
            stats = {k: msg[k] for k in _RELAY_STATS if k in msg}
            return Frame(None, t, lighting=SH9Result(coeffs, mats, stats),
                         info={"upstream_seq": msg.get("seq")})

    def close(self) -> None:
        if self._ws is not None:
            self._ws.close()


# ---- parsing a source specification --------------------------------------------------------------

@dataclass
class SourceSpec:
    """A parsed source specification: ``make()`` builds a fresh source for each attempt."""

    kind: str
    target: object
    options: SourceOptions
    description: str

    def make(self) -> Source:
        o, t = self.options, self.target
        if self.kind == "demo":
            return DemoSource(fps=o.fps or 30.0)
        if self.kind == "image":
            return ImageSource(t, fps=o.fps or 2.0)
        if self.kind == "sequence":
            return SequenceSource(t, fps=o.fps or 1.0, loop=o.loop)
        if self.kind == "video":
            return VideoFileSource(t, fps=o.fps, loop=o.loop)
        if self.kind in ("camera", "opencv"):
            return OpenCVSource(t, o)
        if self.kind == "picamera2":
            return Picamera2Source(t, o)
        if self.kind == "mjpeg":
            return MjpegHttpSource(t, o)
        if self.kind == "theta":
            return ThetaSource(t, o)
        if self.kind == "relay":
            return RelaySource(t, o)
        raise AssertionError(self.kind)

    @property
    def nominal_fps(self) -> float | None:
        """The rate this source is paced at, when we pace it (None otherwise)."""
        defaults = {"demo": 30.0, "image": 2.0, "sequence": 1.0}
        if self.kind in defaults:
            return self.options.fps or defaults[self.kind]
        if self.kind == "mjpeg":
            return None
        return self.options.fps if self.kind == "video" else None


def parse_source(spec: str, options: SourceOptions | None = None) -> SourceSpec:
    """Parse a ``--source`` specification (see the module docstring).

    Raises :class:`InputError` for a specification that cannot work (a missing file, an
    empty glob, an unknown scheme), so that ``shlight serve`` refuses to start with one
    clear line rather than retrying forever.
    """
    from .io import IMAGE_EXTENSIONS
    o = options or SourceOptions()
    s = spec.strip()
    low = s.lower()
    if not s:
        raise InputError("empty source")
    if low == "demo":
        return SourceSpec("demo", None, o, "demo (built-in animated scene)")
    if re.fullmatch(r"(camera:)?\d+", low):
        index = int(low.split(":")[-1])
        return SourceSpec("camera", index, o, f"camera {index}")
    if low.startswith("/dev/video"):
        return SourceSpec("camera", s, o, f"camera {s}")
    if re.fullmatch(r"picamera2(:\d+)?", low):
        index = int(low.split(":")[1]) if ":" in low else 0
        return SourceSpec("picamera2", index, o, f"Raspberry Pi camera {index} (Picamera2)")
    if low.startswith("opencv:"):
        return SourceSpec("opencv", s[7:], o, f"OpenCV {_redact(s[7:])}")
    scheme = urllib.parse.urlsplit(s).scheme.lower() if "://" in s else ""
    if scheme in ("http", "https"):
        return SourceSpec("mjpeg", s, o, f"MJPEG {_redact(s)}")
    if scheme in ("theta", "osc", "thetas", "oscs"):
        if not urllib.parse.urlsplit(s).hostname:
            raise InputError(f"theta source needs a host, e.g. theta://192.168.1.1: {s}")
        ThetaSource(s, o)  # validates the options
        return SourceSpec("theta", s, o, f"Ricoh Theta {_redact(s)} (OSC live preview)")
    if scheme in ("ws", "wss"):
        return SourceSpec("relay", s, o, f"relay {_redact(s)}")
    if scheme in ("rtsp", "rtsps", "rtmp", "udp", "tcp", "srt"):
        return SourceSpec("opencv", s, o, f"stream {_redact(s)}")
    if scheme:
        raise InputError(f"unknown source scheme {scheme}:// in {_redact(s)}")
    if any(c in s for c in "*?[") or os.path.isdir(s):
        if not SequenceSource.expand(s):
            raise InputError(f"no image files match {s}")
        return SourceSpec("sequence", s, o, f"images {s}")
    if not os.path.exists(s):
        raise InputError(f"no such file or source: {s} (sources: demo, a file, a camera "
                         f"index, http://, rtsp://, theta://, ws://; see shlight serve --help)")
    if low.endswith(IMAGE_EXTENSIONS):
        _read_image(s)  # refuses an unreadable image now, with the reader's message
        return SourceSpec("image", s, o, f"image {s}")
    if os.path.isfile(s):
        # A file that is neither an image nor a video would be retried forever: refuse it
        # now, with one line (a file of frames on disk does not come back by retrying).
        cap = cv2.VideoCapture(s)
        try:
            ok = cap.isOpened()
        finally:
            cap.release()
        if not ok and low.endswith(VIDEO_EXTENSIONS):
            raise InputError(f"OpenCV cannot open the video {s} (damaged, or a codec "
                             "this OpenCV build lacks)")
        if not ok:
            raise InputError(f"cannot open {s} as a video (OpenCV) or an image "
                             f"({', '.join(IMAGE_EXTENSIONS)})")
    return SourceSpec("video", s, o, f"video {s}")


# ---- the capture thread ------------------------------------------------------------------------------

class _Attempt:
    """One connection attempt: one fresh source object and the thread that reads it."""

    def __init__(self, number: int):
        self.number = number
        self.source: Source | None = None
        self.thread: threading.Thread | None = None
        self.started = time.monotonic()
        self.connected_at: float | None = None
        self.last_frame: float | None = None
        self.frames = 0
        self.error: str | None = None
        self.finished = False
        self.abandoned = False


class Capture:
    """Reads a source in background threads; keeps only the newest frame.

    * :meth:`take` returns the newest frame not yet taken (or None): frames that arrive
      while the consumer is busy replace each other, so there is never a backlog.
    * ``state`` is ``"connecting"``, ``"live"``, ``"lost"`` (retrying) or ``"finished"``;
      ``reason`` says why the source was lost. ``notify`` (a thread-safe callable, no
      arguments) is called after every new frame and every state change.
    * After a failure the source object is discarded and a fresh one is made by
      ``spec.make()`` after a backoff that doubles from ``backoff_min`` to ``backoff_max``
      (reset once an attempt has delivered frames).
    * A connected source that delivers no frame for ``hang_timeout`` seconds (or an open
      that takes that long) is declared hung: its thread is abandoned (it exits when its
      call returns) and a new attempt starts.
    """

    def __init__(self, spec: SourceSpec, *, name: str = "default", notify=None,
                 backoff_min: float = 0.5, backoff_max: float = 10.0,
                 hang_timeout: float | None = None):
        self.spec, self.name = spec, name
        self.notify = notify or (lambda: None)
        self.backoff_min, self.backoff_max = backoff_min, max(backoff_min, backoff_max)
        timeout = spec.options.timeout
        fps = spec.nominal_fps
        self.hang_timeout = hang_timeout or max(2.0 * timeout, 3.0 / fps if fps else 0.0)
        self.state = "connecting"
        self.reason = ""
        self.frames = 0
        self.reconnects = 0
        self.lost_since: float | None = None   # unix time the source was lost
        self._latest: Frame | None = None
        self._lock = threading.Lock()
        self._stopping = threading.Event()
        self._attempt: _Attempt | None = None
        self._arrivals = collections.deque(maxlen=90)
        self._thread: threading.Thread | None = None

    # -- the consumer's side --------------------------------------------------------------
    def start(self) -> None:
        self._thread = threading.Thread(target=self._supervise, daemon=True,
                                        name=f"capture-{self.name}")
        self._thread.start()

    def stop(self, timeout: float = 2.0) -> None:
        """Stop reading; returns within about ``timeout`` seconds (stuck threads are daemons)."""
        self._stopping.set()
        attempt = self._attempt
        if attempt is not None and attempt.source is not None:
            attempt.source.interrupt()
        if self._thread is not None:
            self._thread.join(timeout)

    def take(self) -> Frame | None:
        """The newest frame not yet taken, or None."""
        with self._lock:
            frame, self._latest = self._latest, None
        return frame

    @property
    def fps(self) -> float:
        """Frames per second delivered over the last two seconds or so."""
        with self._lock:
            times = list(self._arrivals)
        if len(times) < 2 or time.monotonic() - times[-1] > 2.0:
            return 0.0
        recent = [t for t in times if t >= times[-1] - 2.0]
        if len(recent) < 2:
            return 0.0
        return (len(recent) - 1) / max(recent[-1] - recent[0], 1e-6)

    # -- the threads ---------------------------------------------------------------------------
    def _set_state(self, state: str, reason: str = "") -> None:
        self.state, self.reason = state, reason
        self.notify()

    def _supervise(self) -> None:
        delay = self.backoff_min
        number = 0
        while not self._stopping.is_set():
            number += 1
            attempt = _Attempt(number)
            attempt.thread = threading.Thread(target=self._run_attempt, args=(attempt,),
                                              daemon=True, name=f"source-{self.name}-{number}")
            self._attempt = attempt
            attempt.thread.start()
            self._watch(attempt)
            if self._stopping.is_set():
                break
            if attempt.finished:
                log.info("probe %s: source finished (%s)", self.name, self.spec.description)
                self.lost_since = time.time()
                self._set_state("finished", "the source has no more frames")
                break
            if attempt.frames:
                delay = self.backoff_min
            reason = attempt.error or "unknown error"
            if self.state != "lost":
                self.lost_since = time.time()
                log.warning("probe %s: source lost (%s): %s", self.name,
                            self.spec.description, reason)
            else:
                log.info("probe %s: still no source (%s)", self.name, reason)
            self._set_state("lost", reason)
            log.info("probe %s: reconnecting in %.1f s", self.name, delay)
            if self._stopping.wait(delay):
                break
            delay = min(delay * 2, self.backoff_max)
            self.reconnects += 1

    def _watch(self, attempt: _Attempt) -> None:
        """Wait for the attempt's thread to end; abandon it if it hangs."""
        while attempt.thread.is_alive() and not self._stopping.is_set():
            attempt.thread.join(0.1)
            since = attempt.last_frame or attempt.connected_at or attempt.started
            idle = time.monotonic() - since
            if attempt.thread.is_alive() and idle > self.hang_timeout:
                doing = "opening" if attempt.connected_at is None else "reading"
                attempt.error = f"hung while {doing} (nothing for {idle:.1f} s)"
                attempt.abandoned = True
                if attempt.source is not None:
                    attempt.source.interrupt()
                log.warning("probe %s: source %s: abandoning it and reconnecting",
                            self.name, attempt.error)
                return

    def _run_attempt(self, attempt: _Attempt) -> None:
        source = None
        try:
            source = attempt.source = self.spec.make()
            source.open()
            if attempt.abandoned or self._stopping.is_set():
                return
            attempt.connected_at = time.monotonic()
            if self.state == "lost":
                down = time.time() - (self.lost_since or time.time())
                log.info("probe %s: source reconnected after %.1f s (%s)", self.name, down,
                         self.spec.description)
            else:
                log.info("probe %s: source connected (%s)", self.name, self.spec.description)
            self._set_state("live")
            while not (attempt.abandoned or self._stopping.is_set()):
                frame = source.read()
                if attempt.abandoned:
                    break
                self._deliver(attempt, frame)
        except SourceFinished:
            attempt.finished = True
        except _Interrupted:
            pass
        except Exception as exc:  # noqa: BLE001 - any failure means: lost, retry
            if not attempt.abandoned:
                attempt.error = _describe(exc)
        finally:
            if source is not None:
                try:
                    source.close()
                except Exception:  # noqa: BLE001
                    pass

    def _deliver(self, attempt: _Attempt, frame: Frame) -> None:
        now = time.monotonic()
        attempt.last_frame = now
        attempt.frames += 1
        with self._lock:
            self._latest = frame
            self.frames += 1
            self._arrivals.append(now)
        self.notify()


def _describe(exc: BaseException) -> str:
    if isinstance(exc, (SourceError, InputError)):
        return str(exc)
    if isinstance(exc, TimeoutError) or type(exc).__name__ == "timeout":
        return "timed out"
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
