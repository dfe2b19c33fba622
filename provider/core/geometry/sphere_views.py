"""Pinhole views rendered from any projection the engine reads (no I/O).

A registration marker is a flat square; in a panorama it is curved, but in a pinhole view it
is a quadrilateral again, the image of the printed marker under a homography, which is what
OpenCV's marker detectors and :func:`cv2.findTransformECC` expect. This module gives each
projection of :mod:`.projections` the inverse of its direction map (world direction ->
continuous pixel coordinates, pixel ``(i, j)`` covering ``[i, i+1) × [j, j+1)``) and renders
pinhole views with :func:`cv2.remap`.

A view is a :class:`PinholeView`: a rotation ``V`` whose columns are the view's image right,
image down and optical axis in the world frame of docs/contract.md §1 (OpenCV's camera axes
x, y, z), a focal length in view pixels and a square size. A view pixel centre ``(c, r)``
(OpenCV's integer-centre convention) looks along ``V · normalize((c − k, r − k, f))`` with
``k = (size − 1) / 2``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from .projections import CubeMap, DualFisheye, Equirect, Fisheye, FisheyeLens, Projection


def _lens_to_pixel(lens: FisheyeLens, d: np.ndarray):
    """Continuous pixel coordinates of world directions ``d`` (..., 3) seen by one lens, and
    the angle θ from its axis (rad)."""
    f, r, u = lens.frame
    cos_t = np.clip(d @ f, -1.0, 1.0)
    theta = np.arccos(cos_t)
    psi = np.arctan2(d @ u, d @ r)
    if lens.K is None:
        rad = lens.radius_of(theta)
        return lens.cx + rad * np.cos(psi), lens.cy - rad * np.sin(psi), theta
    # Kannala-Brandt (cv2.fisheye): normalised undistorted point (tanθ cosψ, −tanθ sinψ).
    tan_t = np.tan(np.minimum(theta, math.radians(89.9)))
    pts = np.stack([tan_t * np.cos(psi), -tan_t * np.sin(psi)], -1).reshape(-1, 1, 2)
    out = cv2.fisheye.distortPoints(pts.astype(np.float64), lens.K, lens.D).reshape(d.shape[:-1] + (2,))
    return out[..., 0], out[..., 1], theta


def direction_to_pixel(projection: Projection, d: np.ndarray):
    """Continuous pixel coordinates ``(px, py)`` where ``projection`` sees the unit world
    directions ``d`` (..., 3), and a mask of the directions it sees at all. The inverse of
    ``projection.pixel_to_direction`` (a dual fisheye: the lens whose axis is nearer)."""
    d = np.asarray(d, np.float64)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    if isinstance(projection, Equirect):
        theta = np.arccos(np.clip(y, -1.0, 1.0))
        phi = np.arctan2(x, -z)
        px = (phi / (2 * math.pi) + 0.5) * projection.width
        return px, theta / math.pi * projection.height, np.ones(x.shape, bool)
    if isinstance(projection, Fisheye):
        px, py, theta = _lens_to_pixel(projection.lens, d)
        return px, py, theta <= projection.lens.theta_max
    if isinstance(projection, DualFisheye):
        a, b = projection.lenses
        pa, qa, ta = _lens_to_pixel(a, d)
        pb, qb, tb = _lens_to_pixel(b, d)
        use_a = ta <= tb
        theta = np.where(use_a, ta, tb)
        lens_max = np.where(use_a, a.theta_max, b.theta_max)
        return np.where(use_a, pa, pb), np.where(use_a, qa, qb), theta <= lens_max
    if isinstance(projection, CubeMap):
        n = projection.face
        ax, ay, az = np.abs(x), np.abs(y), np.abs(z)
        face = np.where((ax >= ay) & (ax >= az), np.where(x > 0, 0, 1),
                        np.where(ay >= az, np.where(y > 0, 2, 3), np.where(z > 0, 4, 5)))
        m = np.maximum(np.maximum(ax, ay), az)
        m = np.where(m > 0, m, 1.0)
        # Inverse of CubeMap.pixel_to_direction's face table, a and b in [-1, 1].
        a = np.select([face == 0, face == 1, face == 2, face == 3, face == 4],
                      [-z, z, x, x, x], -x) / m
        b = np.select([face == 0, face == 1, face == 2, face == 3, face == 4],
                      [-y, -y, z, -z, -y], -y) / m
        px = face * n + (np.clip(a, -1, 1) + 1) / 2 * n
        return px, (np.clip(b, -1, 1) + 1) / 2 * n, np.ones(x.shape, bool)
    raise TypeError(f"no inverse direction map for projection {projection.name!r}")


def look_rotation(forward, up_hint=(0.0, 1.0, 0.0)) -> np.ndarray:
    """A view rotation (columns: image right, image down, optical axis in the world) looking
    along ``forward`` with the world's ``up_hint`` as upright as possible."""
    f = np.asarray(forward, np.float64)
    f = f / np.linalg.norm(f)
    up = np.asarray(up_hint, np.float64)
    if abs(f @ up) > 0.99:
        up = np.array([0.0, 0.0, -1.0]) if abs(f[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    right = np.cross(f, up)
    right /= np.linalg.norm(right)
    down = np.cross(f, right)
    return np.stack([right, down, f], axis=1)


@dataclass
class PinholeView:
    """A square pinhole view: ``rotation`` (columns: right, down, axis in the world),
    ``focal`` (view pixels per unit tangent), ``size`` (pixels)."""

    rotation: np.ndarray
    focal: float
    size: int

    @property
    def centre(self) -> float:
        return (self.size - 1) / 2.0

    @property
    def K(self) -> np.ndarray:
        k = self.centre
        return np.array([[self.focal, 0, k], [0, self.focal, k], [0, 0, 1.0]])

    def rays(self, points: np.ndarray) -> np.ndarray:
        """Unit world directions of view pixel coordinates ``points`` (N, 2)."""
        p = np.asarray(points, np.float64).reshape(-1, 2)
        cam = np.column_stack([(p - self.centre) / self.focal, np.ones(len(p))])
        cam /= np.linalg.norm(cam, axis=1, keepdims=True)
        return cam @ self.rotation.T

    def project(self, directions: np.ndarray) -> np.ndarray:
        """View pixel coordinates (N, 2) of world directions (N, 3) in front of the view."""
        cam = np.asarray(directions, np.float64).reshape(-1, 3) @ self.rotation
        return cam[:, :2] / cam[:, 2:3] * self.focal + self.centre


def render_view(image: np.ndarray, projection: Projection, view: PinholeView,
                interpolation=cv2.INTER_LINEAR) -> np.ndarray:
    """The pinhole ``view`` of ``image`` (H, W) or (H, W, C) seen through ``projection``,
    float32; what the projection does not see is 0."""
    k = np.arange(view.size, dtype=np.float64) - view.centre
    gx, gy = np.meshgrid(k / view.focal, k / view.focal)
    cam = np.stack([gx, gy, np.ones_like(gx)], -1)
    cam /= np.linalg.norm(cam, axis=-1, keepdims=True)
    px, py, seen = direction_to_pixel(projection, cam @ view.rotation.T)
    src = np.asarray(image, np.float32)
    pad = 4
    if isinstance(projection, Equirect):
        # The panorama wraps around in longitude; pad so the seam interpolates across.
        src = cv2.copyMakeBorder(src, pad, pad, pad, pad, cv2.BORDER_WRAP)
        src[:pad], src[-pad:] = src[pad:pad + 1], src[-pad - 1:-pad]
        px = np.mod(px, projection.width)
    else:
        src = cv2.copyMakeBorder(src, pad, pad, pad, pad, cv2.BORDER_REPLICATE)
    map_x = np.where(seen, px - 0.5 + pad, -10).astype(np.float32)
    map_y = np.where(seen, py - 0.5 + pad, -10).astype(np.float32)
    return cv2.remap(src, map_x, map_y, interpolation, borderMode=cv2.BORDER_CONSTANT,
                     borderValue=0)


def local_scale(projection: Projection, direction: np.ndarray) -> float:
    """Pixels per radian of ``projection`` around ``direction`` (geometric mean of its two
    axes): what turns an angle on the sphere into apparent pixels."""
    px, py, _ = direction_to_pixel(projection, np.asarray(direction, np.float64)[None])
    x, y = float(px[0]), float(py[0])
    x = min(max(x, 1.0), projection.width - 1.0)
    y = min(max(y, 1.0), projection.height - 1.0)
    d, _ = projection.pixel_to_direction(np.array([x, x + 0.5, x]), np.array([y, y, y + 0.5]))
    ax = math.acos(min(1.0, float(d[0] @ d[1]) / (np.linalg.norm(d[0]) * np.linalg.norm(d[1]))))
    ay = math.acos(min(1.0, float(d[0] @ d[2]) / (np.linalg.norm(d[0]) * np.linalg.norm(d[2]))))
    return 0.5 / math.sqrt(max(ax * ay, 1e-18))
