"""A bracket projected: the SH9 product's share of the merge (no I/O).

:mod:`provider.core.radiometry.bracket` merges a bracket's frames into light (the hat
merge, the live partition's slot tables); projecting them is this product's:

* :func:`project_bracket`: ``shlight compute FRAME@T FRAME@T ...``, the exact hat merge
  projected, with what clipped in every frame;
* :func:`captured_stats`: the radiometry statistics of the frame(s) as the camera captured
  them (a bracket's, or the lux meter's, :mod:`.meter`);
* :class:`BracketProjector`: the live merge of a source that cycles its exposure, one table
  projection a frame (the SH projection is linear: the merged coefficients are the sum of
  the slots' parts).
"""
from __future__ import annotations

import time

import numpy as np

from ..errors import InputError
from ..radiometry.bracket import LinearBracket, merge
from ..radiometry.response import CameraResponse, check_bracket, check_time


def project_bracket(projector, frames, times, *, gain: float = 1.0,
                    f_number: float | None = None):
    """``shlight compute FRAME@T FRAME@T ...``: the exact hat merge
    (:func:`~provider.core.radiometry.bracket.merge`) with the projector's camera response
    (sRGB without one), projected; ``stats`` say ``radiometry: "merged"``, the exposures,
    and what clipped in every frame (``clipped_fraction``) and the share of the light it
    carries (``clipped_light_fraction``, a lower bound). With an absolutely calibrated
    curve (gain = ISO/100, ``f_number`` or the calibration's) the result is in cd/m²
    (:mod:`~provider.core.radiometry.photometry`)."""
    t0 = time.perf_counter()
    frames, times, bits = check_bracket(frames, times)
    response = (projector.response or CameraResponse.srgb()).to_bits(bits)
    m = merge(frames, times, response, gain=gain)
    stats = {}
    factor = projector.absolute_scale(1.0, f_number, stats)
    radiance = m.radiance * np.float32(factor) if factor != 1.0 else m.radiance
    result = projector.project(radiance, units=stats["coefficient_units"])  # + its lux
    short = float(times.min()) * check_time(gain, "gain") / factor
    captured_stats(projector, stats, result.coefficients[0], np.minimum.reduce(frames),
                   response.lut(short), response, merged=m, gain=gain)
    result.stats.update(stats)
    result.stats["compute_ms"] = (time.perf_counter() - t0) * 1e3
    return result


def captured_stats(projector, stats: dict, l00, lowest, table, response, *, merged=None,
                   gain: float = 1.0) -> None:
    """The radiometry statistics of frame(s) as the camera captured them, into ``stats``
    (:func:`project_bracket`'s, and the lux meter's of what it closed,
    :func:`provider.core.sh9.meter.project_with_meter`): a bracket's (``merged``: its
    :func:`~provider.core.radiometry.bracket.merge`) ``clipped_fraction``, ``exposures_s``
    and ``gain`` when ≠ 1, else one frame's own ``clipped_fraction``;
    ``clipped_light_fraction``, what clipped in every frame (``lowest``: their per-sample
    minimum, 8/16-bit, read through ``table``: the shortest frame's, in the result's units)
    over all the light (``l00``: (3,) the captured L00, before rotation); ``radiometry``
    ("merged" for a bracket, else the projector's) and ``response`` (``response``: the
    curve at the frames' bit depth)."""
    if merged is not None:
        stats.update(clipped_fraction=merged.clipped_fraction, exposures_s=merged.times)
        if gain != 1.0:
            stats["gain"] = float(gain)
    clipped = projector.clipping(lowest, table, {} if merged is not None else stats)
    projector.radiometry_stats(stats, np.asarray(l00)[None], clipped * projector.exposure,
                               "merged" if merged is not None else projector.radiometry)
    stats["response"] = response.method


class BracketProjector:
    """The live merge of a source that cycles its exposure over slots (see the module doc).

    ``push(slot, frame, exposure_s, gain)`` projects the frame through its slot's table,
    keeps that (9, 3) part, and returns an :class:`~.result.SH9Result` for *every* frame:
    the sum of the newest part of every slot (``radiometry: "merged"``) once each slot has
    one, the single frame's own result until then. ``slot_exposures`` are the nominal
    exposures t·gain of the slots (the partition's knots). ``clipped_fraction`` of a merged
    result is the shortest slot's (a sample clipped in the shortest exposure of a static
    view is clipped in all of them), ``clipped_light_fraction`` the share of L00 those
    samples carry (a lower bound: the sun).

    A part whose L00 moved by more than ``restart`` of the set's L00 since that slot's last
    frame (a lamp switched on, the camera moved) restarts the set: the merged sum would
    otherwise mix the old light with the new for up to a cycle.
    """

    def __init__(self, projector, slot_exposures, *, restart: float = 0.1):
        self.projector = projector
        self.response = projector.response or CameraResponse.srgb()
        self.slot_exposures = tuple(float(check_time(t, "slot exposure")) for t in slot_exposures)
        self.restart = float(restart)
        self._brackets: dict = {}
        n = len(self.slot_exposures)
        self.parts: list = [None] * n
        self._clipped: list = [None] * n
        self._fraction: list = [None] * n
        self.exposures: list = [None] * n
        #: each slot's newest frame, kept only when ``keep_frames`` (a lux meter closes the
        #: merged pixels: serve --lux with a bracket); None else
        self.keep_frames = False
        self.frames: list = [None] * n
        self.restarts = 0
        self._bracket(8)  # validates the slots now

    def _bracket(self, bits: int) -> LinearBracket:
        lb = self._brackets.get(bits)
        if lb is None:
            lb = LinearBracket(self.response.to_bits(bits), self.slot_exposures)
            self._brackets[bits] = lb
        return lb

    @property
    def complete(self) -> bool:
        return all(p is not None for p in self.parts)

    def push(self, slot: int, frame: np.ndarray, exposure_s: float, gain: float = 1.0,
             f_number: float | None = None):
        """(``f_number``: the frame's aperture; with an absolutely calibrated curve the
        parts are in cd/m², ``coefficient_units``; ``illuminance_lux`` then comes from the
        merged SH9, the parts' pixels being gone.)"""
        t0 = time.perf_counter()
        if not 0 <= slot < len(self.parts):
            raise InputError(f"bracket slot {slot} out of range (0..{len(self.parts) - 1})")
        k = 1.0 / (check_time(exposure_s, "exposure_s") * check_time(gain, "gain"))
        units = {}
        k = self.projector.absolute_scale(k, f_number, units)
        bits = 16 if getattr(frame, "dtype", None) == np.uint16 else 8
        coeffs, clipped, stats = self.projector.project_part(
            frame, self._bracket(bits).slot_table(slot))
        coeffs, clipped = coeffs * k, clipped * k
        old = self.parts[slot]
        if old is not None and self.complete:
            total = sum(float(np.sum(p[0])) for p in self.parts)
            if abs(float(np.sum(coeffs[0])) - float(np.sum(old[0]))) > self.restart * abs(total):
                self.parts = [None] * len(self.parts)
                self.frames = [None] * len(self.parts)
                self.restarts += 1
        self.parts[slot], self._clipped[slot] = coeffs, clipped
        if self.keep_frames:      # a copy: a source may reuse its buffer for the next frame
            self.frames[slot] = np.array(frame, copy=True)
        self._fraction[slot] = stats["clipped_fraction"]
        self.exposures[slot] = float(exposure_s) * float(gain)
        if not self.complete:
            result = self.projector.project(frame, exposure_s=exposure_s, gain=gain,
                                            f_number=f_number)
            result.stats["bracket_slots"] = sum(p is not None for p in self.parts)
            return result
        total = self.parts[0]
        for p in self.parts[1:]:
            total = total + p
        short = self._bracket(bits).shortest
        stats["clipped_fraction"] = self._fraction[short]
        stats["exposures_s"] = list(self.exposures)
        self.projector.radiometry_stats(stats, total, self._clipped[short], "merged")
        stats["response"] = self.response.method
        stats.update(units)
        result = self.projector.result(total, stats)
        result.stats["compute_ms"] = (time.perf_counter() - t0) * 1e3
        return result
