"""Correlated colour temperature (CCT) and Duv of linear Rec. 709 RGB light (no I/O).

The chain: linear Rec. 709 RGB → CIE 1931 XYZ (the BT.709 / sRGB matrix, D65 white, no
chromatic adaptation: the light's own colour) → CIE 1960 UCS (u, v) =
(4X, 6Y) / (X + 15Y + 3Z) → the nearest point of the Planckian locus in (u, v): its
temperature is the CCT, the signed distance Duv (positive above the locus, towards green),
as Ohno (2013, "Practical use and calculation of CCT and Duv", LEUKOS 10(1)) defines them.

Ohno's method searches a table of the locus computed from the CIE 1931 2° colour matching
functions; here the locus is Krystek's (1985) rational approximation of it in (u, v) (within
8·10⁻⁵ of the CMF locus for 1,000-15,000 K), searched the same way: a coarse grid in
reciprocal temperature (mired), then the distance's parabola through the best three points
(Ohno's parabolic step). Why not colour-science, the kept library: it pulls
scipy and many megabytes into what must run on a Raspberry Pi; the core stays on numpy.
tests/core/radiometry/test_colour_temperature.py checks this against colour-science's ``uv_to_CCT_Ohno2013``.
"""
from __future__ import annotations

import numpy as np

#: Linear Rec. 709 RGB → CIE 1931 XYZ (ITU-R BT.709 primaries, D65 white).
RGB709_TO_XYZ = np.array([[0.4123908, 0.3575843, 0.1804808],
                          [0.2126390, 0.7151687, 0.0721923],
                          [0.0193308, 0.1191948, 0.9505322]])
#: The range of temperatures reported (K); outside it the CCT is None.
CCT_RANGE = (1000.0, 25000.0)
#: Beyond this |Duv| the colour is too far from any white for a CCT to mean anything
#: (ANSI C78.377 whites are within ±0.006; CIE 015 calls CCT meaningless beyond ±0.05).
DUV_LIMIT = 0.05


def planck_uv(t_k) -> np.ndarray:
    """(u, v) of the Planckian locus at temperatures ``t_k`` (K), Krystek 1985 (..., 2)."""
    t = np.asarray(t_k, np.float64)
    u = (0.860117757 + 1.54118254e-4 * t + 1.28641212e-7 * t * t) / (
        1 + 8.42420235e-4 * t + 7.08145163e-7 * t * t)
    v = (0.317398726 + 4.22806245e-5 * t + 4.20481691e-8 * t * t) / (
        1 - 2.89741816e-5 * t + 1.61456053e-7 * t * t)
    return np.stack([u, v], axis=-1)


def rgb_to_uv(rgb) -> np.ndarray | None:
    """CIE 1960 (u, v) of linear Rec. 709 RGB, or None for black (or a denominator ≤ 0)."""
    xyz = RGB709_TO_XYZ @ np.asarray(rgb, np.float64)
    d = xyz[0] + 15 * xyz[1] + 3 * xyz[2]
    if not (d > 0 and np.isfinite(d)):
        return None
    return np.array([4 * xyz[0] / d, 6 * xyz[1] / d])


#: The locus tabulated in reciprocal temperature (mired), 0.24 mired apart: the search's
#: grid, computed once.
_MIRED = np.linspace(1e6 / CCT_RANGE[1], 1e6 / CCT_RANGE[0], 4000)
_LOCUS = planck_uv(1e6 / _MIRED)


def uv_to_cct_duv(uv) -> tuple[float, float]:
    """(CCT in K, Duv) of a CIE 1960 (u, v): the nearest point of the Planckian locus, by
    the nearest grid point and Ohno's parabola through it and its neighbours. The CCT is
    clamped to :data:`CCT_RANGE`; callers check it and |Duv|."""
    uv = np.asarray(uv, np.float64)
    d = np.sqrt(np.sum((_LOCUS - uv) ** 2, axis=1))
    i = int(np.clip(np.argmin(d), 1, len(_MIRED) - 2))
    d0, d1, d2 = d[i - 1], d[i], d[i + 1]
    h = _MIRED[i + 1] - _MIRED[i]
    curvature = d0 - 2 * d1 + d2
    step = 0.5 * (d0 - d2) / curvature if curvature > 0 else 0.0
    best = float(_MIRED[i] + np.clip(step, -1.0, 1.0) * h)
    cct = 1e6 / best
    on = planck_uv(cct)
    # the sign: above the locus (towards +v, greenish) is positive, Ohno's convention
    tangent = _LOCUS[i + 1] - _LOCUS[i - 1]
    normal = np.array([-tangent[1], tangent[0]])
    normal *= np.sign(normal[1]) or 1.0
    dist = float(np.hypot(*(uv - on)))
    return cct, dist if np.dot(uv - on, normal) >= 0 else -dist


def cct_duv(rgb) -> tuple[float, float] | None:
    """(CCT K, Duv) of linear Rec. 709 RGB light, or None when it has none: black, or
    too far from the Planckian locus (|Duv| > :data:`DUV_LIMIT`) or outside
    :data:`CCT_RANGE`."""
    uv = rgb_to_uv(rgb)
    if uv is None:
        return None
    cct, duv = uv_to_cct_duv(uv)
    if abs(duv) > DUV_LIMIT or not (CCT_RANGE[0] < cct < CCT_RANGE[1]):
        return None
    return cct, duv


def rgb_of_cct(t_k: float, duv: float = 0.0) -> np.ndarray:
    """Linear Rec. 709 RGB of unit luminance (Y = 1) whose CCT is ``t_k`` (K) and Duv
    ``duv``: the locus point (u, v) moved ``duv`` along the locus's normal (positive toward
    +v, Ohno's sign) → (x, y) → XYZ → RGB: the inverse of :func:`cct_duv`. What a chroma
    meter's reading (lux, CCT, Duv) is in the frame's colour space."""
    t = float(t_k)
    on = planck_uv(t)
    tangent = planck_uv(t * 1.001) - planck_uv(t / 1.001)
    normal = np.array([-tangent[1], tangent[0]]) / np.hypot(*tangent)
    normal *= np.sign(normal[1]) or 1.0
    u, v = on + float(duv) * normal
    d = 2 * u - 8 * v + 4
    x, y = 3 * u / d, 2 * v / d
    return np.linalg.solve(RGB709_TO_XYZ, np.array([x / y, 1.0, (1 - x - y) / y]))


def colour_fields(coefficients, lights=()) -> dict:
    """The message's colour fields: ``cct_k`` and ``duv`` of the mean radiance (L00) when it
    has a CCT, and per light ``light_cct_k`` / ``light_duv`` (k numbers, 0 where a light
    has none: JsonUtility has no null)."""
    out = {}
    ambient = cct_duv(np.asarray(coefficients, np.float64)[0])
    if ambient is not None:
        out["cct_k"], out["duv"] = ambient
    per = [cct_duv(light.irradiance) for light in lights]
    out["light_cct_k"] = [p[0] if p else 0.0 for p in per]
    out["light_duv"] = [p[1] if p else 0.0 for p in per]
    return out
