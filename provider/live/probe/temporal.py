"""Temporal behaviour of live lighting: smoothing, change detection, keep-alive.

Everything here works on the coefficient arrays of :class:`~provider.core.sh9.engine.SH9Result`
and needs one fact of the maths: the basis is orthonormal, so the RMS of the irradiance
over the sphere of normals is exactly the Euclidean norm of ``Â_l · L_lm`` (Parseval).
The distance between two lightings is therefore computed from 27 numbers, with no
sampling:

    change(a, b) = ‖Â (a − b)‖ / ‖Â b‖     (relative RMS irradiance difference)

:class:`LightingFilter` smooths with a time constant but lets a real change through at
once; :class:`ChangeGate` decides when a message is worth sending.

Lights (``lights="auto"``, docs/contract.md §10). Every linear quantity (full and ambient
coefficients and matrices, each light's irradiance and angular radius) is smoothed with the
same weight, and each light's direction with that weight on the sphere (normalised lerp), so a sun that moves
is followed smoothly. The *set* of lights is never blended: a light appearing or
disappearing, or a change of which source a slot holds, snaps everything in that frame (the
demo's switching lamp reaches clients at once, never as a half-faded ghost). The
ambient + lights model is compared through its irradiance at fixed normals
(:func:`model_change`), so the snap and the change gate also notice a change that only the
lights show.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ...core.lights.analysis import model_irradiance
from ...core.geometry.sh import A_HAT_PER_COEFF, fibonacci_sphere

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


#: Normals at which two ambient + lights models are compared.
_MODEL_NORMALS = fibonacci_sphere(256)


def light_model(result):
    """``(identities, ambient (9, 3), lights)`` of a result with lights (``lights="auto"``
    or relayed), else None. Identities are the tracker keys of the lights, slot by slot."""
    ambient = getattr(result, "ambient_coefficients", None)
    if ambient is None:
        return None
    lights = list(getattr(result, "lights", None) or [])
    return tuple(int(light.key) for light in lights), np.asarray(ambient, np.float64), lights


def model_change(new, reference) -> float:
    """Relative RMS difference of ambient + lights irradiance between two
    :func:`light_model` tuples, over a fixed set of normals (``inf`` from black)."""
    a = model_irradiance(new[1], new[2], _MODEL_NORMALS)
    b = model_irradiance(reference[1], reference[2], _MODEL_NORMALS)
    diff = float(np.sqrt(np.sum((a - b) ** 2)))
    ref = float(np.sqrt(np.sum(b * b)))
    if ref == 0.0:
        return 0.0 if diff == 0.0 else math.inf
    return diff / ref


def _lights_differ(new, reference, threshold: float) -> bool:
    """Another set of lights (None against a model, other identities), or a model change
    beyond ``threshold``."""
    if new is None or reference is None:
        return (new is None) != (reference is None)
    return new[0] != reference[0] or model_change(new, reference) > threshold


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
        self._model = None              # (identities, ambient, lights) with lights
        self._last_weight = 1.0

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
            self._last_weight = w
            self.coefficients = self.coefficients + w * (c - self.coefficients)
            self.matrices = self.matrices + w * (m - self.matrices)
        self._t = t
        return self.coefficients, self.matrices, snapped

    def update_result(self, result, t: float):
        """Feed a whole result (coefficients, matrices, and with lights the ambient and each
        light, see the module docstring) at time ``t``; returns ``(result, snapped)``, a
        smoothed copy."""
        model = light_model(result)
        state = self._model
        force = (self.coefficients is not None and self.time_constant > 0
                 and _lights_differ(model, state, self.snap))
        if force:
            self.coefficients = None                  # snap: a light came, went or moved
        c, m, snapped = self.update(result.coefficients, result.matrices, t)
        if model is not None and not snapped:
            w = self._last_weight
            ids, ambient, lights = model
            ambient = state[1] + w * (ambient - state[1])
            lights = [_blend(old, new, w) for old, new in zip(state[2], lights)]
            model = (ids, ambient, lights)
        self._model = None if model is None else (model[0], model[1].copy(), list(model[2]))
        out = replace(result, coefficients=c.copy(), matrices=m.copy())
        if model is not None:
            out = replace(out, ambient_coefficients=model[1].copy(), lights=list(model[2]))
        return out, snapped


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
        self.sent_lights = None
        self.sent_at = -math.inf

    def changed(self, coefficients, lights=None) -> bool:
        """True when ``coefficients`` (or, with lights, the :func:`light_model` ``lights``:
        another set of lights, or their irradiance) differ from the last sent beyond the
        threshold."""
        if self.sent is None:
            return True
        if self.threshold <= 0:
            return True
        return (lighting_change(coefficients, self.sent) > self.threshold
                or _lights_differ(lights, self.sent_lights, self.threshold))

    def due(self, now: float) -> bool:
        """True when a keep-alive message is due."""
        return now - self.sent_at >= self.keepalive

    def mark_sent(self, coefficients, now: float, lights=None) -> None:
        self.sent = np.array(coefficients, np.float64)
        self.sent_lights = lights
        self.sent_at = now


def _blend(old, new, w: float):
    """A light moved a fraction ``w`` of the way from ``old`` to ``new`` (irradiance and
    angular radius linearly, direction by normalised lerp)."""
    d = old.direction + w * (new.direction - old.direction)
    norm = float(np.linalg.norm(d))
    d = new.direction if norm == 0.0 else d / norm
    irradiance = old.irradiance + w * (new.irradiance - old.irradiance)
    radius = old.angular_radius_deg + w * (new.angular_radius_deg - old.angular_radius_deg)
    return replace(new, direction=d, irradiance=irradiance, angular_radius_deg=radius)
