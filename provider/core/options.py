"""The engine's options, checked before any frame; what a frame's exposure does; what
building a projector costs.

Shared by the products (:mod:`.sh9`, :mod:`.reflections`), kept apart from them so that the command line can refuse an impossible option
at start (``shlight serve``: once, in one line) without building anything.
"""
from __future__ import annotations

import math

import numpy as np

from .errors import InputError
from .radiometry.response import check_time

ORDERS = (0, 1, 2, "auto")
DERING = ("off", "auto")
LIGHTS = ("off", "auto")
#: Most directional lights per frame (the shaders' SH_MAX_LIGHTS).
MAX_LIGHTS = 4
#: The largest float32: integer frames' tables (code -> linear × exposure) are float32, so a
#: larger exposure overflows every lit pixel, and no shader holds the result.
FLOAT32_MAX = float(np.finfo(np.float32).max)
#: The smallest normal float32: below it the tables underflow (every pixel 0 or denormal).
FLOAT32_TINY = float(np.finfo(np.float32).tiny)
#: The largest coefficient a result may hold: the irradiance matrices (up to ~1.2× the
#: coefficients) and the shaders' sums of products over them stay within float32.
LIGHTING_MAX = FLOAT32_MAX / 16


def check_options(*, encoding="auto", exposure=1.0, downsample=1, rotation=None, order=2,
                  dering="off", order_budget=0.02, lights="off", max_lights=4) -> None:
    """Raise :class:`InputError` for engine options that no frame can make valid (so that
    ``shlight serve`` refuses them at start, in one line, rather than per frame)."""
    if order not in ORDERS:
        raise InputError(f"order must be one of 0, 1, 2, auto; got {order!r}")
    if dering not in DERING:
        raise InputError(f"dering must be 'off' or 'auto'; got {dering!r}")
    if lights not in LIGHTS:
        raise InputError(f"lights must be 'off' or 'auto'; got {lights!r}")
    if (isinstance(max_lights, bool) or not isinstance(max_lights, (int, np.integer))
            or not 1 <= max_lights <= MAX_LIGHTS):
        raise InputError(f"max_lights must be an integer from 1 to {MAX_LIGHTS}; "
                         f"got {max_lights!r}")
    if encoding not in ("auto", "srgb", "linear"):
        raise InputError(f"encoding must be auto, srgb or linear; got {encoding!r}")
    if not (isinstance(exposure, (int, float)) and math.isfinite(exposure) and exposure > 0):
        raise InputError(f"exposure must be a positive finite number; got {exposure!r}")
    if not FLOAT32_TINY <= exposure <= FLOAT32_MAX:
        raise InputError(f"exposure {exposure:g} {'over' if exposure > 1 else 'under'}flows "
                         f"the lighting: from {FLOAT32_TINY:.3g} to {FLOAT32_MAX:.3g} (float32's "
                         "range)")
    if not (isinstance(order_budget, (int, float)) and math.isfinite(order_budget)
            and order_budget >= 0):
        raise InputError(f"order budget must be a finite number >= 0; got {order_budget!r}")
    try:
        whole = not isinstance(downsample, bool) and float(downsample).is_integer()
    except (TypeError, ValueError):
        whole = False
    if not whole or downsample < 1:
        raise InputError(f"downsample must be a positive integer; got {downsample!r}")
    if rotation is not None:
        try:
            R = np.asarray(rotation, np.float64)
        except (TypeError, ValueError):
            R = np.full(1, np.nan)
        if (R.shape != (3, 3) or not np.all(np.isfinite(R))
                or not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0):
            raise InputError("rotation must be a finite 3×3 rotation matrix (orthonormal, "
                             "determinant +1)")


#: Rough cost of integrating the per-pixel weights of a fisheye, dual-fisheye or cube map
#: frame once (measured on one x86-64 core: 1 to 1.8 µs and ~130 bytes per pixel at peak; an
#: 8192×4096 fisheye frame took 37 s and 4.4 GB).
PRECOMPUTE_S_PER_PIXEL = 1.2e-6
PRECOMPUTE_BYTES_PER_PIXEL = 130
#: Frames (after --downsample) above this many pixels (about 10 s, 1 GB) get a note first.
PRECOMPUTE_NOTE_PIXELS = 8_000_000


def precompute_note(width: int, height: int, projection="equirect", downsample: int = 1):
    """One line saying what building a projector for such frames costs, with the
    ``--downsample`` that makes it cheap, when that is a lot; None otherwise. (Equirect
    frames are separable and always quick.)"""
    name = projection if isinstance(projection, str) else getattr(projection, "name", "")
    try:
        downsample = max(1, int(downsample))
    except (TypeError, ValueError):
        return None
    pixels = (width // downsample) * (height // downsample)
    if name == "equirect" or pixels <= PRECOMPUTE_NOTE_PIXELS:
        return None
    factor = downsample
    while (width // factor) * (height // factor) > 1_000_000:     # about a second
        factor *= 2
    small = (width // factor) * (height // factor)
    return (f"a {width}×{height} {name} frame{f' at --downsample {downsample}' if downsample > 1 else ''}"
            f" needs its per-pixel weights integrated once: "
            f"{_duration(pixels * PRECOMPUTE_S_PER_PIXEL)} and "
            f"{pixels * PRECOMPUTE_BYTES_PER_PIXEL / 1e9:.1f} GB of memory before the first "
            f"result. --downsample {factor} ({width // factor}×{height // factor}) takes "
            f"{_duration(small * PRECOMPUTE_S_PER_PIXEL)} and changes the lighting by well "
            "under 1 % (nine SH coefficients are very low frequency)")


def _duration(seconds: float) -> str:
    if seconds < 1:
        return "under a second"
    return f"about {seconds:.0f} s" if seconds < 90 else f"about {seconds / 60:.0f} min"


def exposure_scale(exposure_s, gain, stats: dict) -> float | None:
    """1 / (exposure_s · gain), recorded in ``stats``; None when no exposure is known."""
    if exposure_s is None:
        if gain != 1.0:
            raise InputError("a gain needs an exposure time too")
        return None
    t = check_time(exposure_s, "exposure_s")
    g = check_time(gain, "gain")
    stats["exposure_s"] = t
    if g != 1.0:
        stats["gain"] = g
    return 1.0 / (t * g)


def check_lighting(coefficients, exposure: float = 1.0, exposure_s=None) -> None:
    """Refuse lighting that overflowed (a huge ``exposure``, a frame of huge values): it
    would reach a shader as infinities, or as numbers beyond what float32 holds.

    Parameters
    ----------
    coefficients : array_like
        The (9, 3) coefficients of one frame, exposure applied.
    exposure : float
        The engine's ``exposure`` option, named in the message.
    exposure_s : float or None
        The frame's exposure time (seconds), named in the message when given.

    Raises
    ------
    InputError
        When a coefficient is not finite or beyond :data:`LIGHTING_MAX`.
    """
    _check_peak([coefficients], "a coefficient", exposure, exposure_s)


def _check_peak(arrays, what: str, exposure: float, exposure_s) -> None:
    """:func:`check_lighting`'s rule on the largest magnitude in ``arrays`` (``what``: what
    one of their numbers is, for the message)."""
    peak = 0.0
    with np.errstate(invalid="ignore"):
        for a in arrays:
            a = np.asarray(a, np.float64)
            m = float(np.max(np.abs(a))) if a.size else 0.0
            if not m <= peak:                   # larger, or NaN: NaN stays
                peak = m
            if not math.isfinite(peak):
                break
    if math.isfinite(peak) and peak <= LIGHTING_MAX:
        return
    at = f"exposure {exposure:g}" + (f" and a {exposure_s:g} s frame" if exposure_s else "")
    got = "not finite" if not math.isfinite(peak) else f"{peak:.3g}"
    raise InputError(f"the lighting overflows at {at}: {what} is {got}, beyond the "
                     f"{LIGHTING_MAX:.2g} that float32 shaders hold; lower the exposure (or "
                     "the frame's values)")


def check_cube_lighting(mips, exposure: float = 1.0, exposure_s=None) -> None:
    """Refuse a reflection cube (``mips``: its float levels, exposure applied) that overflowed,
    by :func:`check_lighting`'s rule and in its words, so that ``environment`` and ``export``
    refuse the frame that ``compute`` refuses (a texel beyond :data:`LIGHTING_MAX`, or not
    finite); what lies between half float's 65504 and that is stored clamped, with a count."""
    _check_peak(mips, "a texel of the cube", exposure, exposure_s)


def freeze_options(options: dict):
    """``options`` as a hashable key (arrays by shape and bytes), for caches of projectors."""
    def f(v):
        if isinstance(v, np.ndarray):
            return (v.shape, v.tobytes())
        if isinstance(v, (list, tuple)):
            return tuple(f(x) for x in v)
        return v
    return tuple(sorted((k, f(v)) for k, v in options.items()))
