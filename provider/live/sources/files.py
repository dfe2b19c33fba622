"""Image files: one image re-read when it changes, or a sequence of images."""
from __future__ import annotations

import glob
import logging
import os
import time

from ...core.errors import InputError
from ...core.radiometry.image_size import FrameTooLarge
from ...core.radiometry.images import IMAGE_EXTENSIONS, TransientReadError, read_image
from .base import Frame, Pacer, Source, SourceError, SourceFinished

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
    picture comes back as soon as that works."""

    def __init__(self, path: str, fps: float = 2.0, max_pixels: int = 0):
        super().__init__()
        self.path, self.nominal_fps, self.max_pixels = path, fps, max_pixels
        self._pacer = Pacer(fps)
        self._image, self._mtime = None, None
        self._bad: tuple | None = None      # (version, why) of an undecodable version
        self._failing: str | None = None    # why the last read failed, if not the content
        self._too_large: tuple | None = None   # (w, h) of a refused version, not yet told
        # after a read that failed (not for its content): that version, when to try again
        # (monotonic time, s) and the wait after the next failure (s)
        self._retry_version, self._retry_at, self._retry_s = None, 0.0, 1.0

    def open(self) -> None:
        self._load()

    def _load(self) -> None:
        try:
            st = os.stat(self.path)
        except OSError as exc:
            raise SourceError(f"cannot read {self.path}: {exc.strerror}") from None
        mtime = file_version(st)
        if mtime == self._mtime or (self._bad is not None and self._bad[0] == mtime):
            return
        if (self._failing is not None and mtime == self._retry_version
                and time.monotonic() < self._retry_at):
            return
        try:
            image = read_image(self.path, self.max_pixels)
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

    def read(self) -> Frame:
        self._pacer.wait(self)
        self._load()
        info = {"path": self.path}
        if self._bad is not None or self._failing is not None:
            info["bad_file"] = self._failing or self._bad[1]
        if self._too_large is not None:
            info["too_large"], self._too_large = self._too_large, None
        return Frame(self._image, time.time(), info=info)


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
                 max_pixels: int = 0):
        super().__init__()
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
                image = read_image(path, self.max_pixels)
            except InputError as exc:
                info = {"path": path, "rejected": str(exc)}
                if not isinstance(exc, TransientReadError):
                    self._bad[path] = version       # its content: not read again until changed
                if isinstance(exc, FrameTooLarge):
                    info["too_large"] = (exc.width, exc.height)
                return Frame(None, time.time(), info=info)
            self._bad.pop(path, None)
            return Frame(image, time.time(), info={"path": path})
        raise SourceError(f"none of the files matching {self.pattern} can be read")
