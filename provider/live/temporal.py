"""Temporal behaviour of live lighting: smoothing, change detection, keep-alive.

Everything here works on the coefficient arrays of :class:`~provider.core.engine.SH9Result`
and needs one fact of the maths: the basis is orthonormal, so the RMS of the irradiance
over the sphere of normals is exactly the Euclidean norm of ``Â_l · L_lm`` (Parseval).
The distance between two lightings is therefore computed from 27 numbers, with no
sampling:

    change(a, b) = ‖Â (a − b)‖ / ‖Â b‖     (relative RMS irradiance difference)

:class:`LightingFilter` smooths with a time constant but lets a real change through at
once; :class:`ChangeGate` decides when a message is worth sending.
"""
from __future__ import annotations

import math

import numpy as np

from ..core.sh import A_HAT_PER_COEFF

_WEIGHT = A_HAT_PER_COEFF[:, None]


def lighting_change(new, reference) -> float:
    """Relative RMS difference of irradiance over the sphere between two (9, C) sets.

    0 for identical lighting, about 0.1 for a 10 % change; ``inf`` when the reference is
    black and the new lighting is not.
    """
    a = np.asarray(new, np.float64) * _WEIGHT
    b = np.asarray(reference, np.float64) * _WEIGHT
    diff = float(np.sqrt(np.sum((a - b) ** 2)))
    ref = float(np.sqrt(np.sum(b * b)))
    if ref == 0.0:
        return 0.0 if diff == 0.0 else math.inf
    return diff / ref


class LightingFilter:
    """Exponential smoothing with a time constant, and a snap for real changes.

    Each update moves the state towards the new lighting by ``1 − exp(−Δt / τ)`` (τ =
    ``time_constant`` seconds; 0 = no smoothing). When the new lighting differs from the
    state by more than ``snap`` (relative RMS irradiance, e.g. 0.1 = 10 %: a light
    switched on or off, a door opened) the state jumps to it, so the change reaches
    clients in the same frame; smoothing only calms noise and flicker. Coefficients and
    matrices are linear in each other, so both are smoothed with the same weight and stay
    consistent.
    """

    def __init__(self, time_constant: float = 0.0, snap: float = 0.1):
        self.time_constant, self.snap = float(time_constant), float(snap)
        self.coefficients = self.matrices = None
        self._t = None

    def update(self, coefficients, matrices, t: float):
        """Feed one frame's lighting at time ``t`` (seconds); returns
        ``(coefficients, matrices, snapped)``, the smoothed lighting."""
        c = np.asarray(coefficients, np.float64)
        m = np.asarray(matrices, np.float64)
        snapped = (self.coefficients is None or self.time_constant <= 0
                   or lighting_change(c, self.coefficients) > self.snap)
        if snapped:
            self.coefficients, self.matrices = c.copy(), m.copy()
        else:
            dt = max(t - self._t, 0.0)
            w = 1.0 - math.exp(-dt / self.time_constant)
            self.coefficients = self.coefficients + w * (c - self.coefficients)
            self.matrices = self.matrices + w * (m - self.matrices)
        self._t = t
        return self.coefficients, self.matrices, snapped


class ChangeGate:
    """Decides whether fresh lighting is worth a message.

    Send when the lighting differs from the last *sent* lighting by more than
    ``threshold`` (relative RMS irradiance), or when ``keepalive`` seconds have passed
    since the last message (so clients know the provider is alive, and so that many tiny
    drifts never go unsent for long). ``threshold = 0`` sends every frame.
    """

    def __init__(self, threshold: float = 0.002, keepalive: float = 1.0):
        self.threshold, self.keepalive = float(threshold), float(keepalive)
        self.sent = None
        self.sent_at = -math.inf

    def changed(self, coefficients) -> bool:
        """True when ``coefficients`` differ from the last sent beyond the threshold."""
        if self.sent is None:
            return True
        if self.threshold <= 0:
            return True
        return lighting_change(coefficients, self.sent) > self.threshold

    def due(self, now: float) -> bool:
        """True when a keep-alive message is due."""
        return now - self.sent_at >= self.keepalive

    def mark_sent(self, coefficients, now: float) -> None:
        self.sent = np.array(coefficients, np.float64)
        self.sent_at = now
