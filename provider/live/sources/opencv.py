"""Everything ``cv2.VideoCapture`` reads: video files, cameras, network streams."""
from __future__ import annotations

import glob
import logging
import os
import time

import cv2
import numpy as np

from .base import (Frame, Interrupted, Pacer, Source, SourceError, SourceFinished, SourceOptions,
                   SourceUnavailable, redact)
from .uvc_exposure import UvcExposure

VIDEO_EXTENSIONS = (".mp4", ".m4v", ".mov", ".avi", ".mkv", ".webm", ".mjpeg", ".mjpg",
                    ".mpg", ".mpeg", ".ts", ".wmv", ".flv", ".ogv")


def _quiet_opencv() -> None:
    """OpenCV ("[ WARN:...] can't open camera by index") and its FFmpeg ("Connection
    refused") print on stderr at every attempt, past our logging, which says what is wrong
    once: mute them unless ``--log-level debug``. (FFmpeg's level is read when OpenCV first
    loads it, so it is set before the first capture is opened.)"""
    if logging.getLogger("shlight").getEffectiveLevel() > logging.DEBUG:
        import cv2.utils.logging as cv_log
        cv_log.setLogLevel(cv_log.LOG_LEVEL_ERROR)
        os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")     # AV_LOG_QUIET


def _missing_camera(target) -> str | None:
    """Why a camera cannot be there (Linux: its /dev/video node is missing), or None."""
    node = f"/dev/video{target}" if isinstance(target, int) else str(target)
    if not node.startswith("/dev/") or not os.path.isdir("/dev") or os.path.exists(node):
        return None
    found = sorted(glob.glob("/dev/video*"))
    return (f"no camera at {node} (cameras here: {', '.join(found) if found else 'none'}); "
            "plug it in and it is picked up")


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
        _quiet_opencv()
        self._cap = cv2.VideoCapture(self.path)
        if not self._cap.isOpened():
            raise SourceError(f"OpenCV cannot open the video {self.path}")
        fps = self._fps or self._cap.get(cv2.CAP_PROP_FPS)
        self.nominal_fps = fps if fps and 0 < fps < 1000 else 30.0
        self._pacer = Pacer(self.nominal_fps)

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
    (honoured only at open time and only by FFmpeg/GStreamer: docs/contract.md §8); a read that
    hangs anyway is caught by the :class:`Capture` watchdog. Cameras' exposure
    (``--exposure-unit``, ``--bracket``): :mod:`.uvc_exposure`.
    """

    def __init__(self, target, options: SourceOptions):
        super().__init__()
        self.target, self.options = target, options
        self._cap = None
        self.exposure = UvcExposure(self)

    def open(self) -> None:
        t, ms = self.target, int(self.options.timeout * 1000)
        _quiet_opencv()
        if isinstance(t, int) or t.startswith("/dev/"):
            missing = _missing_camera(t)
            if missing:
                raise SourceUnavailable(missing)
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
            raise SourceError(f"OpenCV cannot open {redact(str(t))} (unreachable, refused, busy "
                              "or not something it reads; --log-level debug shows OpenCV's "
                              "own messages)")
        fps = cap.get(cv2.CAP_PROP_FPS)
        self.nominal_fps = fps if fps and 0 < fps < 1000 else None
        self.exposure.start_bracket()

    def _grab(self) -> np.ndarray:
        if self._stop.is_set():
            raise Interrupted()
        ok, img = self._cap.read()
        if not ok or img is None:
            raise SourceError("no frame (read failed)")
        return _bgr_to_rgb(img)

    def read(self) -> Frame:
        return self.exposure.frame(self._grab())

    def close(self) -> None:
        if self._cap is not None:
            self._cap.release()
