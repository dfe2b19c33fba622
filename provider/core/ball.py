"""Finding a mirror ball in a frame: OpenCV's circle detection, refined on the ball's edge
(numpy + OpenCV, no I/O).

Coordinates are the projections' (pixel (i, j) covers [i, i+1) × [j, j+1), y down), so a
located circle is the ``center``/``radius`` that :class:`~provider.core.projections_probe.
MirrorBall` takes as is.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from .errors import InputError

#: Frames are searched at most this many pixels wide (Hough is costly); the edge is then
#: refined at full resolution.
SEARCH_SIZE = 800
#: Edge samples around the circle when refining it.
EDGE_RAYS = 720


@dataclass
class BallCircle:
    """A ball in a frame: centre ``x``, ``y`` and ``radius`` in pixels; ``edge_rms``: RMS
    distance (px) of the edge points kept from the fitted circle; ``edge_points``: how many
    of the :data:`EDGE_RAYS` rays found an edge that fits."""

    x: float
    y: float
    radius: float
    edge_rms: float = float("nan")
    edge_points: int = 0

    def as_dict(self) -> dict:
        return {"x": round(self.x, 3), "y": round(self.y, 3), "radius": round(self.radius, 3),
                "edge_rms_px": round(self.edge_rms, 3), "edge_points": self.edge_points,
                "ball": f"{self.x:.2f},{self.y:.2f},{self.radius:.2f}"}


def grey8(image: np.ndarray) -> np.ndarray:
    """An 8-bit grey picture of any frame the engine takes (float frames: scaled to their
    99.5th percentile and square-rooted, so that a bright window does not hide the edge)."""
    img = np.asarray(image)
    if img.ndim == 3 and img.shape[2] >= 3:
        img = cv2.cvtColor(np.ascontiguousarray(img[..., :3]).astype(np.float32),
                           cv2.COLOR_RGB2GRAY)
    elif img.ndim == 3:
        img = img[..., 0]
    img = img.astype(np.float32)
    if np.asarray(image).dtype == np.uint8:
        return np.clip(img, 0, 255).astype(np.uint8)
    if np.asarray(image).dtype == np.uint16:
        return np.clip(img / 257.0, 0, 255).astype(np.uint8)
    img = np.where(np.isfinite(img), np.maximum(img, 0), 0)
    top = float(np.percentile(img, 99.5)) or float(img.max()) or 1.0
    return (np.sqrt(np.clip(img / top, 0, 1)) * 255).astype(np.uint8)


def locate_ball(image: np.ndarray, *, min_radius_fraction: float = 0.05) -> BallCircle:
    """The ball in ``image`` (H×W, or H×W×C in RGB order, any dtype the engine takes):
    the strongest circle of :func:`cv2.HoughCircles` with a radius from
    ``min_radius_fraction`` to 0.55 of the frame's smaller side, then refined on the edge
    (the steepest step along :data:`EDGE_RAYS` rays, a least-squares circle without the
    outliers). Raises :class:`InputError` when no circle is found."""
    grey = grey8(image)
    h, w = grey.shape[:2]
    if min(h, w) < 32:
        raise InputError(f"a {w}×{h} frame is too small to find a ball in")
    scale = min(1.0, SEARCH_SIZE / max(h, w))
    small = grey if scale == 1.0 else cv2.resize(grey, (round(w * scale), round(h * scale)),
                                                 interpolation=cv2.INTER_AREA)
    small = cv2.GaussianBlur(small, (0, 0), 1.5)
    side = min(small.shape[:2])
    found = None
    for votes in (80, 60, 45, 30, 20):
        found = cv2.HoughCircles(small, cv2.HOUGH_GRADIENT, dp=1, minDist=side / 4,
                                 param1=100, param2=votes,
                                 minRadius=max(4, int(side * min_radius_fraction)),
                                 maxRadius=int(side * 0.55))
        if found is not None:
            break
    if found is None:
        raise InputError(f"no ball found in the {w}×{h} frame (no circle of radius "
                         f"{min_radius_fraction:.0%} to 55 % of its smaller side): "
                         "give it with --ball X,Y,R")
    x, y, r = (float(v) / scale for v in found[0][0][:3])
    circle = BallCircle(x + 0.5, y + 0.5, r)   # OpenCV's pixel centres are integers
    for _ in range(3):
        circle = refine_edge(grey, circle)
    return circle


def refine_edge(grey: np.ndarray, circle: BallCircle, *, search: float = 0.12) -> BallCircle:
    """``circle`` fitted to the steepest step of ``grey`` (8-bit) along rays from its centre,
    within ``search`` (a fraction of the radius) of its rim: sub-pixel (a parabola through
    the peak), and a least-squares circle through the edge points, dropping those farther
    than 2.5 median deviations (at least 0.5 px)."""
    img = cv2.GaussianBlur(grey.astype(np.float32), (0, 0), 1.0)
    h, w = img.shape[:2]
    angles = np.linspace(0, 2 * np.pi, EDGE_RAYS, endpoint=False)
    step = 0.25
    radii = np.arange(circle.radius * (1 - search), circle.radius * (1 + search), step)
    if radii.size < 5:
        return circle
    cx, cy = circle.x - 0.5, circle.y - 0.5          # OpenCV's sample coordinates
    X = (cx + np.cos(angles)[:, None] * radii[None]).astype(np.float32)
    Y = (cy + np.sin(angles)[:, None] * radii[None]).astype(np.float32)
    inside = ((X >= 1) & (X <= w - 2) & (Y >= 1) & (Y <= h - 2)).all(axis=1)
    profile = cv2.remap(img, X, Y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    slope = np.abs(np.diff(profile, axis=1))
    k = np.clip(np.argmax(slope, axis=1), 1, slope.shape[1] - 2)
    rows = np.arange(len(angles))
    a, b, c = slope[rows, k - 1], slope[rows, k], slope[rows, k + 1]
    denom = a - 2 * b + c
    offset = np.where(denom < 0, 0.5 * (a - c) / np.where(denom < 0, denom, -1), 0.0)
    rho = radii[0] + (k + 0.5 + np.clip(offset, -1, 1)) * step
    strong = inside & (b > max(2.0, 0.25 * float(np.median(b[inside])) if inside.any() else 2.0))
    ex, ey = cx + np.cos(angles) * rho, cy + np.sin(angles) * rho
    keep = strong
    fit = None
    for _ in range(3):
        if keep.sum() < 12:
            break
        fit = _fit_circle(ex[keep], ey[keep])
        dev = np.abs(np.hypot(ex - fit[0], ey - fit[1]) - fit[2])
        limit = max(0.5, 2.5 * float(np.median(dev[keep])))
        keep = strong & (dev <= limit)
    if fit is None or keep.sum() < 12:
        return circle
    dev = np.hypot(ex[keep] - fit[0], ey[keep] - fit[1]) - fit[2]
    return BallCircle(fit[0] + 0.5, fit[1] + 0.5, fit[2], float(np.sqrt(np.mean(dev ** 2))),
                      int(keep.sum()))


def _fit_circle(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Least-squares (Kåsa) circle through points: centre and radius."""
    A = np.stack([2 * x, 2 * y, np.ones_like(x)], axis=1)
    sol, *_ = np.linalg.lstsq(A, x * x + y * y, rcond=None)
    return float(sol[0]), float(sol[1]), float(math.sqrt(max(sol[2] + sol[0] ** 2 + sol[1] ** 2, 0)))



def resolve_ball(options: dict, frame: np.ndarray) -> tuple[dict, BallCircle | None]:
    """Engine options with ``ball="auto"`` replaced by the ``center`` and ``radius`` of the
    ball located in ``frame`` (and that circle); other options come back unchanged (None)."""
    if options.get("ball") != "auto":
        return options, None
    circle = locate_ball(frame)
    out = {k: v for k, v in options.items() if k != "ball"}
    out.update(center=(circle.x, circle.y), radius=circle.radius)
    return out, circle
