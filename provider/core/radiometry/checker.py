"""A camera's colour from a photo of an X-Rite ColorChecker (24 patches) (no I/O).

A camera's RGB is not Rec. 709: its own primaries and its white balance tilt every colour
field (``cct_k``, ``light_cct_k``, a clipped sun's modelled colour). One photo of a
ColorChecker under the light to measure fixes both: OpenCV's MCC detector finds the chart
and the mean of each patch (``cv2.mcc``, contrib), the camera's curve linearises them, and
OpenCV's colour correction model fits the 3×3 matrix that takes them to the chart's
reference in linear Rec. 709 (``cv2.ccm``: its ColorChecker reference in CIE Lab, D50, to
linear sRGB, whose primaries and white are Rec. 709's). The matrix is scaled so that the
neutral patches keep their luminance: the absolute scale (``params.absolute``) holds.

camera.json keeps it as ``params.colour_matrix`` (3×3, linear camera RGB → linear Rec. 709,
column vectors) with ``params.white_balance`` (the R, G, B gains that make the chart's
greys grey, G = 1: what the matrix does to white) and ``params.checker`` (the fit's
residual); :class:`~provider.core.sh9.engine.SH9Projector` applies the matrix to every
result of a frame decoded with that curve.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from .photometry import LUMINANCE_WEIGHTS

#: The ColorChecker's neutral patches (white to black), in the chart's order (0-based).
NEUTRALS = slice(18, 24)
#: Patches within this share of the top code in any channel, or this share of it from
#: black, do not enter the fit (clipped, or in the toe).
USABLE = (0.02, 0.98)


def checker_patches(rgb: np.ndarray) -> np.ndarray:
    """(24, 3) mean codes of the ColorChecker's patches in an 8-bit RGB photo, in the
    chart's order (dark skin … black), found by OpenCV's MCC detector. InputError when no
    chart is found."""
    import cv2
    frame = np.ascontiguousarray(rgb)
    if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3:
        raise InputError("--checker needs an 8-bit RGB photo of the chart")
    detector = cv2.mcc.CCheckerDetector.create()
    detector.setColorChartType(cv2.mcc.MCC24)
    if not detector.process(cv2.cvtColor(frame, cv2.COLOR_RGB2BGR), 1):
        raise InputError("--checker: no ColorChecker (24 patches) found in the photo: "
                         "the whole chart in view, flat, evenly lit, a tenth of the frame "
                         "or more")
    stats = detector.getBestColorChecker().getChartsRGB()    # (72, 5): count, mean, …
    return np.asarray(stats[:, 1], np.float64).reshape(24, 3)


def fit_colour_matrix(linear: np.ndarray, usable=None) -> dict:
    """The camera's colour from its patches ``linear`` (24, 3; linear camera RGB, any
    scale): ``{"colour_matrix": 3×3 list, "white_balance": [r, 1, b], "checker": {...}}``
    (module doc). ``usable`` (24,) bool: the patches to fit (default all). OpenCV's
    ``cv2.ccm.ColorCorrectionModel`` fits the matrix (linear, identity linearisation, CIE
    2000 distance); InputError when fewer than 12 patches are usable or the fit is
    degenerate."""
    import cv2
    linear = np.asarray(linear, np.float64).reshape(24, 3)
    usable = np.ones(24, bool) if usable is None else np.asarray(usable, bool)
    if usable.sum() < 12 or not usable[NEUTRALS].any():
        raise InputError(f"--checker: only {int(usable.sum())} of 24 patches are neither "
                         "clipped nor black (at least 12 and a grey are needed): expose the "
                         "chart's white below clipping")
    src = np.clip(linear / max(float(linear[usable].max()), 1e-30), 0.0, 1.0)
    model = cv2.ccm.ColorCorrectionModel(src.reshape(24, 1, 3), cv2.ccm.COLORCHECKER_MACBETH)
    model.setColorSpace(cv2.ccm.COLOR_SPACE_SRGB)          # (linear sRGB: Rec. 709)
    model.setCcmType(cv2.ccm.CCM_LINEAR)
    model.setLinearization(cv2.ccm.LINEARIZATION_IDENTITY)
    model.setInitialMethod(cv2.ccm.INITIAL_METHOD_LEAST_SQUARE)
    model.setWeightsList(usable.astype(np.float64).reshape(24, 1))
    model.compute()
    matrix = np.asarray(model.getColorCorrectionMatrix(), np.float64).T   # column vectors
    greys = linear[NEUTRALS][usable[NEUTRALS]].sum(axis=0)
    weights = np.asarray(LUMINANCE_WEIGHTS, np.float64)
    after = float(weights @ (matrix @ greys))
    if not (np.all(np.isfinite(matrix)) and after > 0):
        raise InputError("--checker: the colour fit is degenerate (are the patches lit "
                         "evenly and exposed?)")
    matrix *= float(weights @ greys) / after           # the neutrals keep their luminance
    balanced = matrix @ greys
    return {"colour_matrix": matrix.tolist(),
            "white_balance": [float(balanced[0] / greys[0] * greys[1] / balanced[1]), 1.0,
                              float(balanced[2] / greys[2] * greys[1] / balanced[1])],
            "checker": {"patches": int(usable.sum()), "loss": float(model.getLoss())}}


def colour_matrix(response) -> np.ndarray | None:
    """(3, 3) camera.json's ``params.colour_matrix`` of a curve, or None. InputError for
    one that is not 3×3 finite numbers."""
    params = getattr(response, "params", None) or {}
    value = params.get("colour_matrix")
    if value is None:
        return None
    try:
        matrix = np.asarray(value, np.float64)
    except (TypeError, ValueError):
        matrix = np.zeros(0)
    if matrix.shape != (3, 3) or not np.all(np.isfinite(matrix)):
        raise InputError("camera.json params.colour_matrix must be 3×3 finite numbers "
                         "(calibrate-response --checker writes it)")
    return matrix
