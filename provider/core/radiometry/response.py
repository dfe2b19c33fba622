"""Camera response: 8- and 16-bit code values -> sensor exposure, per channel (no I/O).

An 8-bit frame is not light (docs/contract.md §9). A camera maps sensor exposure
``X = L · t · gain`` (scene radiance L, exposure time t in seconds, gain = ISO / aperture
constant) through its tone curve to a code value z. The *inverse response* ``g(z)`` gives X
back, per channel, as a table of 2**bits entries, exactly like the sRGB table the engine
already applies: a calibrated curve costs nothing more per frame than sRGB.

Units
-----
* ``g`` is normalised so that mid-grey is 0.18: ``g(118) = 0.18`` in every channel for
  8-bit (ISO 12232 "standard output sensitivity": 18 % grey renders to sRGB code 118; sRGB
  itself decodes 118 to 0.1812 and is used as it is). 16-bit tables are anchored at the same
  light level (code 118·257).
* ``g(z) / (t · gain)`` is **radiance per second of exposure** (per unit gain): a surface a
  camera at (t, gain) renders as mid-grey has radiance ``0.18 / (t · gain)``. This is
  scene-referred up to one camera constant (aperture, sensor sensitivity) that is the same
  for every frame, so auto exposure no longer changes the level of the lighting. A grey card
  or a lux meter fixes that constant: :meth:`CameraResponse.scaled`.
* The top code decodes to the clip level: a *lower bound* of the light that clipped.

What is here: :class:`CameraResponse` (tables from sRGB, a gamma, a calibration or a
camera.json dict; validation; OpenCV-ready lookup tables), :func:`calibrate` (OpenCV's
Debevec, or Robertson, from >= 3 frames of one static view with known times),
:func:`check_bracket` (the bad-input checks every bracket goes through) and
:func:`parse_seconds`. Merging brackets is :mod:`.bracket`. Reading and writing camera.json
files is not the maths' business: this module converts dicts only.

Measured on the nine real panoramas with a simulated filmic camera (``shlight bench
--sections radiometry``): Debevec with 150 samples and lambda 50 recovers codes 16..250
within about 1 % (OpenCV's default 70 / 10 is 4-6 % off once there is sensor noise).
"""
from __future__ import annotations

import math
import re

import cv2
import numpy as np

from ..errors import InputError

FORMAT = "shlight-camera-response"
FORMAT_VERSION = 1
METHODS = ("srgb", "gamma", "debevec", "robertson", "true", "table")
CHANNELS = ("r", "g", "b")

#: Mid-grey anchor of every table: g(ANCHOR_CODE_8) = ANCHOR_VALUE (8-bit code scale).
ANCHOR_CODE_8 = 118
ANCHOR_VALUE = 0.18
#: Codes around the anchor whose log-mean sets a calibrated curve's scale (smooth curves).
ANCHOR_WINDOW_8 = (113, 123)



class ResponseError(InputError):
    """Bad input for the radiometric chain; the message says what is wrong and what to do."""


# -- small helpers ---------------------------------------------------------------------------

def srgb_decode(v: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1 sRGB decoding of values in [0, 1] (float64)."""
    v = np.asarray(v, np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def _top(bits: int) -> int:
    return (1 << bits) - 1


def _bits_of_dtype(dtype) -> int:
    if dtype == np.uint8:
        return 8
    if dtype == np.uint16:
        return 16
    raise ResponseError(f"frames must be uint8 or uint16 code values, got {dtype}")


def check_time(t, what="exposure time") -> float:
    try:
        t = float(t)
    except (TypeError, ValueError):
        raise ResponseError(f"{what} must be a number of seconds, got {t!r}") from None
    if not math.isfinite(t) or t <= 0:
        raise ResponseError(f"{what} must be a positive finite number of seconds, got {t!r}")
    return t


_SECONDS = re.compile(r"\s*(\d+(?:\.\d*)?|\.\d+)(?:\s*/\s*(\d+(?:\.\d*)?|\.\d+))?\s*")


def parse_seconds(text: str) -> float:
    """An exposure time written as a decimal (``0.004``) or a fraction (``1/250``), in
    seconds; :class:`InputError` unless it is a positive finite number within
    :data:`~.photometry.EXPOSURE_S_RANGE`."""
    m = _SECONDS.fullmatch(str(text))
    if not m:
        raise ResponseError(f"exposure time {text!r} is not a number of seconds (a decimal "
                            "such as 0.004 or a fraction such as 1/250)")
    num, den = float(m.group(1)), float(m.group(2)) if m.group(2) else 1.0
    if den == 0:
        raise ResponseError(f"exposure time {text!r} divides by zero")
    from .photometry import EXPOSURE_S_RANGE, check_physical
    t = check_time(num / den, f"exposure time {text!r}")
    return check_physical(f"exposure time {text.strip()!r}", t, EXPOSURE_S_RANGE, " s")


def check_bracket(frames, times) -> tuple[list, np.ndarray, int]:
    """Validate a bracket: same size, 3 channels, all uint8 or all uint16, one positive
    finite time per frame. Returns (frames, times float64, bits)."""
    if frames is None or len(frames) == 0:
        raise ResponseError("no frames given")
    frames = list(frames)
    if times is None:
        raise ResponseError("exposure times are missing: give one time (s) per frame")
    times = list(np.ravel(np.asarray(times, dtype=object))) if not np.isscalar(times) else [times]
    if len(times) != len(frames):
        raise ResponseError(f"{len(frames)} frames but {len(times)} exposure times")
    times = np.array([check_time(t, f"exposure time of frame {i}") for i, t in enumerate(times)])
    dtypes = {f.dtype if isinstance(f, np.ndarray) else None for f in frames}
    if None in dtypes:
        raise ResponseError("every frame must be a numpy array")
    if len(dtypes) > 1:
        raise ResponseError("frames mix pixel types "
                            f"({', '.join(sorted(str(d) for d in dtypes))}): a bracket must be "
                            "all 8-bit or all 16-bit")
    bits = _bits_of_dtype(frames[0].dtype)
    shape = frames[0].shape
    for i, f in enumerate(frames):
        if f.ndim != 3 or f.shape[2] != 3:
            raise ResponseError(f"frame {i} has shape {f.shape}: expected H×W×3")
        if f.shape != shape:
            raise ResponseError(f"frame {i} is {f.shape[1]}×{f.shape[0]}, frame 0 is "
                                f"{shape[1]}×{shape[0]}: a bracket must be one static view")
    return [np.ascontiguousarray(f) for f in frames], times, bits


# -- the inverse response --------------------------------------------------------------------

class CameraResponse:
    """Inverse camera response per channel: code value -> sensor exposure X (see module doc).

    Parameters
    ----------
    table : array (2**bits, 3) or (2**bits,)
        g(z) per channel, non-negative, non-decreasing, finite (a 1-D table is shared by
        the three channels). Stored as float64 (2**bits, 3).
    method : one of METHODS
        Where the curve came from ("table" when unknown).
    exposure_times : list of float, optional
        The bracket a calibration used (kept in camera.json for the record).
    params : dict, optional
        Method parameters (gamma, samples, lambda, fit errors...), JSON-able.
    """

    def __init__(self, table, *, method: str = "table", exposure_times=None, params=None):
        t = np.asarray(table, dtype=np.float64)
        if t.ndim == 1:
            t = np.repeat(t[:, None], 3, axis=1)
        if t.ndim != 2 or t.shape[1] != 3 or t.shape[0] not in (256, 65536):
            raise ResponseError(f"a response table must have 256 or 65536 rows and 3 "
                                f"channels, got shape {np.shape(table)}")
        if method not in METHODS:
            raise ResponseError(f"unknown response method {method!r} (one of {METHODS})")
        self.table = t
        self.bits = 8 if t.shape[0] == 256 else 16
        self.method = method
        self.exposure_times = None if exposure_times is None else [float(x) for x in exposure_times]
        self.params = dict(params or {})
        self.validate()
        self._lut_cache: dict = {}

    # -- constructors ----------------------------------------------------------------------
    @classmethod
    def srgb(cls, bits: int = 8) -> "CameraResponse":
        """The sRGB decoding (the engine's default assumption), scaled so g(118) ≈ 0.1812
        (sRGB's own value: no rescaling, sRGB already meets the anchor within 0.7 %)."""
        _check_bits(bits)
        top = _top(bits)
        return cls(srgb_decode(np.arange(top + 1) / top), method="srgb")

    @classmethod
    def gamma(cls, g: float, bits: int = 8) -> "CameraResponse":
        """A pure power law ``X ∝ (z/top)**g``, anchored so g(118) = 0.18."""
        _check_bits(bits)
        g = float(g)
        if not math.isfinite(g) or g <= 0:
            raise ResponseError(f"gamma must be a positive finite number, got {g!r}")
        top = _top(bits)
        v = (np.arange(top + 1) / top) ** g
        v *= ANCHOR_VALUE / (ANCHOR_CODE_8 / 255.0) ** g
        return cls(v, method="gamma", params={"gamma": g})

    @classmethod
    def from_dict(cls, d: dict) -> "CameraResponse":
        """Inverse of :meth:`to_dict` (camera.json content), validated."""
        if not isinstance(d, dict):
            raise ResponseError(f"a camera response must be a JSON object, got {type(d).__name__}")
        if d.get("format") != FORMAT:
            raise ResponseError(f"not a camera response (format is {d.get('format')!r}, "
                                f"expected {FORMAT!r})")
        if d.get("version") != FORMAT_VERSION:
            raise ResponseError(f"camera response version {d.get('version')!r} is not "
                                f"supported (this code reads version {FORMAT_VERSION})")
        bits = d.get("bits")
        if bits not in (8, 16):
            raise ResponseError(f"camera response bits must be 8 or 16, got {bits!r}")
        table = d.get("table")
        if not isinstance(table, dict) or any(c not in table for c in CHANNELS):
            raise ResponseError("camera response table must have 'r', 'g' and 'b' arrays")
        cols = []
        for c in CHANNELS:
            col = table[c]
            if not isinstance(col, (list, tuple)) or len(col) != 1 << bits:
                raise ResponseError(f"table '{c}' must be a list of {1 << bits} numbers")
            try:
                arr = np.array(col, dtype=np.float64)
            except (TypeError, ValueError):
                raise ResponseError(f"table '{c}' contains something that is not a number") from None
            cols.append(arr)
        times = d.get("exposure_times")
        if times is not None:
            if not isinstance(times, (list, tuple)):
                raise ResponseError("exposure_times must be a list of seconds")
            times = [check_time(t, "a calibration exposure time") for t in times]
        return cls(np.stack(cols, axis=1), method=d.get("method", "table"),
                   exposure_times=times, params=d.get("params") or {})

    # -- checks and conversions ------------------------------------------------------------
    def validate(self) -> None:
        """Raise :class:`ResponseError` unless every channel is finite, >= 0, non-decreasing
        and rises (top > bottom)."""
        t = self.table
        if not np.all(np.isfinite(t)):
            raise ResponseError("response table has non-finite values (NaN or inf)")
        if np.any(t < 0):
            raise ResponseError("response table has negative values")
        d = np.diff(t, axis=0)
        if np.any(d < 0):
            c, z = np.argwhere(d < 0)[0][::-1]
            raise ResponseError(f"response table is not monotone: channel {CHANNELS[c]} "
                                f"falls from code {z} to {z + 1}")
        if np.any(t[-1] <= t[0]):
            raise ResponseError("response table is flat: top code must decode above code 0")

    def to_dict(self) -> dict:
        """JSON-able camera.json content (flat lists of floats only)."""
        return {
            "format": FORMAT, "version": FORMAT_VERSION, "method": self.method,
            "bits": self.bits,
            "anchor": {"code": ANCHOR_CODE_8 if self.bits == 8 else ANCHOR_CODE_8 * 257,
                       "value": ANCHOR_VALUE},
            "units": "sensor exposure X = radiance * exposure_s * gain; mid-grey = 0.18",
            "exposure_times": self.exposure_times,
            "params": _jsonable(self.params),
            "table": {c: [float(v) for v in self.table[:, i]] for i, c in enumerate(CHANNELS)},
        }

    def to_bits(self, bits: int) -> "CameraResponse":
        """The same curve for another bit depth (8 <-> 16), interpolated in log space
        (code z16 ≡ z8 · 257). Going to 16 bits adds no information: it lets a 16-bit
        stream use an 8-bit calibration."""
        _check_bits(bits)
        if bits == self.bits:
            return self
        if bits < self.bits:  # 65535 = 255 · 257: 8-bit codes are every 257th 16-bit code
            out = self.table[np.arange(256) * 257]
        else:
            floor = _positive_floor(self.table)
            src = np.arange(256) / 255.0
            dst = np.arange(65536) / 65535.0
            out = np.empty((65536, 3))
            for c in range(3):
                logt = np.log(np.maximum(self.table[:, c], floor[c]))
                out[:, c] = np.exp(np.interp(dst, src, logt))
            out[0] = self.table[0]
            out = np.maximum.accumulate(out, axis=0)
        return CameraResponse(out, method=self.method, exposure_times=self.exposure_times,
                              params={**self.params, "resampled_from_bits": self.bits})

    def scaled(self, k: float) -> "CameraResponse":
        """The curve times a constant (a photometric reference fixes the camera constant)."""
        k = check_time(k, "scale")
        return CameraResponse(self.table * k, method=self.method,
                              exposure_times=self.exposure_times, params=self.params)

    def shared(self) -> tuple["CameraResponse", float]:
        """One curve for all three channels (the geometric mean of the channels) and its
        largest relative deviation from any channel over codes 16..250 (8-bit scale).

        Worth it where the camera's channels share one tone curve (white balance applied
        before it, as most ISPs do): OpenCV's one-channel LUT is faster than the
        per-channel one, so a shared curve linearises at the sRGB path's speed."""
        floor = _positive_floor(self.table)
        g = np.exp(np.log(np.maximum(self.table, floor)).mean(axis=1))
        g[self.table.max(axis=1) <= 0] = 0.0
        lo, hi = (16, 250) if self.bits == 8 else (16 * 257, 250 * 257)
        dev = float(np.max(np.abs(self.table[lo:hi + 1] / g[lo:hi + 1, None] - 1)))
        return CameraResponse(np.maximum.accumulate(g), method=self.method,
                              exposure_times=self.exposure_times,
                              params={**self.params, "shared_from_channels": True,
                                      "shared_max_deviation": dev}), dev

    @property
    def channels_identical(self) -> bool:
        """True when one table serves all channels (OpenCV's 1-channel LUT is ~1.7× faster)."""
        return bool(np.array_equal(self.table[:, 0], self.table[:, 1])
                    and np.array_equal(self.table[:, 0], self.table[:, 2]))

    def lut(self, exposure_time: float = 1.0, gain: float = 1.0) -> np.ndarray:
        """float32 table giving radiance per second ``g(z)/(t·gain)`` for :func:`apply_lut`
        (and the engine's ``cv2.LUT`` band path): 8-bit -> (256,) if channels are identical
        else (256, 1, 3); 16-bit -> (65536, 3)."""
        t = check_time(exposure_time) * check_time(gain, "gain")
        key = t
        lut = self._lut_cache.get(key)
        if lut is None:
            lut = _as_lut(self.table / t, self.bits, self.channels_identical)
            if len(self._lut_cache) > 64:
                self._lut_cache.clear()
            self._lut_cache[key] = lut
        return lut

    def linearise(self, frame: np.ndarray, exposure_time: float = 1.0,
                  gain: float = 1.0) -> np.ndarray:
        """Radiance per second of exposure (float32 H×W×3) of one frame."""
        bits = _bits_of_dtype(frame.dtype)
        if bits != self.bits:
            raise ResponseError(f"a {bits}-bit frame needs a {bits}-bit response "
                                f"(this one is {self.bits}-bit: use .to_bits({bits}))")
        if frame.ndim != 3 or frame.shape[2] != 3:
            raise ResponseError(f"frame has shape {frame.shape}: expected H×W×3")
        return apply_lut(frame, self.lut(exposure_time, gain))

    def curve_error(self, other: "CameraResponse", lo: int = 5, hi: int = 250,
                    fit_scale: bool = True) -> float:
        """Relative RMS difference of the two curves over 8-bit codes lo..hi, all channels
        (after one scale per channel, the geometric mean of the ratio, when
        ``fit_scale``; the anchor normalisation otherwise): how well a
        calibration recovered a known curve."""
        a, b = self.to_bits(8).table[lo:hi + 1], other.to_bits(8).table[lo:hi + 1]
        r = a / np.maximum(b, 1e-300)
        if fit_scale:  # geometric-mean scale per channel
            r = r / np.exp(np.log(np.maximum(r, 1e-300)).mean(axis=0))
        return float(np.sqrt(np.mean((r - 1) ** 2)))

    def summary(self) -> dict:
        """What a person checks after a calibration: the curve at a few codes per channel,
        how far it is from sRGB (codes 16..250, mid-grey anchor, no refit), how much the
        channels differ, and the codes the monotone repair changed."""
        r8 = self.to_bits(8)
        codes = [16, 32, 64, 118, 160, 200, 235, 250, 255]
        srgb = CameraResponse.srgb()
        _, channel_spread = r8.shared()
        return {
            "method": self.method, "bits": self.bits,
            "exposure_times": self.exposure_times,
            "codes": codes,
            "table": {c: [float(r8.table[z, i]) for z in codes] for i, c in enumerate(CHANNELS)},
            "srgb": [float(srgb.table[z, 0]) for z in codes],
            "error_vs_srgb": r8.curve_error(srgb, lo=16, hi=250, fit_scale=False),
            "channel_spread": channel_spread,
            "dynamic_range_stops": float(np.log2(r8.table[254].min() / max(
                r8.table[1].max(), 1e-300))),
            "repaired_codes": self.params.get("repaired_codes"),
        }

    def __repr__(self) -> str:
        return (f"CameraResponse(method={self.method!r}, bits={self.bits}, "
                f"g(mid)={self.table[self.table.shape[0] * 118 // 255].round(4).tolist()})")


def _check_bits(bits):
    if bits not in (8, 16):
        raise ResponseError(f"bits must be 8 or 16, got {bits!r}")


def _positive_floor(table: np.ndarray) -> np.ndarray:
    """Per channel, the smallest positive value (to take logs of tables starting at 0)."""
    out = np.empty(3)
    for c in range(3):
        pos = table[:, c][table[:, c] > 0]
        out[c] = pos.min() if pos.size else 1e-12
    return out


def _as_lut(table: np.ndarray, bits: int, identical: bool) -> np.ndarray:
    if table.ndim == 1:
        return np.ascontiguousarray(table, dtype=np.float32)
    if bits == 8:
        if identical:
            return np.ascontiguousarray(table[:, 0], dtype=np.float32)
        return np.ascontiguousarray(table.reshape(256, 1, 3), dtype=np.float32)
    return np.ascontiguousarray(table, dtype=np.float32)


_CH = np.arange(3)


def apply_lut(frame: np.ndarray, lut: np.ndarray, dst: np.ndarray | None = None) -> np.ndarray:
    """Table lookup of a uint8 frame (cv2.LUT) or a uint16 frame (numpy gather)."""
    if frame.dtype == np.uint8:
        return cv2.LUT(frame, lut, dst=dst) if dst is not None else cv2.LUT(frame, lut)
    out = lut[frame, _CH] if lut.ndim == 2 else lut[frame]
    if dst is not None:
        dst[...] = out
        return dst
    return out


def _jsonable(v):
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_jsonable(x) for x in np.asarray(v, dtype=object).ravel()] \
            if isinstance(v, np.ndarray) else [_jsonable(x) for x in v]
    if isinstance(v, (np.floating, float)):
        return float(v)
    if isinstance(v, (np.integer, int)) and not isinstance(v, bool):
        return int(v)
    return v


# -- calibration ------------------------------------------------------------------------------

#: Defaults chosen by measurement on the nine panoramas (RESULTS.md, calibration study):
#: the data term of Debevec's least squares grows with the number of samples and the
#: smoothness term does not, so lambda has to grow with samples (lambda ≈ samples / 3).
#: OpenCV's default (70 samples, lambda 10) recovers codes 16..250 within 0.7 % median,
#: 1.2 % worst on clean frames but 4.0 % / 6.4 % with sensor noise (the noise biases the
#: fit; more smoothing resists it); 150 samples with lambda 50: 0.4 % / 1.2 % clean and
#: 0.9 % / 1.4 % noisy, in 0.15 s at 512×256. Above ~1000 samples OpenCV 5.0's float32
#: SVD solve can return NaN for a whole channel: calibrate() retries with half the samples.
DEBEVEC_SAMPLES = 150
DEBEVEC_LAMBDA = 50.0
#: The largest smoothness accepted: past ~1e9 the curve is a straight line whatever the
#: frames, and from ~1e38 OpenCV's float32 solve fails (LAPACK prints on stdout). Even a
#: million samples want a lambda of only ~3e5 (about samples / 3).
DEBEVEC_LAMBDA_MAX = 1e6


def debevec_grid(width: int, height: int, samples: int) -> tuple[int, int]:
    """The (columns, rows) of the grid of pixels that OpenCV's Debevec calibration samples
    in a ``width`` × ``height`` frame (its own arithmetic, ``photo/src/calibrate.cpp``); it
    refuses frames that the grid does not fit."""
    x = int(math.sqrt(samples * width / height))
    return x, (samples // x if x > 0 else samples)


def check_debevec(width: int, height: int, samples: int, lambda_: float) -> None:
    """Refuse Debevec parameters, and frames too small for them, before solving (OpenCV
    would fail an assertion or print LAPACK's complaints); :class:`ResponseError`."""
    try:
        lam = float(lambda_)
    except (TypeError, ValueError):
        lam = math.nan
    if not (math.isfinite(lam) and 0 < lam <= DEBEVEC_LAMBDA_MAX):
        raise ResponseError(f"Debevec's smoothness lambda must be a finite number above 0 and at most "
                            f"{DEBEVEC_LAMBDA_MAX:g} (default {DEBEVEC_LAMBDA:g}, about "
                            f"samples / 3), got {lambda_!r}")
    x, y = debevec_grid(width, height, samples)
    if not (0 < x <= width and 0 < y <= height):
        raise ResponseError(
            f"the frames are too small to calibrate: {width}×{height} pixels, where Debevec's "
            f"{samples} samples need a grid of {max(x, 1)}×{y} (a square frame needs at least "
            f"{_side(samples)}×{_side(samples)})")


def _side(samples: int) -> int:
    """The side of the smallest square frame that holds ``samples`` Debevec samples."""
    side = math.isqrt(samples)
    while True:
        x, y = debevec_grid(side, side, samples)
        if 0 < x <= side and 0 < y <= side:
            return side
        side += 1


def calibrate(frames, times, method: str = "debevec", *, samples: int = DEBEVEC_SAMPLES,
              lambda_: float = DEBEVEC_LAMBDA, max_iter: int = 30,
              threshold: float = 0.01) -> CameraResponse:
    """Recover the inverse response from >= 3 frames of one static view with known times.

    ``method``: ``"debevec"`` (cv2.createCalibrateDebevec: least squares on ``samples``
    grid pixels with second-derivative smoothness ``lambda_``; recommended) or
    ``"robertson"`` (cv2.createCalibrateRobertson: iterates over every pixel; measured
    4-7 % off over codes 16..250, biased high at the top by clipped pixels, and NaN for any
    code absent from a channel, filled here by interpolation). OpenCV
    returns a 256×1×3 curve in linear units up to one scale per channel; here it is
    made strictly increasing (a few extreme codes that no sample reached can come out
    non-monotone) and normalised so the log-mean over codes 113..123 equals log 0.18
    (mid-grey at code 118, see the module doc). 8-bit frames only (OpenCV's limit); use
    :meth:`CameraResponse.to_bits` for a 16-bit stream.
    """
    frames, times, bits = check_bracket(frames, times)
    if len(frames) < 3:
        raise ResponseError(f"calibration needs at least 3 frames of one static view, got "
                            f"{len(frames)}")
    if bits != 8:
        raise ResponseError("calibration needs 8-bit frames (OpenCV's CalibrateDebevec/"
                            "Robertson are 8-bit only); convert the response with to_bits(16)")
    if times.max() / times.min() < 2.0 or len(np.unique(times)) < 2:
        raise ResponseError("calibration needs exposure times at least 1 EV apart "
                            f"(got {times.tolist()})")
    t32 = times.astype(np.float32)
    if method == "debevec":
        samples = int(samples)
        if samples < 10:
            raise ResponseError("samples must be >= 10")
        check_debevec(frames[0].shape[1], frames[0].shape[0], samples, lambda_)
        while True:
            # positional: the binding's keyword for lambda is a Python reserved word
            cal = cv2.createCalibrateDebevec(samples, float(lambda_), False)
            curve = cal.process(frames, t32).reshape(256, 3).astype(np.float64)
            if np.all(np.isfinite(curve)) or samples < 40:
                break
            samples //= 2  # OpenCV's float32 SVD gave NaN: a smaller system
        params = {"samples": samples, "lambda": float(lambda_), "random": False}
    elif method == "robertson":
        cal = cv2.createCalibrateRobertson(max_iter=int(max_iter), threshold=float(threshold))
        params = {"max_iter": int(max_iter), "threshold": float(threshold)}
        curve = cal.process(frames, t32).reshape(256, 3).astype(np.float64)
    else:
        raise ResponseError(f"unknown calibration method {method!r} (debevec or robertson)")
    # Robertson divides by each code's pixel count: a code that no pixel of a channel has
    # comes out NaN (OpenCV 5.0). Fill such codes by log-linear interpolation.
    filled = []
    for c in range(3):
        ok = np.isfinite(curve[:, c]) & (curve[:, c] > 0)
        if np.count_nonzero(ok) < 16:
            raise ResponseError(f"{method} calibration failed (channel {CHANNELS[c]}): are "
                                "the frames one static view with these exposure times?")
        z = np.arange(256)
        if not ok.all():
            curve[~ok, c] = np.exp(np.interp(z[~ok], z[ok], np.log(curve[ok, c])))
        filled.append(int(np.count_nonzero(~ok)))
    curve, repaired = make_increasing(curve)
    params["filled_codes"] = filled
    lo, hi = ANCHOR_WINDOW_8
    curve *= ANCHOR_VALUE / np.exp(np.log(curve[lo:hi + 1]).mean(axis=0))
    params["repaired_codes"] = repaired
    return CameraResponse(curve, method=method, exposure_times=times.tolist(), params=params)


def make_increasing(curve: np.ndarray, min_step: float = 1e-4) -> tuple[np.ndarray, list]:
    """Force a positive curve (N, 3) strictly increasing: every code at least ``min_step``
    (relative) above the one below, working outward from the middle code. Returns the curve
    and the number of codes changed per channel."""
    c = np.array(curve, np.float64)
    n = c.shape[0]
    mid = n // 2
    changed = []
    for ch in range(c.shape[1]):
        col = c[:, ch]
        before = col.copy()
        col[col <= 0] = np.nan
        col[np.isnan(col)] = np.nanmin(col) if np.any(np.isfinite(col)) else 1e-6
        for z in range(mid + 1, n):
            col[z] = max(col[z], col[z - 1] * (1 + min_step))
        for z in range(mid - 1, -1, -1):
            col[z] = min(col[z], col[z + 1] / (1 + min_step))
        changed.append(int(np.count_nonzero(col != before)))
    return c, changed


