"""Exposure on live sources (docs/contract.md §9): what a source reports per frame, and the
bracket it cycles when it can set its exposure.

Every source that knows a frame's exposure puts it in ``Frame.info``: ``exposure_s`` (the
exposure time, seconds) and ``gain`` (analogue × digital gain, or ISO/100; 1 when
unknown), and the probe divides the coefficients by their product, so that auto exposure
no longer makes the lighting jump. A source cycling a bracket (``--bracket``) also sets
``slot`` (which exposure of the bracket this frame is, *confirmed* by the camera where it
can say so) and ``bracket`` (the nominal exposures t·gain of all slots); the probe merges
the newest frame of every slot (:class:`~provider.core.sh9.bracket_projection.BracketProjector`).

Who can do what:

* ``picamera2``: reports ExposureTime × AnalogueGain × DigitalGain from each frame's
  metadata; brackets with per-frame controls, each frame assigned to a slot by its own
  metadata.
* a UVC camera through OpenCV: ``CAP_PROP_EXPOSURE`` has no fixed unit. V4L2 gives
  ``exposure_time_absolute`` in 100 µs units, DirectShow and Media Foundation log2 seconds
  (-6 = 1/64 s), and under auto exposure many drivers report the last manual value, not the
  one in use. So it is read only when the user names the unit (``--exposure-unit``), and
  bracketing needs it too.
* ``theta://``: the Open Spherical Camera options: in manual mode (exposureProgram 1)
  ``shutterSpeed`` and ``iso`` are the exposure; in auto mode the camera does not say.
  Brackets switch it to manual and set ``shutterSpeed`` per slot (``camera.setOptions``),
  discarding the preview frames of a short settling time after each change.
* every other source (demo, files, MJPEG, RTSP, relay) cannot set its exposure: ``--bracket``
  with one is refused at start.
"""
from __future__ import annotations

import logging
import math

import numpy as np

from ...core.radiometry.bracket import check_offsets, match_slot  # noqa: F401 (match_slot: the sources')
from ...core.errors import InputError

log = logging.getLogger("shlight.source")

#: Source kinds (SourceSpec.kind) that can cycle their exposure.
BRACKETING_KINDS = ("picamera2", "camera", "theta")

#: ``--exposure-unit``: what a UVC driver's CAP_PROP_EXPOSURE means.
EXPOSURE_UNITS = ("100us", "log2s", "s")


def check_bracket_support(kind: str, description: str, offsets, exposure_unit) -> tuple | None:
    """The checked EV offsets, or :class:`InputError` at start for a source that cannot
    bracket (one clear line, instead of a probe that silently never merges)."""
    if not offsets:
        return None
    offsets = check_offsets(offsets)
    if kind not in BRACKETING_KINDS:
        raise InputError(f"--bracket: {description} cannot set its exposure; bracketing "
                         "works with picamera2, a UVC camera (with --exposure-unit) and "
                         "theta://")
    if kind == "camera" and not exposure_unit:
        raise InputError(f"--bracket with {description} needs --exposure-unit (what the "
                         "driver's CAP_PROP_EXPOSURE means: 100us for V4L2 on Linux, log2s "
                         "for DirectShow/Media Foundation)")
    return offsets


def to_seconds(value: float, unit: str) -> float | None:
    """CAP_PROP_EXPOSURE in ``unit`` -> seconds, or None when it is not a plausible exposure
    (the driver gave nonsense: never divide by it)."""
    if value is None or not math.isfinite(value):
        return None
    if unit == "100us":
        s = value * 1e-4
    elif unit == "log2s":
        s = 2.0 ** value if abs(value) < 40 else float("nan")
    elif unit == "s":
        s = value
    else:
        raise InputError(f"unknown exposure unit {unit!r} (one of {', '.join(EXPOSURE_UNITS)})")
    return s if 1e-6 <= s <= 60.0 else None


def from_seconds(seconds: float, unit: str) -> float:
    """Seconds -> the value to set as CAP_PROP_EXPOSURE in ``unit``."""
    if unit == "100us":
        return max(1.0, round(seconds * 1e4))
    if unit == "log2s":
        return round(math.log2(seconds))
    return seconds


def meter(rgb: np.ndarray, exposure: float) -> float:
    """The exposure (same units as ``exposure``) that would put this 8-bit frame's median
    at mid-grey, assuming sRGB (a first guess for a bracket's centre; clipped or black
    frames move it by 4 EV)."""
    lum = np.asarray(rgb, np.float64).mean(axis=-1) / 255.0
    med = float(np.median(lum))
    if med >= 0.98:
        return exposure / 16
    if med <= 0.02:
        return exposure * 16
    lin = med / 12.92 if med <= 0.04045 else ((med + 0.055) / 1.055) ** 2.4
    return exposure * 0.18 / lin


def plan(offsets, base: float, achievable) -> list[float]:
    """Nominal exposures (t·gain) of the slots: ``base · 2**ev`` each, as ``achievable(want)``
    (the camera's nearest settable exposure) makes it; slots that collapse onto a
    neighbour (closer than 0.5 EV, at a camera limit) are dropped with a warning. Raises
    :class:`InputError` when fewer than 2 remain."""
    out = []
    for ev in offsets:
        want = base * 2.0 ** ev
        got = float(achievable(want))
        if abs(math.log2(got / want)) > 0.25:
            log.warning("bracket %+g EV: asked for %.3g, the camera can do %.3g", ev, want, got)
        if any(abs(math.log2(got / o)) < 0.5 for o in out):
            log.warning("bracket %+g EV dropped: the camera cannot reach it", ev)
            continue
        out.append(got)
    if len(out) < 2:
        raise InputError("the camera cannot set the bracket's exposures (fewer than 2 "
                         "distinct ones)")
    return out


def frame_info(exposure_s: float | None, gain: float = 1.0, **extra) -> dict:
    """``Frame.info`` for a frame of known exposure (empty when unknown)."""
    if exposure_s is None or not (exposure_s > 0 and math.isfinite(exposure_s)):
        return dict(extra)
    info = {"exposure_s": float(exposure_s), **extra}
    if gain and math.isfinite(gain) and gain > 0 and gain != 1.0:
        info["gain"] = float(gain)
    return info


def still_info(path) -> dict:
    """``Frame.info`` of a JPEG/TIFF still from its EXIF (ExposureTime, ISO as gain =
    ISO/100, FNumber as ``f_number``; issue 31), empty when it says no exposure time."""
    from ...core.radiometry.exif import read_still_exposure
    e = read_still_exposure(path)
    extra = {"f_number": e.f_number} if e.f_number else {}
    return frame_info(e.exposure_s, (e.iso or 100.0) / 100.0, **extra) if e.exposure_s else {}
