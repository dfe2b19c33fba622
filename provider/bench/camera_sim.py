"""A simulated 8-bit camera for the radiometry bench and the tests (tooling, not product).

It renders what a consumer camera would record of a linear HDR panorama:

    X = L · t · gain            sensor exposure (scene radiance L, exposure time t seconds,
                                gain = ISO/aperture constant; X = 0.18 is mid-grey)
    X += noise                  optional: shot noise (variance ∝ X) + read noise
    y = tone_c(X)               per-channel tone curve, NOT sRGB: a log-logistic "filmic"
                                curve with a toe and a shoulder, hard sensor clip at X_clip
    z = round(255 · y)          8-bit quantisation, clipped to 0..255

The tone curve is ISO 12232 "standard output sensitivity"-like: X = 0.18 (mid-grey) maps to
code 118 in every channel (so the camera is grey-balanced at mid-grey, as white balance
makes it), but the channels differ slightly in contrast (exponent n) and toe, and the sensor
clips 3.5 stops above mid-grey (sRGB would clip at 2.47 stops). Decoding these frames as
sRGB is therefore wrong in shape, not only in level.

``CameraSim.true_response()`` gives the exact inverse curve as a ``CameraResponse``
(method "true"), for the "one frame with the true curve" case.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.radiometry.response import CameraResponse

MID_GREY = 0.18
MID_CODE = 118  # ISO 12232 SOS: 18 % grey renders to sRGB code 118


def auto_exposure(hdr: np.ndarray, gain: float = 1.0, target: float = MID_GREY) -> float:
    """Exposure time (s) that puts the median luminance at ``target`` (18 % grey).

    Luminance here is the plain mean of R, G, B of the non-negative radiance (as
    :func:`provider.bench.common._auto_exposure`).
    """
    lum = np.maximum(np.nan_to_num(hdr), 0).mean(axis=-1)
    med = float(np.median(lum))
    return target / (max(med, 1e-9) * gain)


@dataclass
class CameraSim:
    """Per-channel filmic camera. Parameters are per RGB channel.

    ``exponent``: the curve's log-log slope in the shadows (a "gamma" of about 1/n);
    ``clip_stops``: sensor saturation above mid-grey; ``toe``: black-level crush (fraction
    of full scale removed at the bottom); ``shot``/``read``: noise in units of X (shot:
    variance = shot · X; read: standard deviation); ``gain``: ISO/aperture constant.
    """

    exponent: tuple = (0.64, 0.60, 0.56)
    clip_stops: tuple = (3.5, 3.45, 3.55)
    toe: tuple = (0.012, 0.010, 0.014)
    gain: float = 1.0
    shot: float = 0.0
    read: float = 0.0
    seed: int = 0
    _sigma: np.ndarray = field(init=False, repr=False)
    _scale: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        n = np.asarray(self.exponent, np.float64)
        xc = MID_GREY * 2.0 ** np.asarray(self.clip_stops, np.float64)
        b = np.asarray(self.toe, np.float64)
        y_mid = MID_CODE / 255.0
        # y(X) = (s · X^n/(X^n + σ^n) − b) / (1 − b) with y(X_clip) = 1 and y(0.18) = y_mid.
        # With u = s·h(X): u(Xc) = 1, u(0.18) = y_mid (1 − b) + b =: m. h = X^n/(X^n+σ^n)
        # => m = h(0.18)/h(Xc): solve σ by bisection in log space.
        m = y_mid * (1 - b) + b
        sig = np.empty(3)
        for c in range(3):
            lo, hi = -20.0, 20.0
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                s = math.exp(mid)
                h = lambda x: x ** n[c] / (x ** n[c] + s ** n[c])
                if h(MID_GREY) / h(xc[c]) > m[c]:
                    lo = mid  # ratio falls as σ grows? (larger σ -> more linear -> smaller)
                else:
                    hi = mid
            sig[c] = math.exp(0.5 * (lo + hi))
        self._n, self._xc, self._b, self._sigma = n, xc, b, sig
        self._scale = (xc ** n + sig ** n) / xc ** n

    # -- the curve -------------------------------------------------------------------------
    def tone(self, X: np.ndarray) -> np.ndarray:
        """Normalised output y in [0, 1] for sensor exposure X (..., 3), before quantising."""
        X = np.clip(np.asarray(X, np.float64), 0.0, self._xc)
        xn = X ** self._n
        u = self._scale * xn / (xn + self._sigma ** self._n)
        return np.clip((u - self._b) / (1 - self._b), 0.0, 1.0)

    def inverse_tone(self, y: np.ndarray) -> np.ndarray:
        """X for an output y in [0, 1] (..., 3) (the exact inverse of :meth:`tone`)."""
        y = np.clip(np.asarray(y, np.float64), 0.0, 1.0)
        u = y * (1 - self._b) + self._b
        r = np.clip(u / self._scale, 0.0, 1 - 1e-12)
        return self._sigma * (r / (1 - r)) ** (1 / self._n)

    def true_response(self, bits: int = 8) -> CameraResponse:
        """Exact inverse response: X at each code's centre; code 0 -> X where y = 0 (the toe
        crush), the top code -> X_clip (a lower bound of what clipped)."""
        top = (1 << bits) - 1
        table = self.inverse_tone(np.repeat((np.arange(top + 1) / top)[:, None], 3, 1))
        return CameraResponse(table, method="true",
                              params={"model": "CameraSim", "exponent": list(self.exponent),
                                      "clip_stops": list(self.clip_stops)})

    # -- rendering --------------------------------------------------------------------------
    def capture(self, hdr: np.ndarray, exposure_time: float, rng=None,
                bits: int = 8) -> np.ndarray:
        """One frame (H, W, 3) uint8 (or uint16 with ``bits=16``) of the HDR radiance.

        Negative and non-finite radiance is treated as 0 (the engine does the same).
        """
        L = np.maximum(np.nan_to_num(np.asarray(hdr, np.float64)), 0.0)
        X = L * (exposure_time * self.gain)
        if self.shot > 0 or self.read > 0:
            rng = np.random.default_rng(self.seed) if rng is None else rng
            sd = np.sqrt(self.shot * X + self.read ** 2)
            X = np.maximum(X + rng.standard_normal(X.shape) * sd, 0.0)
        top = (1 << bits) - 1
        z = np.rint(self.tone(X) * top)
        return z.astype(np.uint8 if bits == 8 else np.uint16)

    def bracket(self, hdr: np.ndarray, base_time: float, evs=(-4, -2, 0, 2, 4), seed=None,
                bits: int = 8):
        """Frames and exposure times for EV offsets around ``base_time``."""
        rng = np.random.default_rng(self.seed if seed is None else seed)
        times = [base_time * 2.0 ** ev for ev in evs]
        return [self.capture(hdr, t, rng, bits) for t in times], times

