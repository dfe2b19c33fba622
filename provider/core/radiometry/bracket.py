"""Brackets: frames of one static view at several exposures -> scene-referred light (no I/O).

* :func:`merge`: a bracket -> radiance per second of exposure (float32 H×W×3), Debevec's hat
  weights ``w(z) = min(z, top − z)`` per channel sample, so a sample clipped (or black) in
  one frame is taken from the others; a sample clipped in *every* frame takes the shortest
  frame's clip level (a lower bound) and is counted in ``clipped_fraction``.
  :func:`~provider.core.sh9.bracket_projection.project_bracket` projects it and says what
  the numbers are (``shlight compute FRAME@SECONDS FRAME@SECONDS ...``).
  :func:`merge_opencv` is OpenCV's ``createMergeDebevec``, for comparison only: it merges
  in the log domain with one weight per pixel and measured 1.6-3.7 % worse on the real
  panoramas.
* The live path (:class:`~provider.core.sh9.bracket_projection.BracketProjector`, which
  projects the slots' tables) for a source that cycles its exposure: the
  weights of :func:`partition_weights` are a *partition of unity* over the bracket (linear
  B-spline hats in log exposure with knots at the slots' exposures), so the merged radiance
  is a plain **sum** of per-slot table lookups, ``R = Σ_i a_i(z_i)·g(z_i)/(t_i·gain_i)``.
  The SH projection is linear, so the merged coefficients are the sum of per-slot
  coefficients: a new frame costs one table projection (the single-frame calibrated path
  with another table) and an update goes out on every frame. Measured: 1.18× (512×256)
  and 1.35× (1920×960) the single-frame sRGB path; its SH9 irradiance differs from the
  exact hat merge of the same frames by 0.01-0.3 % (docs/radiometry.md).

Moving scenes: the partition assumes the view is static over one cycle. A slot whose light
jumped (a lamp switched on) restarts the set (``BracketProjector``).

Only the merge's maths lives here: projecting a bracket is the SH9 product's
(:mod:`provider.core.sh9.bracket_projection`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..errors import InputError
from .response import (CameraResponse, ResponseError, _as_lut, _positive_floor, _top, apply_lut,
                       check_bracket, check_time)

#: Weight of a clipped sample in the shortest frame and of a black one in the longest, so
#: that a sample clipped in every frame takes the shortest frame's lower bound (and a black
#: one the longest frame's value) instead of 0/0.
END_WEIGHT = 1.0 / 64.0
#: Weight (times the hat) of a code outside the curve's trusted range: a sample seen there
#: only (no frame of the bracket has it in the calibrated range) still gets a value, but any
#: frame that has it inside the range outweighs it 1000 to 1.
UNTRUSTED_WEIGHT = 1e-3


def hat_weights(bits: int = 8, trusted=None) -> np.ndarray:
    """Debevec's hat ``w(z) = min(z, top − z)`` (0 at black and at clipping), float64.

    ``trusted``: the (lo, hi) 8-bit codes where the curve was calibrated (camera.json's
    ``params.trusted_codes``), or one (lo, hi) per channel (``params.trusted_codes_rgb``:
    then the weights are (2**bits, 3)); codes outside weigh :data:`UNTRUSTED_WEIGHT` × the
    hat. Why: a bracket wider than the calibration's puts the extra frames' samples in the
    toe and the shoulder, where the curve is extrapolated; with the plain hat their weight
    (code 30 weighs 30) moved a room's level by up to 5.5 % between a ±4 and a ±6 EV
    bracket of one simulated camera (docs/photometry.md). Per channel, because a tinted
    room puts one channel's samples low in the codes where another channel's curve is not
    trusted: one range for all made the weakest channel's toe every channel's."""
    top = _top(bits)
    z = np.arange(top + 1, dtype=np.float64)
    w = np.minimum(z, top - z)
    if trusted is None:
        return w
    ranges = np.asarray(trusted, np.int64) * (257 if bits == 16 else 1)
    if ranges.ndim == 1:
        w[(z < ranges[0]) | (z > ranges[1])] *= UNTRUSTED_WEIGHT
        return w
    w = np.repeat(w[:, None], 3, axis=1)
    for c, (lo, hi) in enumerate(ranges):
        w[(z < lo) | (z > hi), c] *= UNTRUSTED_WEIGHT
    return w


def trusted_ranges(response: CameraResponse):
    """The codes where ``response`` was calibrated: camera.json's per-channel
    ``trusted_codes_rgb`` where it has them, else ``trusted_codes`` (one range), else
    None (every code trusted: sRGB, a gamma, a table without a record)."""
    p = response.params
    own = p.get("trusted_codes_rgb")
    if isinstance(own, (list, tuple)) and len(own) == 3:
        return own
    return p.get("trusted_codes")


@dataclass
class Merged:
    """A merged bracket.

    radiance : (H, W, 3) float32, radiance per second of exposure (see module doc).
    clipped_fraction : fraction of channel samples at the top code in *every* frame (their
        radiance is only a lower bound: light that was never measured).
    black_fraction : fraction of channel samples at code 0 in every frame.
    """

    radiance: np.ndarray
    clipped_fraction: float
    black_fraction: float
    times: list = field(default_factory=list)


def _slot_tables(response: CameraResponse, times: np.ndarray, gain: float):
    """Per frame: (numerator table w·g/(t·gain), weight table w) for the hat merge."""
    w0 = hat_weights(response.bits, trusted_ranges(response))
    top = _top(response.bits)
    short, long_ = int(np.argmin(times)), int(np.argmax(times))
    out = []
    for i, t in enumerate(times):
        w = w0.copy()
        if i == short:
            w[top] = END_WEIGHT
        if i == long_:
            w[0] = END_WEIGHT
        num = (w if w.ndim == 2 else w[:, None]) * response.table / (t * gain)
        out.append((_as_lut(num, response.bits, response.channels_identical and w.ndim == 1),
                    _as_lut(w, response.bits, w.ndim == 1)))
    return out


def _extreme_fractions(frames, bits):
    top = _top(bits)
    lo = frames[0]
    hi = frames[0]
    for f in frames[1:]:
        lo = np.minimum(lo, f)
        hi = np.maximum(hi, f)
    n = lo.size
    return np.count_nonzero(lo == top) / n, np.count_nonzero(hi == 0) / n


def merge(frames, times, response: CameraResponse, *, gain: float = 1.0) -> Merged:
    """Hat-weighted merge of a bracket into radiance per second of exposure.

    ``R = Σ_i w(z_i) g(z_i)/(t_i·gain) / Σ_i w(z_i)`` per channel sample, ``w`` the hat
    (:func:`hat_weights`, near 0 outside a calibrated curve's trusted codes, each channel's
    own, so a bracket's span does not move the scale): a sample clipped or black in one
    frame gets weight 0 there and is taken from the others; a sample clipped in every frame
    gets the shortest frame's clip level (``END_WEIGHT``), a lower bound. A sample that a
    shorter frame shows brighter than this frame can measure (above its curve's last trusted
    code) is clipped whatever its code says (:func:`_evidence`). 8-bit frames go through
    cv2.LUT, 16-bit through numpy gathers.
    """
    frames, times, bits = check_bracket(frames, times)
    gain = check_time(gain, "gain")
    if bits != response.bits:
        raise ResponseError(f"{bits}-bit frames need a {bits}-bit response "
                            f"(use response.to_bits({bits}))")
    num = np.zeros(frames[0].shape, np.float32)
    den = np.zeros(frames[0].shape, np.float32)
    tables = _slot_tables(response, times, gain)
    evidence, ceiling = _evidence(response)
    top = _top(bits)
    shorter = None
    for i in np.argsort(times, kind="stable"):
        f, (nt, wt) = frames[i], tables[i]
        if shorter is not None:
            # the codes of the next shorter frame that prove more light than this frame
            # measures (g(z)/t_j ≥ g(hi)/t_i); a clipped one does (g(hi)/t_j > g(hi)/t_i),
            # so the next shorter frame speaks for all the shorter ones
            ratio = times[shorter] / times[i]
            proof = [int(np.searchsorted(evidence[:, c], ceiling[c] * ratio)) for c in range(3)]
            f = _as_clipped(f, frames[shorter], proof, top)
        num += apply_lut(f, nt)
        den += apply_lut(f, wt)
        shorter = i
    rad = np.divide(num, den, out=np.zeros_like(num), where=den > 0)
    clipped, black = _extreme_fractions(frames, bits)
    return Merged(rad, clipped, black, times.tolist())


def _evidence(response: CameraResponse) -> tuple[np.ndarray, np.ndarray]:
    """What a sample proves of its light, for :func:`merge`: a table (2**bits, 3) of the
    exposure it shows at least (0 below the curve's trusted codes, where the curve is
    extrapolated and noise rules; g(hi) above them, a clipped sample included), and (3,)
    the most a frame measures on its trusted codes, g(hi) (lo, hi: each channel's trusted
    codes, else 1 and the code below the top).

    Why :func:`merge` takes a sample that a shorter frame shows above that as clipped: a
    JPEG rings at the edge of a clipped lamp, and the codes it decodes there (245-254 where
    the sensor clipped) read as light just below the clip; the five longer frames of a
    ±6 EV bracket each outvoted the short frame that measured the lamp, and a room lit by
    bright tubes read 3.1 % low (now 1.6 %). The shorter frame's light proves them clipped."""
    top = _top(response.bits)
    ranges = trusted_ranges(response)
    scale = 257 if response.bits == 16 else 1
    if ranges is None:
        ranges = [(1, top - 1)] * 3
    elif np.ndim(ranges) == 1:
        ranges = [ranges] * 3
    table = response.table.copy()
    ceiling = np.empty(3)
    for c, (lo, hi) in enumerate(ranges):
        lo, hi = int(lo) * scale, min(int(hi) * scale, top - 1)
        table[:lo, c] = 0.0
        table[hi + 1:, c] = ceiling[c] = table[hi, c]
    return table, ceiling


def _as_clipped(frame: np.ndarray, shorter: np.ndarray, proof, top: int) -> np.ndarray:
    """``frame`` with the top code wherever ``shorter`` has a code at or above ``proof``
    (one per channel): those samples weigh 0 in the merge, as clipped ones do. uint8 frames
    through OpenCV (a lookup and a max: no float work)."""
    if frame.dtype == np.uint8:
        codes = np.arange(256)[:, None]
        lut = np.where(codes >= np.asarray(proof)[None, :], 255, 0).astype(np.uint8)
        return cv2.max(frame, cv2.LUT(shorter, lut.reshape(256, 1, 3)))
    return np.where(shorter >= np.asarray(proof, np.int64), frame.dtype.type(top), frame)


def merge_opencv(frames, times, response: CameraResponse) -> np.ndarray:
    """cv2.createMergeDebevec with this response (for comparison): radiance per second.

    Beware (OpenCV 5.0, measured): it merges in the log domain (a weighted geometric mean),
    uses one weight per *pixel* (the mean of the three channels' hat weights), so a channel
    clipped while the others are not still votes; a pixel clipped in every frame gets the
    geometric mean of the frames' lower bounds; a table with g(0) = 0 (sRGB) gives log(0).
    """
    frames, times, bits = check_bracket(frames, times)
    if bits != 8 or response.bits != 8:
        raise ResponseError("cv2.createMergeDebevec takes 8-bit frames and a 256-entry response")
    floor = _positive_floor(response.table)
    curve = np.maximum(response.table, floor).reshape(256, 1, 3).astype(np.float32)
    return cv2.createMergeDebevec().process(frames, times.astype(np.float32), curve)


def partition_weights(response: CameraResponse, slot_times, *, top_code: int = 245):
    """Per-slot weight tables a_i(z) (2**bits, 3) that sum to 1 over the bracket.

    Slot i is trusted for log2 exposures within ``[c − s_i⁻, c + s_i⁺]`` of its own centre
    ``c``, as a linear hat: ``s_i⁻`` / ``s_i⁺`` are the log2 time ratios to the next longer /
    shorter slot. With ``ε = log2 g(z) − c``: ``a_i = 1 + ε/s⁻`` for −s⁻ ≤ ε ≤ 0,
    ``1 − ε/s⁺`` for 0 ≤ ε ≤ s⁺, else 0; the longest slot keeps 1 for all ε ≤ 0 and the
    shortest 1 for all ε ≥ 0 (so a sample clipped everywhere takes the shortest frame's
    lower bound). For a static scene, each sample's radiance log2 L puts it between two
    adjacent knots, and the two slots' weights sum to exactly 1 (linear B-splines are a
    partition of unity on any knot spacing). ``c = log2 g(top_code) − max spacing``, so no
    slot is used above ``top_code`` (the shoulder, where clipping and a poorly calibrated top
    begin) except the shortest.
    """
    times = np.array([check_time(t, "slot time") for t in slot_times])
    if len(times) < 1:
        raise ResponseError("no slots")
    order = np.argsort(-times)  # longest first: increasing radiance knots
    logt = np.log2(times[order])
    gaps = -np.diff(logt)  # spacing between consecutive slots (stops), > 0
    if np.any(gaps <= 0):
        raise ResponseError("slot exposure times must be distinct")
    floor = _positive_floor(response.table)
    lg = np.log2(np.maximum(response.table, floor))
    top8 = top_code if response.bits == 8 else top_code * 257
    smax = float(gaps.max()) if gaps.size else 0.0
    c = lg[top8] - smax  # per channel
    eps = lg - c  # (codes, 3)
    weights = [None] * len(times)
    n = len(times)
    for rank, idx in enumerate(order):
        s_lo = gaps[rank - 1] if rank > 0 else None        # to the longer neighbour
        s_hi = gaps[rank] if rank < n - 1 else None        # to the shorter neighbour
        a = np.zeros_like(eps)
        neg, pos = eps <= 0, eps > 0
        a[neg] = 1.0 if s_lo is None else np.clip(1 + eps[neg] / s_lo, 0, 1)
        a[pos] = 1.0 if s_hi is None else np.clip(1 - eps[pos] / s_hi, 0, 1)
        weights[idx] = a
    return weights



class LinearBracket:
    """The per-slot tables of the live merge (:func:`partition_weights`).

    ``slot_table(slot)`` linearises *and* weights a frame of that slot at t = 1:
    ``T_i(z) = a_i(z)·g(z)``; divided by the frame's ``t·gain`` it is that slot's share of
    the radiance per second. Anything linear in the radiance (the SH projection, a sum, a
    resize) applied to it gives the slot's part; the merged result is the sum of the parts.
    The weights depend only on the slots' *nominal* exposures (the knots), so a camera that
    delivers an exposure slightly off its slot (quantised shutter times) changes nothing but
    the 1/(t·gain) applied to that frame.
    """

    def __init__(self, response: CameraResponse, slot_exposures, *, top_code: int = 245):
        self.response = response
        self.nominal = np.array([check_time(t, "slot exposure") for t in slot_exposures])
        if len(self.nominal) < 2:
            raise ResponseError("a bracket needs at least 2 exposures")
        self.weights = partition_weights(response, self.nominal, top_code=top_code)
        self.shortest = int(np.argmin(self.nominal))
        self._tables: dict = {}

    def slot_table(self, slot: int) -> np.ndarray:
        """float32 table ``a_slot(z)·g(z)`` for :func:`~.response.apply_lut` (and the
        engine): (256, 1, 3) for 8-bit, (65536, 3) for 16-bit."""
        table = self._tables.get(slot)
        if table is None:
            table = _as_lut(self.weights[slot] * self.response.table, self.response.bits, False)
            self._tables[slot] = table
        return table

    def linearise(self, slot: int, frame: np.ndarray, exposure_s: float,
                  gain: float = 1.0) -> np.ndarray:
        """This frame's weighted share of the radiance per second (float32 H×W×3)."""
        k = np.float32(1.0 / (check_time(exposure_s) * check_time(gain, "gain")))
        return apply_lut(frame, self.slot_table(slot)) * k


def merge_partition(frames, times, response: CameraResponse, *, gain: float = 1.0,
                    top_code: int = 245) -> Merged:
    """Whole-bracket version of the live path: ``R = Σ_i T_i(z_i)/(t_i·gain)`` (no
    division by a weight sum)."""
    frames, times, bits = check_bracket(frames, times)
    gain = check_time(gain, "gain")
    response = response.to_bits(bits)
    lb = LinearBracket(response, times * gain, top_code=top_code)
    rad = np.zeros(frames[0].shape, np.float32)
    for i, (f, t) in enumerate(zip(frames, times)):
        rad += lb.linearise(i, f, t, gain)
    clipped, black = _extreme_fractions(frames, bits)
    return Merged(rad, clipped, black, times.tolist())


# -- EV offsets and slots ----------------------------------------------------------------------

#: The live default, chosen by measurement (``shlight bench --sections radiometry``, "choosing
#: the live default"): through the live path, on the two simulated cameras, the worst shape
#: error of the eight scenes without a sun disc was 0.9 % for −9, −6, −3, 0, +3 EV, against
#: 2.3 % for −8, −4, 0, +4 (4 EV gaps are too wide for the partition near the toe), 24.7 % for
#: the issue's −4, −2, 0, +2, +4 (the studio's tubes clip) and 0.6 % for seven shots −8…+4.
#: The short end matters most: bright lamps and windows carry the light. The cost per frame
#: does not depend on the number of slots; a cycle (the time to follow a change) does.
DEFAULT_OFFSETS = (-9.0, -6.0, -3.0, 0.0, 3.0)


def check_offsets(offsets) -> tuple[float, ...]:
    """EV offsets of a live bracket: at least 2, finite, within ±16 EV, at least 0.5 EV
    apart (so that every frame's exposure names its slot without doubt)."""
    try:
        items = list(offsets)
    except TypeError:
        raise InputError("bracket offsets must be a list of numbers (EV)") from None
    evs = []
    for v in items:
        try:
            evs.append(float(v))
        except (TypeError, ValueError):
            raise InputError(f"bracket offsets must be numbers (EV): {str(v).strip()!r} is "
                             "not one") from None
    evs = tuple(evs)
    if len(evs) < 2:
        raise InputError(f"a bracket needs at least 2 EV offsets, got {len(evs)}")
    if not all(math.isfinite(v) and abs(v) <= 16 for v in evs):
        raise InputError(f"bracket offsets must be finite and within ±16 EV, got {list(evs)}")
    ordered = sorted(evs)
    if min(b - a for a, b in zip(ordered, ordered[1:])) < 0.5:
        raise InputError(f"bracket offsets must be at least 0.5 EV apart, got {list(evs)}")
    return evs


def match_slot(slot_exposures, exposure: float) -> int | None:
    """The slot whose nominal exposure (t·gain) is within half the closest spacing (at most
    0.5 EV) of ``exposure``, or None: a camera's metadata confirms which slot a frame is."""
    logs = np.log2(np.asarray(slot_exposures, np.float64))
    gaps = np.diff(np.sort(logs))
    tol = min(0.5, float(gaps.min()) / 2) if gaps.size else 0.5
    d = np.abs(logs - math.log2(check_time(exposure, "exposure")))
    i = int(np.argmin(d))
    return i if d[i] <= tol else None
