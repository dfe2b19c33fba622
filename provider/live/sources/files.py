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


def file_version(st: os.stat_result) -> tuple:
    """What tells two versions of a file apart: the modification time alone misses a file
    replaced (renamed over) within the file system's timestamp granularity; the inode and
    size tell those apart."""
    return st.st_mtime_ns, st.st_size, st.st_ino, st.st_dev


class ImageSource(Source):
    """One image file, delivered at ``fps`` and re-read whenever its modification time
    changes (another program may rewrite it; write it atomically, e.g. with a rename).

    A version of the file that cannot be decoded is remembered until the file changes
    again (not decoded again every frame); meanwhile the previous image goes on, its frames
    saying why (``info["bad_file"]``)."""

    def __init__(self, path: str, fps: float = 2.0):
        super().__init__()
        self.path, self.nominal_fps = path, fps
        self._pacer = Pacer(fps)
        self._image, self._mtime = None, None
        self._bad: tuple | None = None      # (version, why) of an undecodable version

    def open(self) -> None:
        self._load()

    def _load(self) -> None:
        try:
            st = os.stat(self.path)
        except OSError as exc:
            raise SourceError(f"cannot read {self.path}: {exc.strerror}") from None
        mtime = file_version(st)
        if mtime != self._mtime and (self._bad is None or self._bad[0] != mtime):
            try:
                self._image = read_image(self.path)
                self._mtime, self._bad = mtime, None
            except InputError as exc:
                if self._image is None:
                    raise SourceError(str(exc)) from None
                self._bad = (mtime, str(exc))
                log.warning("%s: keeping the previous image until the file changes (%s)",
                            self.path, exc)

    def read(self) -> Frame:
        self._pacer.wait(self)
        self._load()
        info = {"path": self.path}
        if self._bad is not None:
            info["bad_file"] = self._bad[1]
        return Frame(self._image, time.time(), info=info)


class SequenceSource(Source):
    """Image files matching a glob (or all images in a directory), in name order, at
    ``fps``; looped (the glob is expanded again at every loop, so new files join).

    A file that cannot be decoded is one rejected frame (``info["rejected"]``: the probe
    counts it and lists it in /healthz) and the sequence goes on with the next file; it is
    remembered, and skipped without decoding, until it changes (modification time, size).
    """

    def __init__(self, pattern: str, fps: float = 1.0, loop: bool = True):
        super().__init__()
        self.pattern, self.loop, self.nominal_fps = pattern, loop, fps
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
                image = read_image(path)
            except InputError as exc:
                self._bad[path] = version
                return Frame(None, time.time(), info={"path": path, "rejected": str(exc)})
            self._bad.pop(path, None)
            return Frame(image, time.time(), info={"path": path})
        raise SourceError(f"none of the files matching {self.pattern} can be read")
