"""A Raspberry Pi camera through Picamera2 (imported only when this source is used)."""
from __future__ import annotations

import logging
import time

import numpy as np

from ...core.errors import InputError
from .base import Frame, Interrupted, Source, SourceOptions, SourceUnavailable
from .exposure import frame_info, match_slot, plan

log = logging.getLogger("shlight.source")


class Picamera2Source(Source):
    """A Raspberry Pi camera through Picamera2 (OpenCV has no libcamera back end).

    Picamera2's "RGB888" format arrives in B, G, R byte order (docs/contract.md §8): it is
    swapped here. Every frame comes with its own metadata (``capture_request``), so each
    frame reports its exposure: ExposureTime × AnalogueGain × DigitalGain.

    ``options.bracket`` (EV offsets): after auto exposure settles, AE (and AWB) are switched
    off and the exposure cycles ``base · 2**ev`` (ExposureTime first, AnalogueGain beyond the
    camera's longest exposure). Controls take effect a few frames after they are set, so a frame is
    assigned to a slot only when *its metadata* says it has that slot's exposure; frames in
    between are dropped.
    """

    #: Frames to wait for auto exposure to settle (AeLocked) before a bracket starts.
    AE_FRAMES = 30
    #: Frames to wait for a requested exposure before giving up on that slot once.
    CONFIRM_FRAMES = 12

    def __init__(self, index: int, options: SourceOptions):
        super().__init__()
        self.index, self.options = index, options
        self._cam = None
        self._slots = None            # nominal exposures t·gain of the bracket's slots
        self._controls = []           # per slot: the controls that give its exposure
        self._want = 0                # the slot requested last
        self._waited = 0
        self._missed = set()

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
        if self.options.bracket:
            self._start_bracket(self.options.bracket)

    # -- frames and their metadata ------------------------------------------------------------
    def _capture(self):
        request = self._cam.capture_request()
        try:
            rgb = np.ascontiguousarray(request.make_array("main")[..., 2::-1])
            metadata = request.get_metadata() or {}
        finally:
            request.release()
        return rgb, metadata

    @staticmethod
    def _exposure(md: dict):
        """(exposure_s, gain) from a frame's metadata, or (None, 1)."""
        t = md.get("ExposureTime")
        if not t:
            return None, 1.0
        return t * 1e-6, float(md.get("AnalogueGain", 1.0)) * float(md.get("DigitalGain", 1.0))

    def read(self) -> Frame:
        while True:
            if self._stop.is_set():
                raise Interrupted()
            rgb, md = self._capture()
            t, gain = self._exposure(md)
            if self._slots is None:
                return Frame(rgb, time.time(), info=frame_info(t, gain))
            slot = match_slot(self._slots, t * gain) if t else None
            self._waited += 1
            if slot == self._want or self._waited > self.CONFIRM_FRAMES:
                if slot != self._want and self._want not in self._missed:
                    self._missed.add(self._want)
                    log.warning("picamera2: bracket slot %d (%.3g s·gain) not confirmed by "
                                "the frames' metadata (they report %s); moving on",
                                self._want, self._slots[self._want],
                                f"{t * gain:.3g}" if t else "no ExposureTime")
                self._request((self._want + 1) % len(self._slots))
            if slot is not None:
                return Frame(rgb, time.time(), info=frame_info(
                    t, gain, slot=slot, bracket=tuple(self._slots)))

    # -- the bracket --------------------------------------------------------------------------
    def _start_bracket(self, offsets) -> None:
        md = {}
        for _ in range(self.AE_FRAMES):          # let auto exposure settle first
            _, md = self._capture()
            if md.get("AeLocked"):
                break
        t, gain = self._exposure(md)
        if t is None:
            raise InputError("picamera2 reports no ExposureTime: cannot bracket")
        again = float(md.get("AnalogueGain", 1.0))
        limits = getattr(self._cam, "camera_controls", {}) or {}
        tmin, tmax = [v * 1e-6 for v in (limits.get("ExposureTime") or (1, 1e6))[:2]]
        gmin, gmax = (limits.get("AnalogueGain") or (1.0, 16.0))[:2]

        def settable(total):
            exp = min(max(total / again, tmin), tmax)
            g = min(max(total / exp, gmin), gmax)
            return exp, g

        self._slots = plan(offsets, t * gain, lambda total: np.prod(settable(total)))
        # the gains auto white balance had settled on, held (issue 31: the room's colour
        # temperature is measured, not normalised away)
        gains = md.get("ColourGains")
        held = {"ColourGains": tuple(float(v) for v in gains)} if gains else {}
        self._controls = []
        for total in self._slots:
            exp, g = settable(total)
            # white balance frozen too: the slots of one set must share their colour gains
            self._controls.append({"AeEnable": False, "AwbEnable": False, **held,
                                   "ExposureTime": int(round(exp * 1e6)),
                                   "AnalogueGain": float(g)})
        longest = max(c["ExposureTime"] for c in self._controls)
        lo = int(round(1e6 / self.options.fps)) if self.options.fps else 0
        self._cam.set_controls({"FrameDurationLimits": (lo or 1000, max(lo, longest + 1000))})
        log.info("picamera2: bracketing %s EV around %.3g s × gain %.2f: exposures %s",
                 ", ".join(f"{e:+g}" for e in offsets), t, gain,
                 ", ".join(f"{c['ExposureTime'] / 1e6:.3g} s×{c['AnalogueGain']:.2f}"
                           for c in self._controls))
        self._request(0)

    def _request(self, slot: int) -> None:
        self._want, self._waited = slot, 0
        self._cam.set_controls(dict(self._controls[slot]))

    def close(self) -> None:
        if self._cam is not None:
            try:
                self._cam.stop()
                self._cam.close()
            except Exception:  # noqa: BLE001 - best effort on a camera that is gone
                pass
