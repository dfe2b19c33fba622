"""Pose-tagged views of a headset's camera: nerfstudio's ``transforms.json``.

What capture apps already export (nerfstudio, Polycam, Record3D, instant-ngp): a JSON
object with ``camera_model`` (``PINHOLE``, or ``OPENCV`` with ``k1 k2 p1 p2``), the
intrinsics ``fl_x fl_y cx cy w h`` at the top level or per frame, and ``frames``, each with
``file_path`` (relative to the JSON's folder) and ``transform_matrix``: camera-to-world 4×4
with OpenGL camera axes (the camera looks down −Z, +Y up, +X right). Optional per frame:
``time`` (s), ``exposure_s``, ``gain`` or ``iso``, ``cct_k``. The world is the frame of
docs/contract.md §1; the translation is kept but unused by the fit (the sphere is at
infinity). Where the headset's world is not the sphere's, a registration takes it there
(:func:`registration_rotation`, :func:`registered`).

Every bad record is refused with one :class:`~provider.core.errors.InputError` line naming
the frame: a matrix that is not a rotation, intrinsics outside the frame, a missing file,
an unknown camera model.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError

CAMERA_MODELS = ("PINHOLE", "OPENCV")
INTRINSICS = ("fl_x", "fl_y", "cx", "cy", "w", "h")
DISTORTION = ("k1", "k2", "p1", "p2")
#: How far R·Rᵀ may be from the identity, and det R from 1 (float32 exports round to ~1e-7;
#: a scaled or sheared matrix is off by far more).
ROTATION_TOLERANCE = 1e-3


@dataclass
class PassthroughView:
    """One frame: its image, pose and intrinsics, and what it says of its exposure."""

    file_path: str                  # as written in transforms.json
    path: str                       # resolved against the JSON's folder
    rotation: np.ndarray            # (3, 3) camera-to-world, OpenGL camera axes
    position: np.ndarray            # (3,) metres (unused by the fit: the sphere is far)
    fl_x: float
    fl_y: float
    cx: float
    cy: float
    w: int
    h: int
    camera_model: str = "PINHOLE"
    distortion: tuple = (0.0, 0.0, 0.0, 0.0)
    time: float | None = None
    exposure_s: float | None = None
    gain: float | None = None       # linear sensor gain (iso / 100 when only iso is given)
    cct_k: float | None = None
    extra: dict = field(default_factory=dict)

    def directions(self, px, py) -> np.ndarray:
        """World directions (..., 3) the pixels at continuous image coordinates ``(px,
        py)`` look along (pixel ``(i, j)`` covers ``[i, i+1) × [j, j+1)``, its centre at
        ``i + 0.5``; OpenCV's distortion undone first for ``OPENCV``)."""
        px = np.asarray(px, np.float64)
        py = np.asarray(py, np.float64)
        if self.camera_model == "OPENCV" and any(self.distortion):
            import cv2
            K = np.array([[self.fl_x, 0, self.cx], [0, self.fl_y, self.cy], [0, 0, 1.0]])
            pts = np.stack([px.ravel(), py.ravel()], -1).reshape(-1, 1, 2)
            und = cv2.undistortPoints(pts, K, np.array(self.distortion, np.float64))
            x = und[:, 0, 0].reshape(px.shape)
            y = und[:, 0, 1].reshape(py.shape)
        else:
            x = (px - self.cx) / self.fl_x
            y = (py - self.cy) / self.fl_y
        # image right = camera +X, image down = camera −Y, forward = camera −Z (OpenGL)
        cam = np.stack([x, -y, -np.ones_like(x)], -1)
        cam /= np.linalg.norm(cam, axis=-1, keepdims=True)
        return cam @ self.rotation.T

    def exposure_product(self) -> float | None:
        """t · gain (gain 1 when not given), or None without an exposure time."""
        if self.exposure_s is None:
            return None
        return self.exposure_s * (self.gain if self.gain is not None else 1.0)


def _number(record: dict, key: str, where: str, *, positive=False, required=True):
    if key not in record or record[key] is None:
        if required:
            raise InputError(f"{where}: {key} is missing")
        return None
    v = record[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(f"{where}: {key} must be a finite number, got {v!r}")
    if positive and v <= 0:
        raise InputError(f"{where}: {key} must be positive, got {v!r}")
    return float(v)


def _rotation(matrix, where: str, name: str = "transform_matrix",
              hint: str = ": camera-to-world with OpenGL axes, no scale"):
    try:
        m = np.asarray(matrix, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{where}: transform_matrix must be a 4×4 (or 3×4) array of "
                         "numbers") from None
    if m.shape not in ((4, 4), (3, 4)) or not np.isfinite(m).all():
        raise InputError(f"{where}: transform_matrix must be a 4×4 (or 3×4) array of finite "
                         f"numbers, got shape {m.shape}")
    if m.shape == (4, 4) and not np.allclose(m[3], (0, 0, 0, 1), atol=1e-6):
        raise InputError(f"{where}: transform_matrix's last row must be 0 0 0 1, got "
                         f"{m[3].tolist()}")
    r = m[:3, :3]
    err = float(np.abs(r @ r.T - np.eye(3)).max())
    det = float(np.linalg.det(r))
    if err > ROTATION_TOLERANCE or abs(det - 1) > ROTATION_TOLERANCE:
        raise InputError(f"{where}: {name}'s 3×3 part is not a rotation "
                         f"(|R·Rᵀ − I| = {err:.3g}, det = {det:.4g}){hint}")
    # re-orthonormalised (exports round to float32)
    u, _, vt = np.linalg.svd(r)
    return u @ vt, m[:3, 3].copy()


def _intrinsics(record: dict, top: dict, where: str) -> dict:
    out = {}
    for key in INTRINSICS:
        src = record if key in record else top
        out[key] = _number(src, key, where, positive=key in ("fl_x", "fl_y", "w", "h"))
    for key in ("w", "h"):
        if out[key] != int(out[key]):
            raise InputError(f"{where}: {key} must be a whole number of pixels, got "
                             f"{out[key]!r}")
        out[key] = int(out[key])
    if not (0 < out["cx"] < out["w"] and 0 < out["cy"] < out["h"]):
        raise InputError(f"{where}: the principal point ({out['cx']:g}, {out['cy']:g}) is "
                         f"outside the {out['w']}×{out['h']} frame")
    return out


def _camera_model(record: dict, top: dict, where: str) -> tuple[str, tuple]:
    model = record.get("camera_model", top.get("camera_model", "PINHOLE"))
    if model not in CAMERA_MODELS:
        raise InputError(f"{where}: camera_model {model!r} is not supported (one of "
                         f"{', '.join(CAMERA_MODELS)}; OPENCV with k1 k2 p1 p2)")
    if model == "PINHOLE":
        return model, (0.0, 0.0, 0.0, 0.0)
    dist = []
    for key in DISTORTION:
        src = record if key in record else top
        v = _number(src, key, where, required=False)
        dist.append(0.0 if v is None else v)
    return model, tuple(dist)


def read_json(path):
    """The JSON value of the file at ``path`` (a transforms.json, a registration);
    :class:`InputError` in one line for a missing, unreadable or malformed file."""
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except FileNotFoundError:
        raise InputError(f"no such file: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read {path}: {getattr(exc, 'strerror', None) or exc}") \
            from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{path} is not JSON ({exc.msg}, line {exc.lineno})") from None


def read_transforms(path, *, check_files: bool = True) -> list[PassthroughView]:
    """The views of a ``transforms.json`` (module doc), in order; :class:`InputError` (one
    line naming the frame) for anything that cannot be used."""
    path = os.fspath(path)
    if os.path.isdir(path):
        path = os.path.join(path, "transforms.json")
    top = read_json(path)
    if not isinstance(top, dict):
        raise InputError(f"{path}: expected a JSON object with 'frames' (nerfstudio's "
                         "transforms.json)")
    frames = top.get("frames")
    if not isinstance(frames, list) or not frames:
        raise InputError(f"{path}: 'frames' must be a non-empty list of views")
    folder = os.path.dirname(os.path.abspath(path))
    views = []
    for i, rec in enumerate(frames):
        where = f"{path}: frame {i}"
        if not isinstance(rec, dict):
            raise InputError(f"{where} is not a JSON object")
        fp = rec.get("file_path")
        if not isinstance(fp, str) or not fp:
            raise InputError(f"{where}: file_path is missing")
        where = f"{path}: frame {i} ({fp})"
        full = fp if os.path.isabs(fp) else os.path.join(folder, fp)
        if check_files and not os.path.isfile(full):
            raise InputError(f"{where}: no such file: {full}")
        if "transform_matrix" not in rec:
            raise InputError(f"{where}: transform_matrix is missing")
        rot, pos = _rotation(rec["transform_matrix"], where)
        intr = _intrinsics(rec, top, where)
        model, dist = _camera_model(rec, top, where)
        gain = _number(rec, "gain", where, positive=True, required=False)
        iso = _number(rec, "iso", where, positive=True, required=False)
        if gain is None and iso is not None:
            gain = iso / 100.0
        views.append(PassthroughView(
            file_path=fp, path=full, rotation=rot, position=pos, camera_model=model,
            distortion=dist,
            time=_number(rec, "time", where, required=False),
            exposure_s=_number(rec, "exposure_s", where, positive=True, required=False),
            gain=gain, cct_k=_number(rec, "cct_k", where, positive=True, required=False),
            **intr))
    return views


def _rotation_field(reg: dict, key: str, where: str) -> np.ndarray:
    v = reg.get(key)
    try:
        m = np.asarray(v, dtype=np.float64).reshape(3, 3)
    except (TypeError, ValueError):
        raise InputError(f"{where}: {key} must be 9 numbers (a rotation, row-major), got "
                         f"{v!r:.60}") from None
    full = np.eye(4)
    full[:3, :3] = m
    return _rotation(full, where, key, "")[0]


def registration_rotation(reg, where: str = "the registration") -> np.ndarray:
    """R_sphere←world, the rotation that takes the headset's world into the sphere's frame,
    from a registration object: either ``world_to_sphere`` (9 numbers, row-major), or what
    ``shlight register`` prints (``rotation``: R_camera←marker, docs/contract.md §13) with
    ``marker_in_world`` (R_world←marker, the same marker's rotation as the headset's
    tracker reports it, OpenCV's marker axes): R_sphere←world = R_camera←marker ·
    R_world←markerᵀ."""
    if not isinstance(reg, dict):
        raise InputError(f"{where} must be a JSON object")
    if "world_to_sphere" in reg:
        return _rotation_field(reg, "world_to_sphere", where)
    if "rotation" in reg and "marker_in_world" in reg:
        r_cm = _rotation_field(reg, "rotation", where)
        r_wm = _rotation_field(reg, "marker_in_world", where)
        return r_cm @ r_wm.T
    raise InputError(f"{where} needs world_to_sphere (9 numbers), or shlight register's "
                     "rotation with marker_in_world (the marker's rotation in the headset's "
                     "world, 9 numbers, from its tracker)")


def registered(views: list[PassthroughView], r_sphere_world: np.ndarray) -> list:
    """The views with their poses taken into the sphere's frame."""
    from dataclasses import replace
    r = np.asarray(r_sphere_world, np.float64)
    return [replace(v, rotation=r @ v.rotation, position=r @ v.position) for v in views]


def read_view_image(view: PassthroughView, max_pixels: int = 0) -> np.ndarray:
    """The view's 8-bit RGB codes (H, W, 3) uint8, checked against its ``w`` × ``h``."""
    from ..radiometry.images import read_image
    img = read_image(view.path, max_pixels)
    if img.dtype != np.uint8 or img.ndim != 3 or img.shape[2] != 3:
        raise InputError(f"{view.path}: a passthrough view must be an 8-bit RGB image (JPEG "
                         f"or PNG), got {img.dtype} {img.shape}")
    if img.shape[:2] != (view.h, view.w):
        raise InputError(f"{view.path} is {img.shape[1]}×{img.shape[0]} but its record says "
                         f"w {view.w}, h {view.h}")
    return img


def view_from_record(rec, where: str = "view", file_path: str = "") -> PassthroughView:
    """One view from a record in a frame's own words (a live headset's message: the
    intrinsics, ``transform_matrix`` as a 4×4, 3×4 or 16 numbers row-major, the optional
    fields of :func:`read_transforms`), checked as :func:`read_transforms` checks a frame;
    :class:`InputError` (one line) for anything that cannot be used."""
    if not isinstance(rec, dict):
        raise InputError(f"{where} is not a JSON object")
    if "transform_matrix" not in rec:
        raise InputError(f"{where}: transform_matrix is missing")
    matrix = rec["transform_matrix"]
    if isinstance(matrix, list) and len(matrix) == 16 and not any(
            isinstance(v, list) for v in matrix):
        matrix = [matrix[i:i + 4] for i in range(0, 16, 4)]
    rot, pos = _rotation(matrix, where)
    intr = _intrinsics(rec, {}, where)
    model, dist = _camera_model(rec, {}, where)
    gain = _number(rec, "gain", where, positive=True, required=False)
    iso = _number(rec, "iso", where, positive=True, required=False)
    if gain is None and iso is not None:
        gain = iso / 100.0
    return PassthroughView(
        file_path=file_path, path="", rotation=rot, position=pos, camera_model=model,
        distortion=dist, time=_number(rec, "time", where, required=False),
        exposure_s=_number(rec, "exposure_s", where, positive=True, required=False),
        gain=gain, cct_k=_number(rec, "cct_k", where, positive=True, required=False), **intr)
