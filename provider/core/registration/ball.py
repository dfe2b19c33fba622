"""Finding a mirror ball in a frame: OpenCV's circle detection, refined on the ball's edge
(numpy + OpenCV, no I/O).

Coordinates are the projections' (pixel (i, j) covers [i, i+1) × [j, j+1), y down), so a
located circle is the ``center``/``radius`` that :class:`~provider.core.geometry.projections_probe.
MirrorBall` takes as is.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError

#: Frames are searched at most this many pixels wide (Hough is costly); the edge is then
#: refined at full resolution.
SEARCH_SIZE = 800
#: Circles of the Hough transform refined; the one whose edge most rays agree with wins.
CANDIDATES = 8
#: Edge samples around the circle when refining it.
EDGE_RAYS = 720
#: A circle whose edge fewer rays than this agree with is *weak*: it may be off. On 54 balls
#: rendered into rooms (``shlight bench --sections probes``), every circle more than 1 px off
#: had fewer than half the rays; nearly every right one had more.
WEAK_EDGE_POINTS = EDGE_RAYS // 2
#: How far a ball's circle may run past the frame's edge, as a fraction of its radius (plus
#: a pixel): a ball cut off more than this is no probe, and the circles found so far out in a
#: frame with no ball (a panorama's arches and lamps, refined outward) are not balls.
MAX_OUTSIDE = 0.1


@dataclass
class BallCircle:
    """A ball in a frame: centre ``x``, ``y`` and ``radius`` in pixels; ``edge_rms``: RMS
    distance (px) of the edge points kept from the fitted circle; ``edge_points``: how many
    of the :data:`EDGE_RAYS` rays found an edge that fits; :attr:`weak` when fewer than
    :data:`WEAK_EDGE_POINTS` did."""

    x: float
    y: float
    radius: float
    edge_rms: float = float("nan")
    edge_points: int = 0

    def inside(self, width: int, height: int) -> bool:
        """Whether the circle lies in a ``width`` × ``height`` frame, give or take
        :data:`MAX_OUTSIDE` of its radius: what a ball must do to be a probe."""
        m = MAX_OUTSIDE * self.radius + 1.0
        return (self.radius > 0 and self.x - self.radius >= -m and self.y - self.radius >= -m
                and self.x + self.radius <= width + m and self.y + self.radius <= height + m)

    @property
    def weak(self) -> bool:
        """Whether too few rays agree on this edge to trust it (check it, or give the circle)."""
        return self.edge_points < WEAK_EDGE_POINTS

    def as_dict(self) -> dict:
        return {"x": round(self.x, 3), "y": round(self.y, 3), "radius": round(self.radius, 3),
                "edge_rms_px": round(self.edge_rms, 3), "edge_points": self.edge_points,
                "weak": self.weak, "ball": f"{self.x:.2f},{self.y:.2f},{self.radius:.2f}"}

    def weak_note(self) -> str:
        """What to do about a :attr:`weak` circle, in one sentence."""
        return (f"only {self.edge_points} of {EDGE_RAYS} rays agree on the ball's edge, so "
                f"the circle may be off (a faint rim, a ball against a background like it): "
                f"check it, or measure it and give --ball X,Y,R")


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
    the :data:`CANDIDATES` strongest circles of :func:`cv2.HoughCircles` with a radius from
    ``min_radius_fraction`` to 0.55 of the frame's smaller side, each refined on its edge
    (:func:`refine_edge`); of those that lie in the frame (:meth:`BallCircle.inside`), the
    one with the most rays on its edge wins. Raises :class:`InputError` when no circle is
    found, or none in the frame."""
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
    for votes in (60, 40, 25):      # the first threshold with candidates; they come
        found = cv2.HoughCircles(  # strongest first, and near circles are kept (minDist)
            small, cv2.HOUGH_GRADIENT, dp=1, minDist=max(2.0, side / 40), param1=100,
            param2=votes, minRadius=max(4, int(side * min_radius_fraction)),
            maxRadius=int(side * 0.55))
        if found is not None and len(found[0]) >= CANDIDATES:
            break
    if found is None:
        raise InputError(f"no ball found in the {w}×{h} frame (no circle of radius "
                         f"{min_radius_fraction * 100:g} % to 55 % of its smaller side): "
                         "give it with --ball X,Y,R")
    best = outside = None
    for x, y, r in found[0][:CANDIDATES, :3] / scale:
        circle = BallCircle(float(x) + 0.5, float(y) + 0.5, float(r))  # OpenCV: centres integer
        for _ in range(3):
            circle = refine_edge(grey, circle)
        if not circle.inside(w, h):
            outside = outside or circle
        elif best is None or circle.edge_points > best.edge_points:
            best = circle
    if best is None:
        raise InputError(f"no ball found in the {w}×{h} frame (the circles found run past "
                         f"its edge, e.g. centre {outside.x:.0f}, {outside.y:.0f}, radius "
                         f"{outside.radius:.0f} px): give it with --ball X,Y,R")
    return best


def refine_edge(grey: np.ndarray, circle: BallCircle, *, search: float = 0.12) -> BallCircle:
    """``circle`` fitted to the edge of ``grey`` (8-bit) near its rim: every strong step
    (a local maximum of the slope, at least 0.3 of the steepest on its ray, sub-pixel by a
    parabola) along :data:`EDGE_RAYS` rays within ``search`` (a fraction of the radius) of
    the rim is a candidate; of the circles that many rays agree with (within 0.75 px, at
    least half the best support, sampled consensus), the outermost is refitted by least
    squares to one candidate per ray. Steps inside the rim (its reflection squeezes the
    whole sphere behind the ball into a thin ring) and in the background lose."""
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
    peak = np.zeros_like(slope, bool)
    peak[:, 1:-1] = (slope[:, 1:-1] > slope[:, :-2]) & (slope[:, 1:-1] >= slope[:, 2:])
    peak &= (slope >= 0.3 * slope.max(axis=1, keepdims=True)) & (slope > 1.0)
    peak &= inside[:, None]
    ray, k = np.nonzero(peak)
    if ray.size < 12:
        return circle
    a, b, c = slope[ray, k - 1], slope[ray, k], slope[ray, k + 1]
    denom = a - 2 * b + c
    offset = np.where(denom < 0, 0.5 * (a - c) / np.where(denom < 0, denom, -1), 0.0)
    rho = radii[0] + (k + 0.5 + np.clip(offset, -1, 1)) * step
    ex, ey = cx + np.cos(angles[ray]) * rho, cy + np.sin(angles[ray]) * rho
    rng = np.random.default_rng(0)
    fits = []
    for _ in range(300):
        i = rng.choice(ray.size, 3, replace=False)
        if len(set(ray[i])) < 3:
            continue
        fit = _fit_circle(ex[i], ey[i])
        if not 0.8 * circle.radius < fit[2] < 1.2 * circle.radius:
            continue
        near = np.abs(np.hypot(ex - fit[0], ey - fit[1]) - fit[2]) < 0.75
        fits.append((np.unique(ray[near]).size, fit))
    most = max((v for v, _ in fits), default=0)
    if most < 12:
        return circle
    # The rim reflects what lies right behind the ball, so the true edge can be faint and a
    # ring of the reflection just inside it as well supported: of the well-supported circles
    # (half the best support), the outermost is the ball.
    best = max((f for v, f in fits if v >= 0.5 * most), key=lambda f: f[2])
    for _ in range(3):      # least squares on the nearest candidate of each agreeing ray
        dev = np.abs(np.hypot(ex - best[0], ey - best[1]) - best[2])
        order = np.lexsort((dev, ray))
        first = order[np.r_[True, ray[order][1:] != ray[order][:-1]]]
        keep = first[dev[first] < 0.75]
        if keep.size < 12:
            break
        best = _fit_circle(ex[keep], ey[keep])
    dev = np.hypot(ex[keep] - best[0], ey[keep] - best[1]) - best[2]
    return BallCircle(best[0] + 0.5, best[1] + 0.5, best[2], float(np.sqrt(np.mean(dev ** 2))),
                      int(keep.size))


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
