"""Image files: one image re-read when it changes, or a sequence of images."""
from __future__ import annotations

import glob
import logging
import os
import time

from ...core.errors import InputError
from ...core.images import IMAGE_EXTENSIONS, read_image
from .base import Frame, Pacer, Source, SourceError, SourceFinished

log = logging.getLogger("shlight.source")


class ImageSource(Source):
    """One image file, delivered at ``fps`` and re-read whenever its modification time
    changes (another program may rewrite it; write it atomically, e.g. with a rename)."""

    def __init__(self, path: str, fps: float = 2.0):
        super().__init__()
        self.path, self.nominal_fps = path, fps
        self._pacer = Pacer(fps)
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
                self._image = read_image(self.path)
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
        self._pacer = Pacer(fps)
        self._paths: list[str] = []
        self._index = 0

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
        if self._index >= len(self._paths):
            if not self.loop:
                raise SourceFinished()
            self.open()
            self._index = 0
        path = self._paths[self._index]
        self._index += 1
        try:
            image = read_image(path)
        except InputError as exc:
            raise SourceError(str(exc)) from None
        return Frame(image, time.time(), info={"path": path})
