"""A Raspberry Pi camera through Picamera2 (imported only when this source is used)."""
from __future__ import annotations

import time

import numpy as np

from .base import Frame, Interrupted, Source, SourceOptions, SourceUnavailable


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
            raise SourceUnavailable("picamera2 is not installed (on Raspberry Pi OS: "
                                    "sudo apt install python3-picamera2, and a venv made "
                                    "with --system-site-packages)") from None
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
            raise Interrupted()
        bgr = self._cam.capture_array("main")
        return Frame(np.ascontiguousarray(bgr[..., 2::-1]), time.time())

    def close(self) -> None:
        if self._cam is not None:
            try:
                self._cam.stop()
                self._cam.close()
            except Exception:  # noqa: BLE001 - best effort on a camera that is gone
                pass
