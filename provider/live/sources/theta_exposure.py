"""The exposure of a Ricoh Theta over Wi-Fi (:class:`~.theta.ThetaSource`), through the Open
Spherical Camera options (docs/contract.md §9, :mod:`.exposure`).

Only with ``options.query_exposure`` (``--camera``) or ``options.bracket``, as it costs
commands: ``camera.getOptions`` gives exposureProgram, shutterSpeed and iso. In manual mode
(exposureProgram 1) every frame reports shutterSpeed and ISO/100; in auto mode the camera
does not say what it uses and nothing is divided. A bracket switches the camera to manual
at a fixed ISO, meters a preview frame when the exposure is unknown, then sets
``shutterSpeed`` per slot with ``camera.setOptions`` (the nearest speed the camera supports)
and drops the preview frames of ``SETTLE_S`` seconds (and at least ``SETTLE_FRAMES``) after
each change, as the MJPEG preview lags the option; the camera's own options are restored on
close. Not tried on a real Theta: the tests use a fake OSC camera that honours setOptions.
"""
from __future__ import annotations

import logging
import math
import time

from . import exposure as X
from .base import Frame, Interrupted, SourceError

log = logging.getLogger("shlight.source")

SETTLE_S = 0.4
SETTLE_FRAMES = 2
#: Shutter speeds of a Theta S/V/Z1 (s), used when getOptions gives no support list.
SPEEDS = (1 / 25000, 1 / 16000, 1 / 12500, 1 / 10000, 1 / 8000, 1 / 6400, 1 / 5000, 1 / 4000,
          1 / 3200, 1 / 2500, 1 / 2000, 1 / 1600, 1 / 1250, 1 / 1000, 1 / 800, 1 / 640,
          1 / 500, 1 / 400, 1 / 320, 1 / 250, 1 / 200, 1 / 160, 1 / 125, 1 / 100, 1 / 80,
          1 / 60, 1 / 50, 1 / 40, 1 / 30, 1 / 25, 1 / 20, 1 / 15, 1 / 13, 1 / 10, 1 / 8,
          1 / 6, 1 / 5, 0.25, 0.3, 0.4, 0.5, 0.625, 0.8, 1.0, 1.3, 1.6, 2.0, 2.5, 3.2, 4.0,
          5.0, 6.0, 8.0, 10.0, 13.0, 15.0, 20.0, 25.0, 30.0, 60.0)
OPTIONS = ["exposureProgram", "shutterSpeed", "iso", "shutterSpeedSupport", "isoSupport",
           "aperture", "whiteBalance"]
#: The white balance a bracket holds when the camera's is "auto" (issue 31: colour
#: temperature is measured, not normalised away by the camera; OSC's "daylight" is a
#: fixed ~5,200 K balance on every Theta; Theta V/Z1 also take "_colorTemperature").
HELD_WHITE_BALANCE = "daylight"


class ThetaExposure:
    """What a :class:`~.theta.ThetaSource` knows and does about exposure."""

    def __init__(self, source):
        self.src = source
        self.fixed = None               # (shutterSpeed, gain) of a camera in manual mode
        self.slots = self.speeds = None
        self.gain = 1.0
        self.f_number = None            # OSC "aperture" (a Theta S/V is fixed at f/2.0)
        self.restore = None             # the camera's options before the bracket
        self.slot = 0

    def _params(self, **p) -> dict:
        return {**p, "sessionId": self.src._session} if self.src._session else p

    def _set(self, options: dict, timeout: float | None = None) -> None:
        self.src._execute("camera.setOptions", self._params(options=options), timeout=timeout)

    def setup(self) -> None:
        """After the preview is open: read the options; start the bracket."""
        o = self.src.options
        if not (o.bracket or o.query_exposure):
            return
        try:
            reply = self.src._execute("camera.getOptions", self._params(optionNames=OPTIONS))
        except SourceError as exc:
            log.warning("%s: camera.getOptions refused (%s): exposure unknown%s",
                        self.src.base, exc, "; no bracket" if o.bracket else "")
            return
        opts = (reply.get("results") or {}).get("options") or {}
        program, speed, iso = (opts.get("exposureProgram"), opts.get("shutterSpeed") or 0,
                               opts.get("iso") or 0)
        manual = program == 1 and speed > 0 and iso > 0
        aperture = opts.get("aperture")
        if isinstance(aperture, (int, float)) and not isinstance(aperture, bool) \
                and math.isfinite(aperture) and aperture > 0:
            self.f_number = float(aperture)
        if not o.bracket:
            if manual:
                self.fixed = (float(speed), iso / 100.0)
            else:
                log.info("%s: the Theta is on auto exposure (exposureProgram %s) and does not "
                         "report the exposure it uses: coefficients are relative to it",
                         self.src.base, program)
            return
        self.restore = {k: opts[k] for k in ("exposureProgram", "shutterSpeed", "iso",
                                             "whiteBalance") if k in opts}
        speeds = sorted(float(v) for v in (opts.get("shutterSpeedSupport") or SPEEDS))
        isos = [i for i in (opts.get("isoSupport") or [100]) if i > 0]
        iso = iso if manual else min([i for i in isos if i >= 100] or isos or [100])
        self.gain = iso / 100.0
        nearest = lambda t: min(speeds, key=lambda v: abs(math.log(v / t)))  # noqa: E731
        held = {"whiteBalance": HELD_WHITE_BALANCE} if opts.get("whiteBalance") == "auto" else {}
        self._set({"exposureProgram": 1, "iso": iso,
                   "shutterSpeed": speed if manual else nearest(1 / 100), **held})
        if held:
            log.info("%s: white balance held at %s while bracketing (auto would normalise "
                     "the room's colour temperature away)", self.src.base, HELD_WHITE_BALANCE)
        base = speed * self.gain if manual else self._meter(nearest)
        self.slots = X.plan(o.bracket, base, lambda want: nearest(want / self.gain) * self.gain)
        self.speeds = [nearest(t / self.gain) for t in self.slots]
        log.info("%s: bracketing %s EV at ISO %d: shutter %s", self.src.base,
                 ", ".join(f"{e:+g}" for e in o.bracket), iso,
                 ", ".join(f"{v:.4g} s" for v in self.speeds))

    def _settled_jpeg(self) -> bytes:
        """The first preview frame after the last change has settled."""
        until = time.monotonic() + SETTLE_S
        for _ in range(SETTLE_FRAMES):
            self.src._reader.next_jpeg()
        while True:
            if self.src._stop.is_set():
                raise Interrupted()
            jpeg = self.src._reader.next_jpeg()
            if time.monotonic() >= until:
                return jpeg

    def _meter(self, nearest) -> float:
        """Exposure t·gain that puts a preview frame's median at mid-grey (manual mode)."""
        t = nearest(1 / 100)
        for _ in range(3):
            frame = Frame(None, 0.0, jpeg=self._settled_jpeg()).decoded(
                self.src.options.max_pixels)
            want = X.meter(frame, t * self.gain) / self.gain
            if abs(math.log2(want / t)) < 0.5:
                break
            t = nearest(want)
            self._set({"shutterSpeed": t})
        return t * self.gain

    def read(self) -> Frame:
        """The next frame: of the next slot when bracketing (after its setOptions settled),
        else the next preview frame with the exposure of a camera in manual mode."""
        if self.slots is None:
            info = X.frame_info(*self.fixed, **self._aperture()) if self.fixed else {}
            return Frame(None, time.time(), jpeg=self.src._reader.next_jpeg(), info=info)
        slot = self.slot
        self._set({"shutterSpeed": self.speeds[slot]})
        jpeg = self._settled_jpeg()
        self.slot = (slot + 1) % len(self.slots)
        return Frame(None, time.time(), jpeg=jpeg, info=X.frame_info(
            self.speeds[slot], self.gain, slot=slot, bracket=tuple(self.slots),
            **self._aperture()))

    def _aperture(self) -> dict:
        """``f_number`` for Frame.info where the camera said its aperture."""
        return {"f_number": self.f_number} if self.f_number else {}

    def close(self) -> None:
        """Give the camera back its own exposure settings (it may be gone)."""
        if self.restore:
            try:
                self._set(self.restore, timeout=1.0)
            except Exception:  # noqa: BLE001
                pass
            self.restore = None
