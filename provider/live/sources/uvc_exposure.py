"""The exposure of a UVC camera read through OpenCV (:class:`~.opencv.OpenCVSource`;
docs/contract.md §9, :mod:`.exposure`).

``CAP_PROP_EXPOSURE`` has no fixed unit (V4L2: 100 µs; DirectShow and Media Foundation:
log2 seconds) and under auto exposure many drivers report the last manual value, not the one
in use: it is read only in the unit the user names (``--exposure-unit``), and a value that
is not a plausible exposure in that unit is never divided by (one warning). A bracket
switches auto exposure off (``CAP_PROP_AUTO_EXPOSURE`` 1 on V4L2, 0.25 on older and
DirectShow builds), sets ``CAP_PROP_EXPOSURE`` per slot, reads every setting back to confirm
the driver took it, and drops ``SETTLE_FRAMES`` frames after each change (UVC cameras queue
a few). A driver that refuses manual exposure is reported once and the camera runs
unbracketed.
"""
from __future__ import annotations

import logging
import math
import time

import cv2

from . import exposure as X
from .base import Frame

log = logging.getLogger("shlight.source")

SETTLE_FRAMES = 3


class UvcExposure:
    """What an :class:`~.opencv.OpenCVSource` camera knows and does about exposure."""

    def __init__(self, source):
        self.src = source
        self.unit = source.options.exposure_unit
        self.slots = None               # bracket: exposure (s) per slot
        self.slot = 0
        self.settle = 0
        self._nonsense = False

    def _now(self) -> float | None:
        value = self.src._cap.get(cv2.CAP_PROP_EXPOSURE)
        seconds = X.to_seconds(value, self.unit)
        if seconds is None and not self._nonsense:
            self._nonsense = True
            log.warning("camera %s: CAP_PROP_EXPOSURE is %r, not an exposure in %s: not used",
                        self.src.target, value, self.unit)
        return seconds

    def _set(self, seconds: float) -> float | None:
        """Set CAP_PROP_EXPOSURE; the seconds the driver reads back, or None."""
        self.src._cap.set(cv2.CAP_PROP_EXPOSURE, X.from_seconds(seconds, self.unit))
        return X.to_seconds(self.src._cap.get(cv2.CAP_PROP_EXPOSURE), self.unit)

    def frame(self, rgb) -> Frame:
        """A frame just read, with its exposure; when bracketing, the settled frame of the
        next slot (``grab`` reads more)."""
        if self.slots is None:
            t = self._now() if self.unit else None
            return Frame(rgb, time.time(), info=X.frame_info(t))
        while self.settle > 0:           # frames the camera queued before the change
            self.settle -= 1
            rgb = self.src._grab()
        slot, t = self.slot, self.slots[self.slot]
        self._set_slot((slot + 1) % len(self.slots))
        return Frame(rgb, time.time(), info=X.frame_info(t, slot=slot, bracket=tuple(self.slots)))

    def start_bracket(self) -> None:
        offsets = self.src.options.bracket
        if not (offsets and self.unit) or not isinstance(self.src.target, int) and \
                not str(self.src.target).startswith("/dev/"):
            return
        cap, target = self.src._cap, self.src.target
        base = X.to_seconds(cap.get(cv2.CAP_PROP_EXPOSURE), self.unit)
        if not (cap.set(cv2.CAP_PROP_AUTO_EXPOSURE, 1) or
                cap.set(cv2.CAP_PROP_AUTO_EXPOSURE, 0.25)):
            log.error("camera %s: the driver refuses manual exposure: no bracket (frames are "
                      "used one by one)", target)
            return
        if base is None:                 # no usable reading: meter a frame from 1/100 s
            base = 0.01
            for _ in range(3):
                got = self._set(base)
                if got is None:
                    break
                for _ in range(SETTLE_FRAMES):
                    self.src._grab()
                base = X.meter(self.src._grab(), got)
        slots = X.plan(offsets, base, lambda want: X.to_seconds(
            X.from_seconds(want, self.unit), self.unit) or want)
        for t in slots:                  # the driver must take every setting
            got = self._set(t)
            if got is None or abs(math.log2(got / t)) > 0.5:
                log.error("camera %s: set exposure %.4g s, the driver reports %s: it does "
                          "not take manual exposure; no bracket", target, t,
                          "nothing" if got is None else f"{got:.4g} s")
                cap.set(cv2.CAP_PROP_AUTO_EXPOSURE, 3)
                return
        self.slots = slots
        self._hold_white_balance()
        log.info("camera %s: bracketing %s EV around %.4g s: %s", target,
                 ", ".join(f"{e:+g}" for e in offsets), base,
                 ", ".join(f"{t:.4g} s" for t in slots))
        self._set_slot(0)

    def _hold_white_balance(self) -> None:
        """Auto white balance off at the temperature it had (V4L2
        ``white_balance_automatic`` 0, ``white_balance_temperature`` kept): the room's colour
        temperature is then measured, not normalised away (issue 31). A driver without
        these controls is said once; its frames stay white-balanced by the camera."""
        cap, target = self.src._cap, self.src.target
        kelvin = cap.get(cv2.CAP_PROP_WB_TEMPERATURE)
        if cap.set(cv2.CAP_PROP_AUTO_WB, 0) and kelvin and kelvin > 0:
            cap.set(cv2.CAP_PROP_WB_TEMPERATURE, kelvin)
            log.info("camera %s: white balance held at %.0f K", target, kelvin)
        else:
            log.info("camera %s: the driver does not hold white balance (colour temperature "
                     "is then the camera's normalised one)", target)

    def _set_slot(self, slot: int) -> None:
        self.slot = slot
        self._set(self.slots[slot])
        self.settle = SETTLE_FRAMES
