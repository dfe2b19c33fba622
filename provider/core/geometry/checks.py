"""Checks of projection geometry against the frame: options no frame can make valid, and
frames too small to integrate. Every failure is a :class:`ProjectionError` that says what
to change (the engine turns it into an :class:`~provider.core.errors.InputError`)."""
from __future__ import annotations

import math


class ProjectionError(ValueError):
    """A projection cannot be built for this image size or these options."""


#: A lens circle smaller than this (pixel radius at the edge of the field of view) is refused:
#: a few pixels each seeing tens of degrees cannot be integrated exactly (a 1×1 frame read
#: as dual fisheye "saw" 24 sr, more than the sphere). At 8 px the solid angle a fisheye sees
#: is within ~3 % of the truth (16 px: 1 %); real lenses have hundreds.
MIN_CIRCLE_PX = 8.0


def finite(value, what: str) -> float:
    """``value`` as a float, or ProjectionError if it is not a finite number."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ProjectionError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ProjectionError(f"{what} must be a finite number, got {v}")
    return v


#: A lens circle more than this many frame widths in radius: the frame sees almost nothing.
MAX_CIRCLE_SPANS = 100.0


def check_fov(fov_deg) -> float:
    """A fisheye field of view in (0, 360] degrees."""
    fov = finite(fov_deg, "fisheye field of view")
    if not 0 < fov <= 360:
        raise ProjectionError(f"fisheye field of view must be in (0, 360] degrees, got {fov:g}")
    return fov


def check_fisheye_calibration(K, D, fov_deg: float):
    """An OpenCV fisheye calibration (Kannala-Brandt) as float arrays ``K`` (3×3), ``D`` (4;
    None: zeros), refused unless finite with positive focal lengths and below 180°."""
    import numpy as np
    try:
        K = np.asarray(K, np.float64).reshape(3, 3)
        D = np.zeros(4) if D is None else np.asarray(D, np.float64).ravel()
    except (TypeError, ValueError):
        raise ProjectionError("an OpenCV fisheye calibration has K (3×3 numbers) and "
                              "D (4 numbers)") from None
    if D.size != 4:
        raise ProjectionError("OpenCV fisheye distortion D must have 4 coefficients")
    if not (np.all(np.isfinite(K)) and np.all(np.isfinite(D)) and K[0, 0] > 0 and K[1, 1] > 0):
        raise ProjectionError("the fisheye calibration K, D must be finite, with "
                              "positive focal lengths K[0][0], K[1][1]")
    if fov_deg >= 180:
        raise ProjectionError(
            "cv2.fisheye (Kannala-Brandt) calibrations are valid below 180°: "
            "pass --fov < 180, or use the equidistant model with a focal length")
    return K, D


def check_lens_in_frame(lens, x0: float, y0: float, x1: float, y1: float, what: str) -> None:
    """Refuse a lens whose centre is outside the pixel rectangle [x0, x1] × [y0, y1], or
    whose image circle is too small to integrate (``lens``: a FisheyeLens)."""
    if not (x0 <= lens.cx <= x1 and y0 <= lens.cy <= y1):
        raise ProjectionError(
            f"{what} centre ({lens.cx:g}, {lens.cy:g}) is outside the frame "
            f"(x in [{x0:g}, {x1:g}], y in [{y0:g}, {y1:g}]): check --center")
    if lens.circle_radius < MIN_CIRCLE_PX:
        raise ProjectionError(
            f"{what} image circle is {lens.circle_radius:.1f} px in radius: too small to "
            f"integrate (at least {MIN_CIRCLE_PX:g} px; a larger frame, a smaller "
            "--downsample, or check --radius)")
    span = max(x1 - x0, y1 - y0, 1.0)
    if lens.circle_radius > MAX_CIRCLE_SPANS * span:
        raise ProjectionError(
            f"{what} image circle is {lens.circle_radius:.4g} px in radius, more than "
            f"{MAX_CIRCLE_SPANS:g}× the {span:g} px frame: the frame would see almost nothing "
            "of the lens's field (too large; check --radius)")
