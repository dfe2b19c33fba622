"""A fisheye lens curve from chessboard photos of one lens (no I/O).

OpenCV's fisheye calibration (``cv2.fisheye.calibrate``, the Kannala-Brandt model) fits
``r = f·θ(1 + k₁θ² + k₂θ⁴ + k₃θ⁶ + k₄θ⁸)`` to the chessboard corners found in each photo
(``cv2.findChessboardCornersSB``): exactly the odd polynomial of a
:class:`~.lens_profiles.LensCurve` (coefficients 1, k₁, …, k₄). The corners must be in front
of the lens (θ < 90°, OpenCV's model goes through tan θ); the polynomial is then used up to
``fov/2`` (a Theta's 100°), refused if it turns back before. The result is a lens file
(:func:`calibrate_lens`): the curve, the focal length and centre in shlight's pixel convention
(pixel ``(i, j)`` covers ``[i, i+1) × [j, j+1)``: OpenCV's centre + 0.5), the frame size, the
RMS reprojection error in pixels, and the profile whose layout a dual-fisheye frame keeps.
"""
from __future__ import annotations

import math

import cv2
import numpy as np

from .checks import ProjectionError
from .lens_profiles import PROFILES, LensCurve, LensProfile, lens_profile

#: Lens file format version (the ``shlight_lens`` key).
LENS_FILE_VERSION = 1


def find_board(gray: np.ndarray, board: tuple) -> np.ndarray | None:
    """(N, 2) inner corners (OpenCV's pixel convention) of a ``board`` = (columns, rows) of
    inner corners chessboard in an 8-bit grey image, or None where it is not found whole."""
    ok, corners = cv2.findChessboardCornersSB(gray, tuple(int(v) for v in board))
    return corners.reshape(-1, 2).astype(np.float64) if ok else None


def board_points(board: tuple, square: float) -> np.ndarray:
    """(N, 3) corner positions on the board plane, row by row (OpenCV's corner order)."""
    cols, rows = board
    return np.array([[i * square, j * square, 0.0] for j in range(rows) for i in range(cols)])


def calibrate_lens(corners: list, board: tuple, image_size: tuple, *, square: float = 1.0,
                   fov_deg: float = 200.0, profile: str = "theta-s") -> dict:
    """Fit a lens to the ``corners`` found in each photo ((N, 2) arrays, :func:`find_board`)
    of a frame of ``image_size`` = (width, height). Returns the lens file's contents
    (:func:`lens_from_dict` reads it back); ProjectionError if fewer than 3 photos or the fit fails."""
    if len(corners) < 3:
        raise ProjectionError(f"a lens calibration needs the board found whole in at least 3 "
                              f"photos; found in {len(corners)}")
    if profile not in PROFILES:
        raise ProjectionError(f"unknown lens profile {profile!r}; choose from {', '.join(PROFILES)}")
    w, h = (int(v) for v in image_size)
    obj = board_points(board, square)
    objs = [obj.reshape(1, -1, 3) for _ in corners]
    imgs = [np.asarray(c, np.float64).reshape(1, -1, 2) for c in corners]
    # A guess of the focal length: a 200° circle inscribed in the frame's shorter side (the
    # fit fails from OpenCV's own identity guess on strong fisheyes: InitExtrinsics).
    f0 = min(w, h) / 2 / math.radians(100)
    K = np.array([[f0, 0, w / 2 - 0.5], [0, f0, h / 2 - 0.5], [0, 0, 1.0]])
    flags = cv2.CALIB_RECOMPUTE_EXTRINSIC | cv2.CALIB_FIX_SKEW | cv2.CALIB_USE_INTRINSIC_GUESS
    try:
        rms, K, D, _, _ = cv2.fisheye.calibrate(
            objs, imgs, (w, h), K, np.zeros((4, 1)), flags=flags,
            criteria=(cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12))
    except cv2.error as exc:
        raise ProjectionError("the lens calibration did not converge (OpenCV: "
                              f"{str(exc).strip().splitlines()[-1]}): take more photos, the "
                              "board at several angles and distances") from None
    fx, fy = float(K[0, 0]), float(K[1, 1])
    out = {"shlight_lens": LENS_FILE_VERSION, "model": "kannala-brandt",
           "curve": [1.0] + [float(v) for v in np.ravel(D)],
           "focal": math.sqrt(fx * fy), "aspect": fx / fy,
           "center": [float(K[0, 2]) + 0.5, float(K[1, 2]) + 0.5],
           "image_size": [w, h], "fov_deg": float(fov_deg), "profile": profile,
           "rms_px": float(rms), "views": len(corners), "board": list(board),
           "max_corner_deg": _max_angle(imgs, K, D)}
    lens_from_dict(out)        # refuse a curve that turns back before fov/2 now
    return out


def _max_angle(imgs, K, D) -> float:
    """The largest angle from the axis (degrees) at which a corner was seen."""
    pts = np.concatenate([i.reshape(-1, 1, 2) for i in imgs])
    und = cv2.fisheye.undistortPoints(pts, K, D).reshape(-1, 2)
    return float(np.degrees(np.arctan(np.hypot(und[:, 0], und[:, 1]))).max())


def lens_from_dict(data: dict, name: str = "lens file") -> dict:
    """The validated contents of a lens file: ``curve`` a LensCurve, ``focal`` (px),
    ``center`` (px), ``image_size``, ``fov_deg``, ``profile``. ProjectionError in one line
    naming what is wrong."""
    try:
        if data.get("shlight_lens") != LENS_FILE_VERSION:
            raise ProjectionError(f"{name} is not a lens file of shlight calibrate-lens "
                                  f"(no \"shlight_lens\": {LENS_FILE_VERSION})")
        fov = float(data["fov_deg"])
        curve = LensCurve(data["curve"], math.radians(fov / 2), f"{name}")
        focal, (cx, cy) = float(data["focal"]), (float(v) for v in data["center"])
        w, h = (int(v) for v in data["image_size"])
        profile = data.get("profile", "theta-s")
    except ProjectionError:
        raise
    except KeyError as exc:
        raise ProjectionError(f"{name}: no {exc} (write it with shlight calibrate-lens)") from None
    except (TypeError, ValueError, AttributeError) as exc:
        raise ProjectionError(f"{name}: {exc}") from None
    if not (math.isfinite(focal) and focal > 0 and math.isfinite(cx) and math.isfinite(cy)
            and w > 0 and h > 0):
        raise ProjectionError(f"{name}: focal, center and image_size must be finite and positive")
    if profile not in PROFILES:
        raise ProjectionError(f"{name}: unknown profile {profile!r}")
    return {"curve": curve, "focal": focal, "center": (cx, cy), "image_size": (w, h),
            "fov_deg": fov, "profile": profile}


def curve_error_px(calibration: dict, curve: LensCurve, focal: float, theta_max: float) -> float:
    """Largest difference (px) between a lens file's radius r(θ) and ``focal``·``curve``
    over [0, ``theta_max``] radians: how well a calibration recovered a known lens."""
    cal = lens_from_dict(calibration)
    theta = np.linspace(0.0, theta_max, 201)
    got = cal["focal"] * cal["curve"].radius(theta)
    return float(np.abs(got - focal * curve.radius(theta)).max())


def calibrated_profile(calibration: dict, name: str = "lens file") -> LensProfile:
    """A dual-fisheye profile from a lens file's contents (``shlight calibrate-lens``): its
    curve and ring for both lenses, its centre for the lens in whose half it lies, the other
    centre and the front from the file's ``profile`` (default: the Theta S layout)."""
    cal = lens_from_dict(calibration, name)
    base = lens_profile(cal["profile"])
    w, h = cal["image_size"]
    ring = cal["focal"] * float(cal["curve"].radius(math.pi / 2))
    return LensProfile(name, None, ((w, h, ring),), base.centres, base.front, cal["fov_deg"],
                       f"calibrated ({w}×{h})", cal["curve"], tuple(cal["center"]))
