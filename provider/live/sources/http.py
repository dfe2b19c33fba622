"""MJPEG over HTTP: the multipart reader, HTTP authentication, and the MJPEG/snapshot source.

Only the standard library: a stalled stream times out on its socket instead of hanging
(which an OpenCV capture of the same URL can do).
"""
from __future__ import annotations

import html
import re
import time
import urllib.error
import urllib.request

from .base import (USER_AGENT, Frame, Pacer, Source, SourceError, SourceOptions, printable,
                   redact, split_credentials)

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


def http_opener(url: str, user: str | None, password: str | None):
    """An urllib opener answering Basic and Digest challenges with the credentials."""
    handlers = []
    if user is not None:
        mgr = urllib.request.HTTPPasswordMgrWithDefaultRealm()
        mgr.add_password(None, url, user, password or "")
        handlers += [urllib.request.HTTPDigestAuthHandler(mgr),
                     urllib.request.HTTPBasicAuthHandler(mgr)]
    return urllib.request.build_opener(*handlers)


_TAG = re.compile(r"<(script|style)\b.*?</\1\s*>|<[^>]*>", re.S | re.I)


def _http_error_text(exc: urllib.error.HTTPError, limit: int = 200) -> str:
    """``HTTP 503 Service Unavailable: <the body's text>`` for one log line: the camera's
    words (whoever answers for the camera writes them) without control characters or
    newlines, HTML tags dropped, at most ``limit`` characters of body."""
    try:
        body = exc.read(4096).decode("utf-8", "replace")
    except Exception:  # noqa: BLE001
        body = ""
    if "html" in (exc.headers.get_content_type() if exc.headers else "") or \
            body.lstrip()[:1] == "<":
        body = html.unescape(_TAG.sub(" ", body))
    body = printable(body, limit)
    return f"HTTP {exc.code} {printable(exc.reason or '', 80)}" + (f": {body}" if body else "")


class MjpegHttpSource(Source):
    """An MJPEG stream over HTTP (``multipart/x-mixed-replace``), read with the standard
    library and our own :class:`MultipartJpegReader` so that a stalled stream times out
    (socket timeout) instead of hanging. A URL that answers with a single JPEG is polled
    as a snapshot URL at ``fps`` (default 5)."""

    def __init__(self, url: str, options: SourceOptions):
        super().__init__()
        self.url, user, password = split_credentials(url)
        self.options = options
        self._open = http_opener(self.url, user, password).open
        self._resp, self._reader, self._snapshot_pacer = None, None, None

    def _get(self):
        req = urllib.request.Request(self.url, headers={"User-Agent": USER_AGENT})
        try:
            return self._open(req, timeout=self.options.timeout)
        except urllib.error.HTTPError as exc:
            raise SourceError(f"{redact(self.url)}: {_http_error_text(exc)}") from None
        except urllib.error.URLError as exc:
            raise SourceError(f"{redact(self.url)}: {exc.reason}") from None

    def open(self) -> None:
        self._resp = self._get()
        ctype = self._resp.headers.get_content_type()
        if ctype.startswith("multipart/"):
            self._reader = MultipartJpegReader(self._resp)
        elif ctype.startswith("image/"):
            self._snapshot_pacer = Pacer(self.options.fps or 5.0)
            self.nominal_fps = self.options.fps or 5.0
        else:
            raise SourceError(f"{redact(self.url)} sends {ctype}, neither MJPEG "
                              f"(multipart/x-mixed-replace) nor an image; for a video stream "
                              f"use opencv:{redact(self.url)}")

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
