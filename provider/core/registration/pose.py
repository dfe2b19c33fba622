"""Registration: where a printed marker is in a panorama, as a pose in the camera's frame.

The headset tracks the same printed marker in its own world (HoloLens QR tracking, AR
Foundation image tracking, Vuforia, OpenXR marker tracking), so the two poses give the
rotation between the frames once: R_world←camera = R_world←marker · R_camera←markerᵀ
(docs/contract.md §13).

Method (:func:`find_marker`):

1. *Search*: six overlapping pinhole views (120°, the cube's axes) rendered from the
   panorama through its projection's inverse direction map (:mod:`.sphere_views`); OpenCV's
   detector (:mod:`.marker_detect`) runs on each.
2. *Measure*: a pinhole view centred on each detection, a few times finer than the
   panorama, rendered in linear light; the detector again, then the corners aligned on every
   marker pixel (ECC homography of the marker's pattern).
3. *Pose on the sphere*: the corners become unit rays; IPPE gives the two poses a planar
   square allows, each refined by Levenberg-Marquardt on the angles between predicted and
   observed rays; the one with the smaller error wins (``ambiguity`` says by how much).

Frames and units: the camera frame is docs/contract.md §1 (right-handed, +Y up; the
equirect centre looks along −Z). ``rotation`` is R_camera←marker, whose columns are the
marker's x (printed right), y (printed up) and z (out of the print) axes as OpenCV's ArUco
defines them; ``position`` is the marker's centre in metres; angles in degrees. No I/O.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from ..errors import InputError
from ..geometry.checks import ProjectionError
from .marker_detect import (OBJECT_CORNERS, MarkerSpec, check_marker_size, detect, parse_marker,
                            refine_corners)
from ..geometry.projections import DualFisheye, Fisheye, Projection, make_projection
from ..geometry.sphere_views import PinholeView, local_scale, look_rotation, render_view

#: Search views: the cube's six axes, each 120° wide, so any marker under ~30° is whole in one.
SEARCH_AXES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1.0]])
SEARCH_HALF_FOV = math.radians(60)
#: Search views are never finer than this (pixels per radian): a 20 cm marker at 2 m then
#: still spans ~40 px, and a 4K panorama is searched at a third of the cost.
SEARCH_MAX_SCALE = 450.0
#: The measuring view: the marker's side spans this many view pixels.
MEASURE_SIDE_PX = 160.0
#: ... but at most this many times finer than the panorama.
MEASURE_UPSAMPLE = 3.0


class MarkerNotFound(InputError):
    """The image holds no detectable marker of the requested kind (never a made-up pose)."""


@dataclass
class MarkerPose:
    """A marker's pose in the camera frame (docs/contract.md §1, §13).

    ``rotation``: R_camera←marker (3×3; columns: the marker's x, y, z axes);
    ``position``: its centre, metres; ``error_deg``/``error_px``: RMS angle between the
    observed and the predicted corner rays (px: in the panorama's pixels there);
    ``apparent_size_px``: the marker's side in panorama pixels; ``ambiguity``: the other
    planar pose's error over this one's (≥ 1; near 1: the two are hard to tell apart);
    ``rays``: the observed corner rays (4, 3); ``frames``: how many frames were averaged;
    ``levelled``: whether the frame was levelled by gravity before."""

    marker: str
    marker_id: int | str
    rotation: np.ndarray
    position: np.ndarray
    error_deg: float
    error_px: float
    apparent_size_px: float
    ambiguity: float
    rays: np.ndarray = field(repr=False)
    frames: int = 1
    levelled: bool = False
    spread_deg: float = 0.0

    @property
    def direction(self) -> np.ndarray:
        """Unit direction of the marker's centre from the camera."""
        return self.position / np.linalg.norm(self.position)

    def to_json(self) -> dict:
        """The JSON fields of ``shlight register`` and the wire message's ``registration``."""
        return {
            "marker": self.marker, "marker_id": self.marker_id,
            "rotation": [round(float(v), 7) for v in self.rotation.ravel()],
            "position": [round(float(v), 5) for v in self.position],
            "error_deg": round(self.error_deg, 4), "error_px": round(self.error_px, 3),
            "apparent_size_px": round(self.apparent_size_px, 1),
            "ambiguity": round(min(self.ambiguity, 1e6), 2), "frames": self.frames,
            "spread_deg": round(self.spread_deg, 3), "levelled": self.levelled,
        }


# -- images -------------------------------------------------------------------------------
def linear_luminance(image: np.ndarray) -> np.ndarray:
    """(H, W) float32 luminance, linear in light: 8/16-bit input is decoded as sRGB, float
    input is taken as linear."""
    img = np.asarray(image)
    if img.dtype.kind not in "fu" or (img.dtype.kind == "u" and img.itemsize > 2):
        raise InputError(f"expected an 8-bit, 16-bit or float image, got {img.dtype}")
    if img.ndim == 3:
        gray = (img[..., :3].astype(np.float32) @ np.float32([0.2126, 0.7152, 0.0722])
                if img.shape[2] >= 3 else img[..., 0].astype(np.float32))
    else:
        gray = img.astype(np.float32)
    if img.dtype.kind == "f":
        return np.nan_to_num(gray, nan=0.0, posinf=0.0, neginf=0.0)
    c = gray / np.float32(255.0 if img.itemsize == 1 else 65535.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


def display_u8(linear: np.ndarray) -> np.ndarray:
    """An 8-bit, sRGB-like view of linear light for the detectors, scaled to its own range."""
    seen = linear[linear > 0]
    top = float(np.percentile(seen, 99.5)) if seen.size else 1.0
    v = np.clip(linear / max(top, 1e-12), 0, 1) ** (1 / 2.2)
    return (v * 255 + 0.5).astype(np.uint8)


# -- pose on the sphere ------------------------------------------------------------------
def _tangent_residuals(R, t, obj, rays, basis):
    p = obj @ R.T + t
    u = p / np.linalg.norm(p, axis=1, keepdims=True)
    return np.einsum("nij,nj->ni", basis, u - rays).ravel()


def _tangent_bases(rays):
    out = []
    for r in rays:
        a = np.array([1.0, 0, 0]) if abs(r[0]) < 0.9 else np.array([0, 1.0, 0])
        e1 = np.cross(r, a)
        e1 /= np.linalg.norm(e1)
        out.append([e1, np.cross(r, e1)])
    return np.array(out)


def refine_on_sphere(R, t, obj, rays, iterations: int = 30):
    """Levenberg-Marquardt on the angles between predicted corner rays ``normalize(R X + t)``
    and observed unit ``rays``; returns (R, t, RMS angle in radians)."""
    basis = _tangent_bases(rays)
    R, t = np.array(R, float), np.array(t, float)
    res = _tangent_residuals(R, t, obj, rays, basis)
    lam = 1e-3
    scale = max(np.linalg.norm(t), 1e-3)
    for _ in range(iterations):
        J = np.empty((res.size, 6))
        eps = 1e-7
        for k in range(6):
            dx = np.zeros(6)
            dx[k] = eps * (1 if k < 3 else scale)
            Rk = cv2.Rodrigues(dx[:3])[0] @ R
            J[:, k] = (_tangent_residuals(Rk, t + dx[3:], obj, rays, basis) - res) / eps
        A, g = J.T @ J, J.T @ res
        improved = False
        for _ in range(8):
            step = -np.linalg.solve(A + lam * np.diag(np.diag(A) + 1e-18), g)
            step[3:] *= scale
            Rn, tn = cv2.Rodrigues(step[:3])[0] @ R, t + step[3:]
            rn = _tangent_residuals(Rn, tn, obj, rays, basis)
            if rn @ rn < res @ res:
                R, t, res, improved = Rn, tn, rn, True
                lam = max(lam / 10, 1e-9)
                break
            lam *= 10
        if not improved or np.linalg.norm(step) < 1e-12:
            break
    u, _, vt = np.linalg.svd(R)
    return u @ vt, t, float(np.sqrt(res @ res / len(rays)))


def _planar_poses(corners, view: PinholeView, size: float):
    """Both IPPE poses of a square of side ``size`` seen at view pixels ``corners``, in the
    world frame (OpenCV camera axes are the view's columns)."""
    obj = (OBJECT_CORNERS * size).astype(np.float64)
    try:
        _, rvecs, tvecs, _ = cv2.solvePnPGeneric(obj, corners.reshape(-1, 1, 2).astype(np.float64),
                                                 view.K, None, flags=cv2.SOLVEPNP_IPPE)
    except cv2.error:
        return []
    return [(view.rotation @ cv2.Rodrigues(r)[0], view.rotation @ np.ravel(t))
            for r, t in zip(rvecs, tvecs)]


def pose_from_rays(rays, size: float, view: PinholeView, corners):
    """(R, t, error rad, ambiguity) of a square of side ``size`` whose corners are seen along
    ``rays`` (4, 3); ``view``/``corners`` seed IPPE. None if no pose puts it in front."""
    obj = OBJECT_CORNERS * size
    fits = []
    for R, t in _planar_poses(corners, view, size):
        R, t, err = refine_on_sphere(R, t, obj, rays)
        if np.all((obj @ R.T + t) @ rays.T > 0) and R[:, 2] @ t < 0:  # in front, face seen
            fits.append((err, R, t))
    if not fits:
        return None
    fits.sort(key=lambda f: f[0])
    err, R, t = fits[0]
    # Both seeds may refine to the same pose: then nothing was ambiguous.
    others = [f[0] for f in fits[1:] if np.linalg.norm(f[1] - R) > math.radians(0.5)]
    ambiguity = others[0] / max(err, 1e-12) if others else math.inf
    return R, t, err, ambiguity


# -- search and measurement -------------------------------------------------------------
def native_scale(projection: Projection) -> float:
    """The projection's pixels per radian where it is sharpest (a lens axis, the horizon)."""
    if isinstance(projection, Fisheye):
        d = projection.lens.frame[0]
    elif isinstance(projection, DualFisheye):
        d = projection.lenses[0].frame[0]
    else:
        d = np.array([0.0, 0.0, -1.0]) if projection.name != "cubemap" else np.array([1.0, 0, 0])
    return local_scale(projection, d)


def _search(lum, projection, spec, scale):
    """Candidate (centre ray, angular side in rad, id) of every detection in the search views."""
    focal = min(scale, SEARCH_MAX_SCALE)
    size = int(2 * focal * math.tan(SEARCH_HALF_FOV)) | 1
    found = []
    for axis in SEARCH_AXES:
        view = PinholeView(look_rotation(axis), focal, size)
        lin = render_view(lum, projection, view)
        if not np.any(lin > 0):
            continue
        for det in detect(display_u8(lin), spec, decode=False):
            rays = view.rays(det.corners)
            centre = rays.sum(0) / np.linalg.norm(rays.sum(0))
            side = float(np.mean([math.acos(np.clip(rays[i] @ rays[(i + 1) % 4], -1, 1))
                                  for i in range(4)]))
            off = math.acos(np.clip(centre @ view.rotation[:, 2], -1, 1))
            dup = next((c for c in found if c[3] == det.marker_id
                        and math.acos(np.clip(c[0] @ centre, -1, 1)) < side), None)
            if dup is None:
                found.append([centre, side, off, det.marker_id])
            elif off < dup[2]:
                dup[:3] = [centre, side, off]
    return [(c[0], c[1], c[3]) for c in found]


def _measure(lum, projection, spec, scale, centre, side, marker_id, size):
    """The pose of the marker seen along ``centre`` (angular side ``side``), or None.

    Detected in a view at the panorama's own scale (the detector's thresholds expect sharp
    cells), aligned in a finer one (the ECC homography wants smooth edges to slide on)."""
    for zoom in (1.0, 1.5, 2.0, 3.0):    # small, tilted cells are found a little enlarged
        coarse = PinholeView(look_rotation(centre), zoom * scale,
                             max(int(4 * zoom * side * scale), 96) | 1)
        dets = [d for d in detect(display_u8(render_view(lum, projection, coarse)), spec, True)
                if marker_id is None or d.marker_id == marker_id]
        if dets:
            break
    else:
        return None
    det = min(dets, key=lambda d: np.linalg.norm(d.corners.mean(0) - coarse.centre))
    rays = coarse.rays(det.corners)
    centre = rays.sum(0) / np.linalg.norm(rays.sum(0))
    side = float(np.mean([math.acos(np.clip(rays[i] @ rays[(i + 1) % 4], -1, 1)) for i in range(4)]))
    focal = float(np.clip(MEASURE_SIDE_PX / max(side, 1e-6), scale, MEASURE_UPSAMPLE * scale))
    view = PinholeView(look_rotation(centre), focal, int(2.6 * side * focal) | 1)
    lin = render_view(lum, projection, view, cv2.INTER_CUBIC)
    det.corners = view.project(rays)
    corners = refine_corners(lin, det, blur_px=0.5 * focal / scale)
    if corners is not None:
        rays = view.rays(corners)
    else:
        corners = det.corners
    fit = pose_from_rays(rays, size, view, corners)
    if fit is None:
        return None
    R, t, err, ambiguity = fit
    px_per_rad = local_scale(projection, t / np.linalg.norm(t))
    side_rad = float(np.mean([math.acos(np.clip(rays[i] @ rays[(i + 1) % 4], -1, 1))
                              for i in range(4)]))
    return MarkerPose(str(spec), det.marker_id, R, t, math.degrees(err), err * px_per_rad,
                      side_rad * px_per_rad, ambiguity, rays)


def find_marker(image, marker: str | MarkerSpec = "aruco:DICT_4X4_50:7", marker_size: float = 0.2,
                projection: str | Projection = "equirect", *, hint=None,
                **projection_options) -> MarkerPose:
    """The pose of a printed marker in a panorama or fisheye frame (see the module's doc).

    ``image``: (H, W[, 3]) uint8/uint16 (sRGB) or float (linear); ``marker``:
    ``aruco:DICT_4X4_50:7`` or ``qr[:TEXT]``; ``marker_size``: the printed side in metres
    (ArUco: the black square; QR: the symbol without its quiet zone); ``projection`` and
    its options as the engine takes them (or a built :class:`Projection`); ``hint``: a
    direction (3,) where the marker was last seen, measured first. Raises
    :class:`MarkerNotFound` (an :class:`InputError`) when no such marker is seen."""
    spec = parse_marker(marker) if not isinstance(marker, MarkerSpec) else marker
    size = check_marker_size(marker_size)
    img = np.asarray(image)
    if img.ndim not in (2, 3) or img.shape[0] < 8 or img.shape[1] < 8:
        raise InputError(f"expected an (H, W) or (H, W, 3) image, got shape {img.shape}")
    if not isinstance(projection, Projection):
        try:
            projection = make_projection(projection, img.shape[1], img.shape[0], **projection_options)
        except ProjectionError as exc:
            raise InputError(str(exc)) from None
    lum = linear_luminance(img)
    scale = native_scale(projection)
    if hint is not None:
        h = np.asarray(hint, float)
        pose = _measure(lum, projection, spec, scale, h / np.linalg.norm(h),
                        math.radians(5), spec.marker_id, size)
        if pose is not None:
            return pose
    poses = [p for c, side, mid in _search(lum, projection, spec, scale)
             if (p := _measure(lum, projection, spec, scale, c, side, mid, size)) is not None]
    if not poses:
        raise MarkerNotFound(f"no {spec} marker found in the {img.shape[1]}×{img.shape[0]} "
                             f"{projection.name} image")
    return max(poses, key=lambda p: p.apparent_size_px)


# -- several frames, gravity ----------------------------------------------------------------
def average_poses(poses: list[MarkerPose]) -> MarkerPose:
    """One pose from several frames' measurements of the same marker: the chordal mean of the
    rotations (SVD of their sum), the mean position; ``spread_deg`` is the largest angle of
    one frame's rotation from the mean."""
    if not poses:
        raise MarkerNotFound("no frame showed the marker")
    u, _, vt = np.linalg.svd(sum(p.rotation for p in poses))
    R = u @ np.diag([1, 1, np.linalg.det(u @ vt)]) @ vt
    spread = max(math.degrees(math.acos(np.clip((np.trace(R.T @ p.rotation) - 1) / 2, -1, 1)))
                 for p in poses)
    first = poses[0]
    return replace(first, rotation=R, position=np.mean([p.position for p in poses], axis=0),
                   error_deg=float(np.mean([p.error_deg for p in poses])),
                   error_px=float(np.mean([p.error_px for p in poses])),
                   apparent_size_px=float(np.mean([p.apparent_size_px for p in poses])),
                   ambiguity=float(min(p.ambiguity for p in poses)), frames=len(poses),
                   spread_deg=spread)


def levelling_rotation(pitch_deg: float, roll_deg: float) -> np.ndarray:
    """R_level←camera for a camera whose panorama centre is pitched ``pitch_deg`` above the
    horizon and rolled ``roll_deg`` (XMP GPano:PosePitchDegrees, PoseRollDegrees; the contract's
    --rotate convention, docs/contract.md §1: R = R_pitch R_roll)."""
    from ..geometry.sh import rotation_from_euler
    return rotation_from_euler(0.0, float(pitch_deg), float(roll_deg))


def levelled(pose: MarkerPose, level: np.ndarray) -> MarkerPose:
    """The pose in the levelled frame: R_level · R, R_level · t."""
    level = np.asarray(level, float)
    return replace(pose, rotation=level @ pose.rotation, position=level @ pose.position,
                   rays=pose.rays @ level.T, levelled=True)
