"""Frame sources for ``shlight serve``: one module per family, and the parser of source
specifications that picks one.

A *source* is a small blocking object (:class:`~.base.Source`: ``open``, ``read`` → a
:class:`~.base.Frame`, ``close``) run by the capture thread (:mod:`provider.live.probe.capture`).
Families, one module each: :mod:`.demo` (the built-in scene), :mod:`.files` (an image, an
image sequence), :mod:`.opencv` (video files, cameras, RTSP), :mod:`.http` (MJPEG over
HTTP), :mod:`.theta` (a Ricoh Theta over Wi-Fi), :mod:`.relay` (another ``shlight
serve``), :mod:`.picamera` (a Raspberry Pi camera). A new family is a module here with a
:class:`~.base.Source` subclass, one ``kind`` in :meth:`SourceSpec.make` and one rule in
:func:`parse_source`.

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

Only the standard library, OpenCV and ``websockets`` are used. May import:
:mod:`provider.core` (errors, image reading; the relay: the engine's result types). Nothing
else of the live service.
"""
from __future__ import annotations

import os
import re
import stat
import urllib.parse
from dataclasses import dataclass

import cv2

from ...core.errors import InputError
from ...core.radiometry.images import IMAGE_EXTENSIONS, read_image
from .base import Frame, Source, SourceError, SourceFinished, SourceOptions, redact  # noqa: F401
from .files import SequenceSource
from .opencv import VIDEO_EXTENSIONS


@dataclass
class SourceSpec:
    """A parsed source specification: ``make()`` builds a fresh source for each attempt."""

    kind: str
    target: object
    options: SourceOptions
    description: str

    def make(self) -> Source:
        # Families are imported when used: a Pi without websockets can still read its camera.
        o, t = self.options, self.target
        if self.kind == "demo":
            from .demo import DemoSource
            return DemoSource(fps=o.fps or 30.0)
        if self.kind == "image":
            from .files import ImageSource
            return ImageSource(t, fps=o.fps or 2.0, max_pixels=o.max_pixels, timeout=o.timeout,
                               exif=o.query_exposure)
        if self.kind == "sequence":
            return SequenceSource(t, fps=o.fps or 1.0, loop=o.loop,
                                  max_pixels=o.max_pixels, exif=o.query_exposure)
        if self.kind == "video":
            from .opencv import VideoFileSource
            return VideoFileSource(t, fps=o.fps, loop=o.loop)
        if self.kind in ("camera", "opencv"):
            from .opencv import OpenCVSource
            return OpenCVSource(t, o)
        if self.kind == "picamera2":
            from .picamera import Picamera2Source
            return Picamera2Source(t, o)
        if self.kind == "mjpeg":
            from .http import MjpegHttpSource
            return MjpegHttpSource(t, o)
        if self.kind == "theta":
            from .theta import ThetaSource
            return ThetaSource(t, o)
        if self.kind == "relay":
            from .relay import RelaySource
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
        # a relay paced below a frame a second must not look hung between two frames
        return self.options.fps if self.kind in ("video", "relay") else None


def _check_host(url: str, scheme: str) -> None:
    """A network source names a host and, if any, a port number: refused at start (the
    same whatever other options are given), not retried forever."""
    try:
        parts = urllib.parse.urlsplit(url)
        parts.port                                  # noqa: B018 - raises on a bad port
    except ValueError as exc:
        # not echoed: redact cannot take it apart either, and it may hold a password
        raise InputError(f"{scheme}:// source: {exc} (e.g. {scheme}://192.168.1.20, "
                         f"{scheme}://[::1])") from None
    if not parts.hostname and scheme not in ("udp", "srt"):   # udp://@:1234 listens
        raise InputError(f"{scheme}:// source needs a host, e.g. {scheme}://192.168.1.20"
                         f"{':8765/' if scheme.startswith('ws') else '/'}: {redact(url)}")


def parse_source(spec: str, options: SourceOptions | None = None) -> SourceSpec:
    """Parse a ``--source`` specification (see the module docstring).

    Raises :class:`InputError` for a specification that cannot work (a missing file, an
    empty glob, an unknown scheme), so that ``shlight serve`` refuses to start with one
    clear line rather than retrying forever.
    """
    o = options or SourceOptions()
    s = spec.strip()
    low = s.lower()
    if not s:
        raise InputError("empty source (an unset variable in a service file?): give one, "
                         "e.g. demo")
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
        return SourceSpec("opencv", s[7:], o, f"OpenCV {redact(s[7:])}")
    try:
        scheme = urllib.parse.urlsplit(s).scheme.lower() if "://" in s else ""
    except ValueError:      # "theta://[::1": the scheme's own check below says what is wrong
        scheme = s.partition("://")[0].lower()
    if scheme in ("http", "https", "ws", "wss", "rtsp", "rtsps", "rtmp", "udp", "tcp", "srt"):
        _check_host(s, scheme)
    if scheme in ("http", "https"):
        return SourceSpec("mjpeg", s, o, f"MJPEG {redact(s)}")
    if scheme in ("theta", "osc", "thetas", "oscs"):
        from .theta import ThetaSource
        ThetaSource(s, o)  # validates the URL and the options
        return SourceSpec("theta", s, o, f"Ricoh Theta {redact(s)} (OSC live preview)")
    if scheme in ("ws", "wss"):
        return SourceSpec("relay", s, o, f"relay {redact(s)}")
    if scheme in ("rtsp", "rtsps", "rtmp", "udp", "tcp", "srt"):
        return SourceSpec("opencv", s, o, f"stream {redact(s)}")
    if scheme:
        raise InputError(f"unknown source scheme {scheme}:// in {redact(s)}")
    if any(c in s for c in "*?[") or os.path.isdir(s):
        if not SequenceSource.expand(s):
            raise InputError(f"no image files match {s}")
        return SourceSpec("sequence", s, o, f"images {s}")
    if not os.path.exists(s):
        raise InputError(f"no such file or source: {s} (sources: demo, a file, a camera "
                         f"index, http://, rtsp://, theta://, ws://; see shlight serve --help)")
    if low.endswith(IMAGE_EXTENSIONS) and stat.S_ISFIFO(os.stat(s).st_mode):
        # not read now: that would wait for a writer before the server listens, and take
        # what it writes from the source (which says what it waits for, and reads it)
        return SourceSpec("image", s, o, f"image {s} (FIFO)")
    if low.endswith(IMAGE_EXTENSIONS):
        # refuses an unreadable image (or one over the pixel budget, from its header)
        # now, with the reader's message
        read_image(s, o.max_pixels)
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
