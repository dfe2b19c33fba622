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
    distinct = _distinct_views(corners)
    if distinct < 3:
        places = f"{distinct} distinct place{'' if distinct == 1 else 's'}"
        raise ProjectionError(f"the board is found in {len(corners)} photos but in only "
                              f"{places} (the same photo twice?): a lens calibration needs "
                              "at least 3; move or tilt the board between photos")
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
        rms, K, D, rvecs, _ = cv2.fisheye.calibrate(
            objs, imgs, (w, h), K, np.zeros((4, 1)), flags=flags,
            criteria=(cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12))
    except cv2.error as exc:
        raise ProjectionError("the lens calibration did not converge (OpenCV: "
                              f"{str(exc).strip().splitlines()[-1]}): take more photos, the "
                              "board at several angles and distances") from None
    # OpenCV hands back its starting guess, or a lens that fits anything, without an error
    # where the photos cannot pin the lens down: refused here, not written.
    if not rms <= MAX_RMS_PX:
        raise ProjectionError(f"the lens calibration did not fit the photos (reprojection "
                              f"error {rms:.3g} px RMS, at most {MAX_RMS_PX:g}): the boards "
                              "found do not come from one fisheye lens; take more photos, the "
                              "board at several angles and distances")
    spread = _tilt_spread(rvecs)
    if spread < MIN_TILT_SPREAD_DEG:
        raise ProjectionError(f"the boards in all {len(corners)} photos face the lens at one "
                              f"tilt (within {spread:.1f}°, at least {MIN_TILT_SPREAD_DEG:g}° "
                              "needed): a flat board at one tilt cannot tell the focal length "
                              "from the curve; tilt it, and move it across the circle")
    fx, fy = float(K[0, 0]), float(K[1, 1])
    out = {"shlight_lens": LENS_FILE_VERSION, "model": "kannala-brandt",
           "curve": [1.0] + [float(v) for v in np.ravel(D)],
           "focal": math.sqrt(fx * fy), "aspect": fx / fy,
           "center": [float(K[0, 2]) + 0.5, float(K[1, 2]) + 0.5],
           "image_size": [w, h], "fov_deg": float(fov_deg), "profile": profile,
           "rms_px": float(rms), "views": len(corners), "board": list(board),
           "max_corner_deg": _max_angle(imgs, K, D)}
    if out["max_corner_deg"] > fov_deg / 2 + 1.0:     # 1°: the corners' own scatter
        raise ProjectionError(f"the photos show corners {out['max_corner_deg']:.0f}° from the "
                              f"lens's axis, outside a field of view of {fov_deg:g}° (--fov): "
                              f"give the lens's field of view, at least "
                              f"{2 * math.ceil(out['max_corner_deg']):g}°")
    lens_from_dict(out)        # refuse a curve that turns back before fov/2 now
    return out


#: Largest reprojection error (px RMS) of a calibration that is written: the corner finder
#: is good to a fraction of a pixel (measured 0.08-0.3 px on rendered boards); OpenCV's
#: unmoved starting guess on boards it cannot fit misses them by 100-230 px.
MAX_RMS_PX = 3.0
#: Least angle (degrees) between the boards' tilts over all photos: boards that all face the
#: lens the same way are Zhang's degenerate case (measured 1-2° for boards moved or scaled
#: in the image only, 91-135° for photos that follow the advice).
MIN_TILT_SPREAD_DEG = 10.0
#: Corners that move less than this on average (px) are the same view (the same photo).
SAME_VIEW_PX = 0.5


def _distinct_views(corners: list) -> int:
    """How many of the photos' corner sets differ from every one before it."""
    kept = []
    for c in corners:
        c = np.asarray(c, np.float64).reshape(-1, 2)
        if all(np.hypot(*(c - k).T).mean() >= SAME_VIEW_PX for k in kept):
            kept.append(c)
    return len(kept)


def _tilt_spread(rvecs) -> float:
    """Largest angle (degrees) between the board normals of any two views."""
    normals = np.array([cv2.Rodrigues(np.asarray(r, np.float64))[0][:, 2] for r in rvecs])
    return float(np.degrees(np.arccos(np.clip(normals @ normals.T, -1.0, 1.0))).max())


def _max_angle(imgs, K, D) -> float:
    """The largest angle from the axis (degrees) at which a corner was seen."""
    pts = np.concatenate([i.reshape(-1, 1, 2) for i in imgs])
    und = cv2.fisheye.undistortPoints(pts, K, D).reshape(-1, 2)
    return float(np.degrees(np.arctan(np.hypot(und[:, 0], und[:, 1]))).max())


#: Most terms of a lens file's curve (c₁θ … c₃₁θ³¹): a calibration writes 5, Ricoh's
#: curves have 7; more is no lens but a cost (every pixel's angle evaluates them all).
MAX_CURVE_TERMS = 16
#: Largest side (px) of a lens file's frame: above any camera's.
MAX_LENS_FRAME_SIDE = 1_000_000


def _shown(value, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 4] + " ..."


def _number(value, name: str, key: str) -> float:
    """A finite number of a lens file (no bool, no text, no list)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ProjectionError(f"{name}: {key} must be a number, got {_shown(value)}")
    try:
        v = float(value)
    except OverflowError:
        v = math.inf
    if not math.isfinite(v):
        raise ProjectionError(f"{name}: {key} must be a finite number, got {_shown(value)}")
    return v


def _numbers(value, count, name: str, key: str) -> list:
    """A flat list of ``count`` (an int, or a range) finite numbers of a lens file."""
    sizes = range(count, count + 1) if isinstance(count, int) else count
    if not isinstance(value, (list, tuple)) or len(value) not in sizes:
        want = (f"{count}" if isinstance(count, int)
                else f"{sizes.start}-{sizes.stop - 1}")
        got = f"{len(value)} items" if isinstance(value, (list, tuple)) else _shown(value)
        raise ProjectionError(f"{name}: {key} must be a list of {want} numbers, got {got}")
    return [_number(v, name, f"{key}[{i}]") for i, v in enumerate(value)]


def lens_from_dict(data: dict, name: str = "lens file") -> dict:
    """The validated contents of a lens file: ``curve`` a LensCurve, ``focal`` (px),
    ``center`` (px), ``image_size``, ``fov_deg``, ``profile``. ProjectionError in one line
    naming what is wrong (every field is checked for its type and range before use)."""
    if not isinstance(data, dict) or data.get("shlight_lens") != LENS_FILE_VERSION:
        raise ProjectionError(f"{name} is not a lens file of shlight calibrate-lens "
                              f"(no \"shlight_lens\": {LENS_FILE_VERSION})")
    missing = [k for k in ("curve", "focal", "center", "image_size", "fov_deg") if k not in data]
    if missing:
        raise ProjectionError(f"{name}: no '{missing[0]}' (write it with shlight calibrate-lens)")
    fov = _number(data["fov_deg"], name, "fov_deg")
    if not 0 < fov <= 360:
        raise ProjectionError(f"{name}: fov_deg {fov:g} is not a field of view in (0, 360] degrees")
    curve = data["curve"]
    if isinstance(curve, (list, tuple)) and len(curve) > MAX_CURVE_TERMS:
        raise ProjectionError(f"{name}: curve has {len(curve):,} terms, at most "
                              f"{MAX_CURVE_TERMS} (a calibration writes 5, Ricoh's curves have "
                              "7; every pixel's angle evaluates them all)")
    coefficients = _numbers(curve, range(1, MAX_CURVE_TERMS + 1), name, "curve")
    focal = _number(data["focal"], name, "focal")
    cx, cy = _numbers(data["center"], 2, name, "center")
    size = _numbers(data["image_size"], 2, name, "image_size")
    if not all(v == int(v) and 1 <= v <= MAX_LENS_FRAME_SIDE for v in size):
        raise ProjectionError(f"{name}: image_size must be two whole numbers of pixels, 1 to "
                              f"{MAX_LENS_FRAME_SIDE:,}, got {_shown(data['image_size'])}")
    w, h = (int(v) for v in size)
    if focal <= 0:
        raise ProjectionError(f"{name}: focal must be positive, got {focal:g}")
    profile = data.get("profile", "theta-s")
    if not isinstance(profile, str) or profile not in PROFILES:
        raise ProjectionError(f"{name}: profile must be one of {', '.join(PROFILES)}, got "
                              f"{_shown(profile)}")
    curve = LensCurve(coefficients, math.radians(fov / 2), f"{name}")
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
