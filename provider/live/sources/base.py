"""What every frame source is: the :class:`Source` interface, the :class:`Frame` it
returns, its errors and options, and small helpers the families share (pacing, URLs).

A *source* is a small blocking object with three methods: :meth:`Source.open` connects,
:meth:`Source.read` blocks until the next :class:`Frame` arrives and returns it, and
:meth:`Source.close` lets go. A source raises :class:`SourceError` when it loses its
camera or stream, and :class:`SourceFinished` at the end of a video that does not loop.
The capture thread (:mod:`provider.live.probe.capture`) runs it; one module per family of
sources implements it.
"""
from __future__ import annotations

import logging
import re
import threading
import time
import urllib.parse
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from ...core.errors import InputError

USER_AGENT = "shlight"
log = logging.getLogger("shlight.source")

class SourceError(Exception):
    """The source lost its camera or stream (the message says why); it will be re-created."""


class SourceUnavailable(SourceError):
    """The source cannot work until someone acts (no such camera, a library not installed):
    the capture says so once and retries only at its longest backoff."""


class SourceFinished(Exception):
    """A finite source (a video played once) has no more frames."""


class Interrupted(Exception):
    """The capture is stopping (raised inside a blocked read)."""


@dataclass
class Frame:
    """One frame from a source.

    ``image`` is an (H, W, 3) RGB array (uint8, uint16 or float: the engine's frame
    contract). MJPEG sources deliver ``jpeg`` bytes instead and the consumer decodes only
    the frames it uses (:meth:`decoded`), so that frames skipped under load cost nothing.
    A relay delivers ready-made ``lighting`` (an :class:`~provider.core.sh9.engine.SH9Result`).
    ``time`` is the unix time of capture (arrival, for network streams). ``info``: what
    the source knows of the frame, e.g. ``exposure_s``, ``gain``, and for a bracket
    ``slot`` and ``bracket`` (see :mod:`.exposure`).
    """

    image: np.ndarray | None
    time: float
    jpeg: bytes | None = None
    lighting: object = None
    info: dict = field(default_factory=dict)

    def decoded(self, max_pixels: int = 0) -> np.ndarray:
        """The RGB image, decoding ``jpeg`` on first use.

        Parameters
        ----------
        max_pixels : int
            Pixel budget (width × height, pixels; 0: none): a frame whose header declares
            more is refused before decoding; a frame whose size only its decoder (or its
            source) knows is checked once decoded.

        Raises
        ------
        InputError
            A corrupt frame; :class:`~provider.core.radiometry.image_size.FrameTooLarge`
            past the budget.
        """
        from ...core.radiometry.image_size import check_decodable, check_pixels, header_size
        if self.image is None and self.jpeg is not None:
            from ...core.radiometry.images import check_complete, decode_jpeg
            what = f"corrupt JPEG frame ({len(self.jpeg)} bytes)"
            size = header_size(self.jpeg)
            if size is not None:     # refused from its header: nothing decoded
                check_pixels(*size, max_pixels)
                check_decodable(*size, self.jpeg, what)
            # a frame cut short is refused, not decoded half-way (the rest grey)
            check_complete(f"JPEG frame ({len(self.jpeg)} bytes)", self.jpeg)
            image, said = decode_jpeg(self.jpeg, what)
            if said:                 # decoded by repairing it: said, a line per interval
                decoder_says("a JPEG frame", said)
            if size is None:         # a size only the decoder read: checked now
                check_pixels(image.shape[1], image.shape[0], max_pixels, decoded=True)
            self.image = image
        elif self.image is not None and self.jpeg is None and self.image.ndim >= 2:
            # decoded by its source (a camera, a video): too late to save the decoding,
            # not too late to save the projection
            check_pixels(self.image.shape[1], self.image.shape[0], max_pixels, decoded=True)
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
    bracket: tuple | None = None      # EV offsets to cycle (sources that set exposure)
    exposure_unit: str | None = None  # UVC: what CAP_PROP_EXPOSURE means (100us, log2s, s)
    max_pixels: int = 0               # --max-frame-pixels: frames with more pixels are
                                      # refused from their header (0: no budget)
    query_exposure: bool = False      # ask the camera for its exposure where that costs a
                                      # command (the Theta's getOptions); see .exposure
    theta_settings: tuple = ()        # Theta: (OSC option, value) pairs set at every open and
                                      # set again when the camera has lost them (.theta)
    theta_check_s: float = 30.0       # Theta: seconds between checks of its settings and state


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
            raise Interrupted()


class Pacer:
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


# ---- URLs ----------------------------------------------------------------------------------

def split_credentials(url: str) -> tuple[str, str | None, str | None]:
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


#: Control characters (C0, DEL, C1), line and paragraph separators, bidi overrides.
_UNPRINTABLE = re.compile("[\x00-\x1f\x7f-\x9f\u2028\u2029\u200e\u200f\u202a-\u202e"
                          "\u2066-\u2069]+")


def printable(text: str, limit: int = 200) -> str:
    """Text from the other side (a camera's error page, its error message), fit for one
    log line.

    Parameters
    ----------
    text : str
        What the camera said (whoever answers for the camera writes it).
    limit : int
        Most characters returned.

    Returns
    -------
    str
        ``text`` with control characters, newlines and bidi overrides turned into single
        spaces, cut to ``limit`` characters (the last one "…" when cut).
    """
    text = " ".join(_UNPRINTABLE.sub(" ", str(text)).split())
    return text if len(text) <= limit else text[:limit - 1].rstrip() + "…"


def redact(url: str) -> str:
    """The URL for logs: no password, no token."""
    clean, user, _ = split_credentials(url)
    parts = urllib.parse.urlsplit(clean)
    query = "&".join(q if not q.lower().startswith("token=") else "token=***"
                     for q in parts.query.split("&")) if parts.query else ""
    return urllib.parse.urlunsplit(parts._replace(query=query))


# ---- what the image decoders say, routed to the log ---------------------------------------------
#
# A camera that keeps sending damaged JPEGs would say the same thing at every frame (issue 29):
# what a decoder says goes to the log as one line per source per interval, with how many were
# held back. Nothing points descriptor 2 anywhere (issue 41: that made the decodes of all
# sources take turns, lost a crash's faulthandler dump, and other threads' lines): JPEGs are
# decoded by a library that returns its words (core.radiometry.images), a PNG is checked before
# libpng sees it (core.radiometry.images), and OpenCV's own log is silenced while a file
# decodes (opencv_log_quiet): OpenEXR's bindings raise.

_said_lock = threading.Lock()
_said: dict = {}                # source -> [monotonic time said, lines held back since]


def decoder_says(where: str, line: str, interval: float = 10.0) -> None:
    """Log what an image decoder said of ``where`` (a file, a camera), at most one line
    every ``interval`` seconds for each ``where`` (the next one counts those held back)."""
    now = time.monotonic()
    with _said_lock:
        seen = _said.get(where)
        if seen is not None and now - seen[0] < interval:
            seen[1] += 1
            return
        held = seen[1] if seen is not None else 0
        if len(_said) > 1024:
            _said.clear()
        _said[where] = [now, 0]
    more = f" (and {held} more from the decoder in the last {interval:g} s)" if held else ""
    log.warning("%s: the image decoder says: %s", where, printable(line, 300) + more)


_quiet_lock = threading.Lock()
_quiet = {"decodes": 0, "level": None}      # decodes under way; OpenCV's level before them


@contextmanager
def opencv_log_quiet():
    """OpenCV's log silenced while any file decodes (its "[ERROR:0@0.1] ... TIFF_Error" and
    "imdecode_(...)" lines, which the caller says in one line of its own), and put back as it
    was when the last one ends: decodes of several sources overlap, so a counter, not a
    level saved by each (the lock guards the counter only: the decodes run side by side)."""
    import cv2.utils.logging as cv_log
    with _quiet_lock:
        if _quiet["decodes"] == 0:
            _quiet["level"] = cv_log.getLogLevel()
            cv_log.setLogLevel(cv_log.LOG_LEVEL_SILENT)
        _quiet["decodes"] += 1
    try:
        yield
    finally:
        with _quiet_lock:
            _quiet["decodes"] -= 1
            if _quiet["decodes"] == 0:
                cv_log.setLogLevel(_quiet["level"])
