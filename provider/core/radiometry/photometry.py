"""Light in the units people use: cd/m², lux and EV100 from a frame's own exposure (no I/O).

The camera relation (ISO 12232:2019 "standard output sensitivity", and the reflected-light
meter equation of ISO 2720:1974): the focal-plane exposure of a scene of luminance L
(cd/m²) is ``H = q · L · t / N²`` (lx·s; t the exposure time in seconds, N the f-number,
q ≈ 0.65 the lens's transmission and vignetting factor), and a camera of sensitivity S
renders mid-grey (code 118) at ``H_m = 10 / S``. Together: the luminance a camera at
(t, N, S) renders as mid-grey is ``L = (10 / q) · N² / (S · t)`` ≈ 15.4 N²/(S·t); a
reflected-light meter's calibration constant K = 12.5 cd·s/m² is the same relation for the
scene's mean (``N²/t = L · S / K``).

shlight's curve decodes a code to sensor exposure ``X = g(z)`` with mid-grey at 0.18
(:mod:`.response`), and the engine divides by ``t · gain`` with gain = ISO/100. So

    L [cd/m²] = C · N² · g(z) / (t · S/100)

with one camera constant C. ISO 12232 gives its nominal value, ``10 / (q · 0.18 · 100)`` =
0.855 (:data:`NOMINAL_CD_M2`); a real camera differs (its ISO is a rating, its lens's q is
not 0.65), so ``shlight calibrate-response BRACKET... --lux E`` measures C once with a lux
meter (``camera.json`` ``params.absolute``). With C known, every later frame's own time,
f-number and ISO give cd/m²; the f-number of the calibration stands in for a frame that
does not say its own (a fixed-aperture camera).

Photometric quantities of linear Rec. 709 RGB: the luminance of (R, G, B) is
``0.2126 R + 0.7152 G + 0.0722 B`` (ITU-R BT.709, the Y row of its RGB→XYZ matrix). With
coefficients in cd/m² (their luminance is in cd/m²), irradiance E from the SH9 matrices is
in lux directly (cd/m² · sr = lm/m²): ``illuminance_lux = Y(E(+Y))``. (For radiometric RGB
in W/(m²·sr) the same weights times 683 lm/W, the luminous efficacy at 555 nm, would give
lux; shlight's absolute scale is calibrated photometrically, so no 683 enters.)

EV100 (what a physical camera at ISO 100 would set for this scene) is the reflected-light
meter equation on the mean luminance over the sphere, ``EV100 = log2(L̄ · 100 / K)``,
K = 12.5; L̄ = Y00 · Y(L00) (the mean radiance of an SH9 is L00 · Y00).
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import InputError

#: ITU-R BT.709 luminance weights of linear R, G, B.
LUMINANCE_WEIGHTS = np.array([0.2126, 0.7152, 0.0722])
#: ISO 12232 lens factor q (transmission × vignetting × cos⁴ for an on-axis point).
LENS_Q = 0.65
#: Nominal C (cd/m² per unit of N²·g(z)/(t·S/100)) of an ideal ISO 12232 SOS camera.
NOMINAL_CD_M2 = 10.0 / (LENS_Q * 0.18 * 100.0)
#: Reflected-light meter calibration constant K (cd·s/m², ISO 2720; Canon, Nikon, Sekonic).
METER_K = 12.5
#: The real SH basis constant Y00 (docs/contract.md §1).
Y00 = 0.282095
UNITS_ABSOLUTE = "cd/m²"
UNITS_RELATIVE = "relative"

# ---- what a camera and a lux meter can read: one place for every command's bounds. A number
# beyond them is a typo or a unit slip (klux for lux, a focal length for an f-number), and
# through N²/(t·S) and lux/(N²·E) it would give a camera constant or a light no display or
# float32 can hold; the commands refuse it in one line (:func:`check_physical`).

#: Lux of a meter's reading, above 0 and at most 2e5: the brightest daylight at the ground
#: is about 1.3e5 lux (a clear sky, the sun near the zenith), so 2e5 leaves room for a
#: meter's own error and a bright reflection, and nothing brighter is a room's light.
LUX_RANGE = (0.0, 2.0e5)
#: f-number N: 0.5 is the limit of a lens in air (N = 1/(2·NA), NA ≤ 1); 128 is the
#: smallest stop of large-format lenses (a pinhole beyond it is no light probe).
F_NUMBER_RANGE = (0.5, 128.0)
#: ISO (S): 1 is below any sensor's or film's base sensitivity; 1e7 above the highest any
#: camera offers (a few million, extended).
ISO_RANGE = (1.0, 1.0e7)
#: Exposure time (s): 1 µs is shorter than any still camera's shutter (1/32,000 s
#: electronic); a day is longer than any exposure of a room's light.
EXPOSURE_S_RANGE = (1.0e-6, 86400.0)


def check_physical(what: str, value, bounds: tuple, unit: str = "") -> float:
    """``value`` as a float if it lies within ``bounds`` (low exclusive when it is 0,
    else inclusive; high inclusive), else one :class:`InputError` naming ``what`` (the
    option) and the range."""
    low, high = bounds
    try:
        v = float(value)
        got = f"{v:g}"
    except (TypeError, ValueError):
        v, got = math.nan, repr(value)
    inside = (v > low if low == 0 else v >= low) and v <= high
    if not (math.isfinite(v) and inside):
        span = (f"a positive number of at most {high:g}{unit}" if low == 0 else
                f"a number from {low:g} to {high:g}{unit}")
        raise InputError(f"{what} must be {span}, got {got} (beyond what a camera or a "
                         "lux meter can read: docs/photometry.md)")
    return v


def luminance(rgb) -> np.ndarray:
    """Rec. 709 luminance of linear RGB (..., 3)."""
    return np.asarray(rgb, np.float64) @ LUMINANCE_WEIGHTS


def irradiance_at(matrices, normal) -> np.ndarray:
    """RGB irradiance E(n) = ñᵀMñ (docs/contract.md §2) of the (3, 4, 4) matrices."""
    n = np.append(np.asarray(normal, np.float64), 1.0)
    return np.einsum("i,cij,j->c", n, np.asarray(matrices, np.float64), n)


def illuminance_up(matrices) -> float:
    """Luminance-weighted irradiance on an up-facing (+Y) surface: lux when the matrices
    are in cd/m²·sr (absolute), relative otherwise. Never below 0 (the shaders clamp too)."""
    return max(float(luminance(irradiance_at(matrices, (0.0, 1.0, 0.0)))), 0.0)


def mean_luminance(coefficients) -> float:
    """Mean luminance over the sphere of directions: Y00 · Y(L00)."""
    return float(luminance(np.asarray(coefficients, np.float64)[0])) * Y00


def ev100(mean_luminance_cd_m2: float) -> float | None:
    """EV100 a reflected-light meter (K = 12.5) gives for a scene of this mean luminance
    (cd/m²); None for a black scene."""
    if not (mean_luminance_cd_m2 > 0 and math.isfinite(mean_luminance_cd_m2)):
        return None
    return math.log2(mean_luminance_cd_m2 * 100.0 / METER_K)


def camera_ev100(exposure_s: float, f_number: float, iso: float) -> float:
    """The EV100 of a camera's own setting: log2(N²/t) − log2(S/100)."""
    return math.log2(f_number ** 2 / exposure_s) - math.log2(iso / 100.0)


def absolute_calibration(response) -> dict | None:
    """camera.json's ``params.absolute`` (``cd_m2`` = C, ``f_number``, ``iso`` of the
    calibration, ``lux``), or None when the curve has no absolute scale."""
    if response is None:
        return None
    a = response.params.get("absolute")
    if not isinstance(a, dict):
        return None
    c = a.get("cd_m2")
    if not isinstance(c, (int, float)) or not (math.isfinite(c) and c > 0):
        raise InputError("camera.json params.absolute.cd_m2 must be a positive number "
                         "(write it with shlight calibrate-response --lux)")
    return a


def absolute_factor(response, f_number: float | None) -> float | None:
    """C · N²: what turns radiance per (t · ISO/100) into cd/m², or None without an
    absolute calibration. A frame that does not say its f-number takes the calibration's."""
    a = absolute_calibration(response)
    if a is None:
        return None
    n = f_number if f_number else a.get("f_number")
    if not n:
        raise InputError("the camera's absolute scale needs the frame's f-number (EXIF "
                         "FNumber, or --f-number)")
    return float(a["cd_m2"]) * float(n) ** 2


def calibrate_absolute(illuminance_relative: float, lux: float, f_number: float,
                       iso: float) -> dict:
    """``params.absolute`` from a bracket's up-facing illuminance, in units of
    radiance per (t · ISO/100) (``illuminance_relative``), and a lux meter's reading ``lux``
    at the camera at the same time: C = lux / (N² · E_rel)."""
    lux = check_physical("--lux", lux, LUX_RANGE, " lux")
    f_number = check_physical("f-number", f_number, F_NUMBER_RANGE)
    iso = check_physical("ISO", iso, ISO_RANGE)
    if not (illuminance_relative > 0 and math.isfinite(illuminance_relative)):
        raise InputError("the bracket shows no light on an up-facing surface: the absolute "
                         "scale needs a lit scene (is the camera upright, the lens uncovered?)")
    c = lux / (f_number ** 2 * illuminance_relative)
    return {"cd_m2": c, "lux": float(lux), "f_number": float(f_number), "iso": float(iso),
            "vs_iso12232": c / NOMINAL_CD_M2,
            "relation": "L [cd/m²] = cd_m2 · N² · g(z) / (t · ISO/100)"}


def photometric_fields(coefficients, matrices, lights=(), absolute: bool = False,
                       exact_lux: float | None = None) -> dict:
    """The message's photometric fields: ``coefficient_units``, and when ``absolute``
    ``illuminance_lux`` (up-facing: ``exact_lux``, the engine's sum over the pixels, where
    it has one, else from the SH9 matrices), ``ev100`` and ``light_illuminance_lux`` (k
    numbers: each light's illuminance on a surface facing it)."""
    out = {"coefficient_units": UNITS_ABSOLUTE if absolute else UNITS_RELATIVE}
    if absolute:
        out["illuminance_lux"] = (float(exact_lux) if exact_lux is not None
                                  and math.isfinite(exact_lux) else illuminance_up(matrices))
        ev = ev100(mean_luminance(coefficients))
        if ev is not None:
            out["ev100"] = ev
        out["light_illuminance_lux"] = [max(float(luminance(light.irradiance)), 0.0)
                                        for light in lights]
    return out
