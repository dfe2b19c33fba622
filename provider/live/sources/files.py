"""Image files: one image re-read when it changes, or a sequence of images."""
from __future__ import annotations

import glob
import logging
import os
import select
import stat
import tempfile
import time

from ...core.errors import InputError
from ...core.radiometry.image_size import FrameTooLarge
from ...core.radiometry.images import IMAGE_EXTENSIONS, TransientReadError, read_image
from .base import (Frame, Pacer, Source, SourceError, SourceFinished, decoder_says,
                   opencv_log_quiet)
from .exposure import still_info

log = logging.getLogger("shlight.source")


def file_version(st: os.stat_result) -> tuple:
    """What tells two versions of a file apart: the modification time alone misses a file
    replaced (renamed over) within the file system's timestamp granularity; the inode and
    size tell those apart."""
    return st.st_mtime_ns, st.st_size, st.st_ino, st.st_dev


class ImageSource(Source):
    """One image file, delivered at ``fps`` and re-read whenever its modification time
    changes (another program may rewrite it; write it atomically, e.g. with a rename).

    A version of the file that cannot be decoded (corrupt, or over the pixel budget
    ``max_pixels``, which is checked on its header) is remembered until the file changes
    again (not read again every frame); meanwhile the previous image goes on, its frames
    saying why (``info["bad_file"]``; the first of them, for a version over the budget,
    also ``info["too_large"]``: (width, height), which the probe counts and says once). A
    read that failed for a reason that is not the file's content (an I/O error, memory) is
    not remembered: the file is read again (after 1 s, then 2, 4, up to 10 s), and its
    picture comes back as soon as that works.

    A FIFO (a named pipe) is such a file whose versions come through the pipe: each writer
    writes one image and closes it (``cat room.png > PATH``). The FIFO is held open for
    reading (non-blocking: a writer never waits for the server, nor finds no reader), and
    between writers the last image goes on. Before the first image, ``open`` waits up to
    ``timeout`` seconds, said once in the log ("waiting for a writer on FIFO PATH"), then
    fails (the capture retries, its reason "no writer ... yet")."""

    def __init__(self, path: str, fps: float = 2.0, max_pixels: int = 0,
                 timeout: float = 5.0, exif: bool = False):
        super().__init__()
        #: with --camera: each version's EXIF exposure goes into Frame.info (.exposure.still_info)
        self.exif, self._still = exif, {}
        self.timeout = timeout
        self.path, self.nominal_fps, self.max_pixels = path, fps, max_pixels
        self._pacer = Pacer(fps)
        self._image, self._mtime = None, None
        self._bad: tuple | None = None      # (version, why) of an undecodable version
        self._failing: str | None = None    # why the last read failed, if not the content
        self._too_large: tuple | None = None   # (w, h) of a refused version, not yet told
        # after a read that failed (not for its content): that version, when to try again
        # (monotonic time, s) and the wait after the next failure (s)
        self._retry_version, self._retry_at, self._retry_s = None, 0.0, 1.0
        self._fifo: _FifoReader | None = None

    def open(self) -> None:
        self._load()

    def _load(self) -> None:
        try:
            st = os.stat(self.path)
        except OSError as exc:
            raise SourceError(f"cannot read {self.path}: {exc.strerror}") from None
        mtime = file_version(st)
        if stat.S_ISFIFO(st.st_mode):       # versions are writers, not modification times
            if self._fifo is None:
                self._fifo = _FifoReader(self.path, self.max_pixels)
            data = self._fifo.take(self.timeout if self._image is None else 0.0, self._stop)
            if data is None and self._image is None:
                raise SourceError(f"no writer on FIFO {self.path} yet (waited "
                                  f"{self.timeout:g} s)")
            if data is None:
                return
            mtime = ("fifo", self._fifo.writers)
        elif mtime == self._mtime or (self._bad is not None and self._bad[0] == mtime):
            return
        elif (self._failing is not None and mtime == self._retry_version
                and time.monotonic() < self._retry_at):
            return
        try:
            with opencv_log_quiet():
                image = (read_image(self.path, self.max_pixels, self._said)
                         if self._fifo is None else self._fifo.decode(data, self._said))
        except TransientReadError as exc:      # not the content: not remembered as bad
            if self._image is None:
                raise SourceError(str(exc)) from None
            if self._failing != str(exc):
                log.warning("%s: keeping the previous image and trying again (%s)",
                            self.path, exc)
            self._failing, self._retry_version = str(exc), mtime
            self._retry_at = time.monotonic() + self._retry_s
            self._retry_s = min(2 * self._retry_s, 10.0)
        except InputError as exc:
            if self._image is None:
                raise SourceError(str(exc)) from None
            self._bad, self._failing, self._retry_s = (mtime, str(exc)), None, 1.0
            if isinstance(exc, FrameTooLarge):  # said (once) and counted by the probe
                self._too_large = (exc.width, exc.height)
            else:
                log.warning("%s: keeping the previous image until the file changes (%s)",
                            self.path, exc)
        else:
            self._image, self._mtime, self._bad, self._failing = image, mtime, None, None
            self._retry_s = 1.0
            if self.exif and self._fifo is None:
                self._still = still_info(self.path)

    def _said(self, words: str) -> None:
        decoder_says(self.path, words)

    def close(self) -> None:
        if self._fifo is not None:
            self._fifo.close()

    def read(self) -> Frame:
        self._pacer.wait(self)
        self._load()
        info = {"path": self.path, **self._still}
        if self._bad is not None or self._failing is not None:
            info["bad_file"] = self._failing or self._bad[1]
        if self._too_large is not None:
            info["too_large"], self._too_large = self._too_large, None
        return Frame(self._image, time.time(), info=info)


#: FIFOs said to wait for their first writer (once per path, not once per retry).
_FIFOS_SAID: set = set()


class _FifoReader:
    """The read end of a FIFO, held open without blocking: :meth:`take` gathers what writers
    write, and gives the bytes of one once it closed its end (an image per writer)."""

    def __init__(self, path: str, max_pixels: int = 0):
        self.path, self.max_pixels = path, max_pixels
        self.limit = 16 * (max_pixels or 1 << 26)     # bytes: float32 RGBA, and then some
        self.fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
        self.data = bytearray()
        self.dropped = 0            # bytes of the current writer beyond the limit
        self.writers = 0            # images taken so far (a writer's is the next version)

    def take(self, wait: float, stop) -> bytes | None:
        """A writer's bytes, once it closed the FIFO, waiting up to ``wait`` s for them (and
        saying so the first time for this path), and while they come; None when none came
        (or ``stop`` is set): what came so far waits for the next call."""
        if wait > 0 and not self.data and self.path not in _FIFOS_SAID:
            _FIFOS_SAID.add(self.path)
            log.warning("waiting for a writer on FIFO %s", self.path)
        deadline = time.monotonic() + wait
        while True:
            try:
                chunk = os.read(self.fd, 1 << 20)
            except BlockingIOError:     # a writer that has not written (all) yet
                chunk = None
            if chunk:                   # a writer at work: give it a second more to finish
                deadline = max(deadline, time.monotonic() + 1.0)
                if self.dropped or len(self.data) + len(chunk) > self.limit:
                    self.dropped += len(self.data) + len(chunk)   # not an image: drained
                    self.data = bytearray()
                else:
                    self.data += chunk
                continue
            if chunk == b"" and (self.data or self.dropped):   # its writer closed
                data, self.data = bytes(self.data), bytearray()
                self.writers += 1
                if self.dropped:
                    self.dropped = 0
                    return b""          # refused by decode
                return data
            left = deadline - time.monotonic()
            if left <= 0 or stop.is_set():
                return None
            if chunk == b"":            # no writer since one left: select would not wait
                stop.wait(min(left, 0.05))
            else:
                select.select([self.fd], [], [], min(left, 0.1))

    def decode(self, data: bytes, said=None):
        """The image in a writer's bytes (read through a temporary file of the FIFO's
        extension; errors name the FIFO)."""
        if not data:
            raise InputError(f"{self.path}: a writer sent more than {self.limit:,} bytes: "
                             "not an image under --max-frame-pixels")
        fd, tmp = tempfile.mkstemp(suffix=os.path.splitext(self.path)[1], prefix="shlight-fifo-")
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(data)
            return read_image(tmp, self.max_pixels, said)
        except InputError as exc:
            exc.args = (str(exc).replace(tmp, self.path),) + exc.args[1:]
            raise
        finally:
            os.unlink(tmp)

    def close(self) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


class SequenceSource(Source):
    """Image files matching a glob (or all images in a directory), in name order, at
    ``fps``; looped (the glob is expanded again at every loop, so new files join).

    A file that cannot be decoded is one rejected frame (``info["rejected"]``: the probe
    counts it and lists it in /healthz) and the sequence goes on with the next file; it is
    remembered, and skipped without decoding, until it changes (modification time, size).
    A file over the pixel budget ``max_pixels`` (checked on its header: it is never decoded)
    is such a file; its frame also says ``info["too_large"]``: (width, height). A read that
    failed for a reason that is not the file's content (an I/O error, memory) is a rejected
    frame too, but not remembered: the file is read again at the next loop.
    """

    def __init__(self, pattern: str, fps: float = 1.0, loop: bool = True,
                 max_pixels: int = 0, exif: bool = False):
        super().__init__()
        self.exif = exif        # with --camera: each still's EXIF exposure into Frame.info
        self.pattern, self.loop, self.nominal_fps = pattern, loop, fps
        self.max_pixels = max_pixels
        self._pacer = Pacer(fps)
        self._paths: list[str] = []
        self._index = 0
        self._bad: dict[str, tuple] = {}    # path -> version that cannot be decoded

    @staticmethod
    def expand(pattern: str) -> list[str]:
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
        for _ in range(len(self._paths) + 1):       # known-bad files are skipped at once
            if self._index >= len(self._paths):
                if not self.loop:
                    raise SourceFinished()
                self.open()
                self._index = 0
            path = self._paths[self._index]
            self._index += 1
            try:
                version = file_version(os.stat(path))
            except OSError:
                continue                            # removed since the glob: next one
            if self._bad.get(path) == version:
                continue
            try:
                with opencv_log_quiet():
                    image = read_image(path, self.max_pixels,
                                       lambda words: decoder_says(path, words))
            except InputError as exc:
                info = {"path": path, "rejected": str(exc)}
                if not isinstance(exc, TransientReadError):
                    self._bad[path] = version       # its content: not read again until changed
                if isinstance(exc, FrameTooLarge):
                    info["too_large"] = (exc.width, exc.height)
                return Frame(None, time.time(), info=info)
            self._bad.pop(path, None)
            return Frame(image, time.time(),
                         info={"path": path, **(still_info(path) if self.exif else {})})
        raise SourceError(f"none of the files matching {self.pattern} can be read")
