"""The sphere extended by the headset's views: their light, in the sphere's units, where the
360° camera sees nothing (docs/passthrough.md, "Extending the sphere").

A view whose curve, exposure and white balance are known (a fit against the sphere,
:mod:`.fit`, or its overlaps with the other views alone, :mod:`.overlaps`) tells the
radiance of what it looks at:

    L_c = g_c(z_c) / (exposure · wb_c · V(ρ))

for every pixel not clipped. :func:`splat_views` brings each view's pixels to an equirect
panorama (docs/contract.md §1) of a given size: for each panorama pixel inside the view's
frame, OpenCV's ``remap`` reads the view there (bilinear; a view much finer than the
panorama is area-averaged first), and the views that see a pixel are averaged, weighted by
how far their codes are from black and from clipping and by how far the pixel is from
their frame's border (so that the seams between views fade). What it records
(:class:`ViewCoverage`): the radiance, which panorama pixels some view saw, and which were
clipped in every view that saw them, with the light they had at least (the highest clip
level among those views: a lower bound, never a measurement).

:func:`sphere_holes` says where the 360° camera sees nothing (non-finite pixels, regions
of zeros: a projection's unseen region, a masked mount; a user's mask; a cap around the
nadir, where its tripod stands), and :func:`fill_sphere` fills them from the views.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError
from ..geometry.projections import Equirect
from .views import PassthroughView

#: Codes at or above this in any channel are clipped (the fit's shoulder limit: above it
#: the curve is an extrapolation and JPEG ringing moves a clipped 255 down to ~250).
CLIP_CODE = 250
#: Codes below this in every channel weigh least: JPEG noise of one code there is a large
#: fraction of the light.
DARK_CODE = 32
#: The weight a view's pixel keeps at its darkest, and at its frame's very border.
MIN_WEIGHT = 0.02
#: How far into the frame (fraction of its shorter side) the border's weight rises to 1.
FEATHER = 0.08


@dataclass
class ViewCoverage:
    """What the views say of an equirect panorama, pixel by pixel (all (H, W[, 3]))."""

    radiance: np.ndarray    # (H, W, 3) the views' weighted mean radiance; 0 where none
    weight: np.ndarray      # (H, W) the summed weight of the unclipped samples there
    seen: np.ndarray        # (H, W) bool: inside some view's frame
    clipped: np.ndarray     # (H, W) bool: clipped (or beside a clipped light) in every
                            # view that saw it, clipped in one at least
    floor: np.ndarray       # (H, W, 3) where bounded: the light it had at least
    bounded: np.ndarray     # (H, W) bool: seen but not measured: ``clipped``, or beside
                            # a clipped light (JPEG's ring) in every view that saw it

    @property
    def measured(self) -> np.ndarray:
        """(H, W) bool: some view measured the light there (a code not clipped)."""
        return self.weight > 0

    def lower_bound(self) -> np.ndarray:
        """The radiance where measured, the clip level where clipped in every view (a lower
        bound of the light there; beside a clipped light, what the views read, at most the
        clip level), 0 where no view looked."""
        return np.where(self.bounded[..., None], self.floor, self.radiance)

    def solid_angle(self, mask: np.ndarray) -> float:
        """The solid angle (sr) of the panorama pixels in ``mask``."""
        return float(pixel_solid_angles(self.seen.shape[0]) @ np.asarray(mask).sum(axis=1))

    @property
    def coverage_sr(self) -> float:
        """The solid angle the views saw (sr, of 4π)."""
        return self.solid_angle(self.seen)

    def clipped_light_fraction(self, channels=(0, 1, 2)) -> float:
        """The share of the light seen (the ``channels`` summed, weighted by solid angle)
        that the views saw only as clipped codes, counted at their clip level: a lower
        bound."""
        c = list(channels)
        omega = pixel_solid_angles(self.seen.shape[0])[:, None, None]
        total = float((omega * self.lower_bound()[..., c]).sum())
        clipped = float((omega * np.where(self.clipped[..., None], self.floor, 0.0)[..., c])
                        .sum())
        return clipped / total if total > 0 else 0.0


def pixel_solid_angles(height: int) -> np.ndarray:
    """(H,) the solid angle of one pixel of each row of a 2:1 equirect panorama."""
    e = Equirect(2 * height, height)
    return e.row_integrals()[0] * (2 * math.pi / e.width)


def equirect_directions(height: int) -> np.ndarray:
    """(H, 2H, 3) float32 unit directions of an equirect panorama's pixel centres."""
    e = Equirect(2 * height, height)
    ys, xs = np.mgrid[0:height, 0:2 * height]
    return e.pixel_to_direction(xs + 0.5, ys + 0.5)[0].astype(np.float32)


def view_pixels(view: PassthroughView, dirs: np.ndarray):
    """Where world directions ``dirs`` (n, 3) land in ``view``: continuous image
    coordinates ``(px, py)`` (pixel ``(i, j)`` covers ``[i, i+1) × [j, j+1)``) and whether
    each is inside the frame, in front of the camera. The inverse of
    :meth:`PassthroughView.directions` (OpenCV's ``projectPoints`` for ``OPENCV``)."""
    dirs = np.asarray(dirs)
    # only the rays within the frame's half-diagonal (and a margin) are projected: a view
    # sees a few per cent of the sphere
    reach = math.atan(math.hypot(max(view.cx, view.w - view.cx) / view.fl_x,
                                 max(view.cy, view.h - view.cy) / view.fl_y))
    near = np.flatnonzero(dirs @ -view.rotation[:, 2].astype(dirs.dtype)
                          > math.cos(min(reach * 1.3 + 0.05, math.pi)))
    px = np.full(len(dirs), -1.0)
    py = np.full(len(dirs), -1.0)
    inside = np.zeros(len(dirs), bool)
    u, v, ok = _project(view, dirs[near])
    px[near], py[near], inside[near] = u, v, ok
    return px, py, inside


def _project(view: PassthroughView, dirs: np.ndarray):
    cam = np.asarray(dirs, np.float64) @ view.rotation       # world -> camera (OpenGL axes)
    depth = -cam[:, 2]
    front = depth > 1e-6
    px = np.full(len(cam), -1.0)
    py = np.full(len(cam), -1.0)
    d = np.maximum(depth[front], 1e-6)
    x, y = cam[front, 0] / d, -cam[front, 1] / d              # OpenCV's axes: y down
    if not front.any():
        u = v = np.zeros(0)
    elif view.camera_model == "OPENCV" and any(view.distortion):
        # the distortion polynomial folds back far outside the frame: only rays within the
        # undistorted frame's reach (its corners, with a margin) are projected
        corners = view.directions(np.array([0.0, view.w, 0.0, view.w]),
                                  np.array([0.0, 0.0, view.h, view.h])) @ view.rotation
        reach = 1.25 * float(np.max(np.hypot(corners[:, 0], corners[:, 1]) / -corners[:, 2]))
        near = np.hypot(x, y) <= reach
        K = np.array([[view.fl_x, 0, view.cx], [0, view.fl_y, view.cy], [0, 0, 1.0]])
        pts = np.stack([x, y, np.ones_like(x)], -1)
        proj = cv2.projectPoints(pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K,
                                 np.array(view.distortion, np.float64))[0].reshape(-1, 2)
        u, v = np.where(near, proj[:, 0], -1.0), np.where(near, proj[:, 1], -1.0)
    else:
        u, v = view.fl_x * x + view.cx, view.fl_y * y + view.cy
    px[front], py[front] = u, v
    inside = front & (px >= 0) & (px <= view.w) & (py >= 0) & (py <= view.h)
    return px, py, inside


def remap_points(src: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``src`` (h, w, C) float32 read bilinearly at the continuous pixel coordinates ``x``,
    ``y`` (n,) (OpenCV's: pixel centres at integers), (n, C): OpenCV's ``remap`` on the
    points laid out in rows (its maps must be under 32767 wide)."""
    n = len(x)
    cols = 1024
    rows = max(1, -(-n // cols))
    mx = np.full(rows * cols, -1e4, np.float32)
    my = np.full(rows * cols, -1e4, np.float32)
    mx[:n], my[:n] = x, y
    out = cv2.remap(src, mx.reshape(rows, cols), my.reshape(rows, cols), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(rows * cols, -1)[:n]


def _code_weight(image: np.ndarray) -> np.ndarray:
    """(h, w) how much a pixel's codes say: 0 where any channel clips, rising from
    ``MIN_WEIGHT`` at black to 1 at ``DARK_CODE``, falling toward the clip code."""
    lo = image.min(axis=-1).astype(np.float32)
    hi = image.max(axis=-1).astype(np.float32)
    w = np.minimum(np.clip((lo + 1) / DARK_CODE, MIN_WEIGHT, 1.0),
                   np.clip((CLIP_CODE - hi) / 16.0, 0.0, 1.0))
    return w.astype(np.float32)


def _border_weight(w: int, h: int) -> np.ndarray:
    ys, xs = np.mgrid[0:h, 0:w]
    edge = np.minimum(np.minimum(xs + 0.5, w - xs - 0.5), np.minimum(ys + 0.5, h - ys - 0.5))
    return np.clip(edge / (FEATHER * min(w, h)), MIN_WEIGHT, 1.0).astype(np.float32)


def vignetting_map(view: PassthroughView, vignetting) -> np.ndarray:
    """(h, w) V(ρ) = exp(v₁ρ² + v₂ρ⁴) of the fit's model (docs/passthrough.md)."""
    v1, v2 = (float(v) for v in vignetting)
    ys, xs = np.mgrid[0:view.h, 0:view.w]
    rho2 = ((xs + 0.5 - view.cx) ** 2 + (ys + 0.5 - view.cy) ** 2) \
        / (0.25 * (view.w ** 2 + view.h ** 2))
    return np.exp(v1 * rho2 + v2 * rho2 * rho2)


def view_radiance(view, image, table, exposure, wb, vignetting=(0.0, 0.0)):
    """``(radiance (h, w, 3), clip level (h, w, 3), clipped (h, w) bool)`` of one view in the
    model's units: g(z) / (exposure · wb · V), and the same of the clip code."""
    image = np.asarray(image)
    if image.dtype != np.uint8 or image.shape != (view.h, view.w, 3):
        raise InputError(f"{view.file_path}: expected {view.w}×{view.h} 8-bit RGB, got "
                         f"{image.dtype} {image.shape}")
    table = np.asarray(table, np.float64)
    gain = (float(exposure) * np.asarray(wb, np.float64))[None, None, :] \
        * vignetting_map(view, vignetting)[..., None]
    lin = np.stack([table[image[..., c], c] for c in range(3)], -1)
    clipped = (image >= CLIP_CODE).any(-1)
    return lin / gain, table[CLIP_CODE][None, None, :] / gain, clipped


def splat_views(views, images, table, exposure, wb_gains, vignetting=(0.0, 0.0), *,
                height: int, use=None) -> ViewCoverage:
    """The views' radiance on an equirect panorama of ``height`` rows (module doc).

    ``table``: the inverse response (256, 3); ``exposure`` (V,), ``wb_gains`` (V, 3),
    ``vignetting`` (v₁, v₂): the model's, in the units the radiance is wanted in; ``use``
    (V,) bool: the views to splat (default all)."""
    height = int(height)
    if height < 2:
        raise InputError(f"the panorama must have at least 2 rows, got {height}")
    dirs = equirect_directions(height).reshape(-1, 3)
    n = dirs.shape[0]
    num = np.zeros((n, 3))
    den = np.zeros(n)
    seen = np.zeros(n, bool)
    clipped_any = np.zeros(n, bool)
    bounded_any = np.zeros(n, bool)
    floor = np.zeros((n, 3))
    pano_step = math.pi / height               # radians per panorama pixel
    for i, (view, image) in enumerate(zip(views, images)):
        if use is not None and not use[i]:
            continue
        lin, clip_level, clipped = view_radiance(view, image, table, exposure[i],
                                                 wb_gains[i], vignetting)
        weight = _code_weight(np.asarray(image)) * _border_weight(view.w, view.h)
        # JPEG rings around a clipped light: its neighbours are no measurement either, but
        # their light is there at least (what they read, at most the clip level)
        ring = cv2.dilate(clipped.astype(np.uint8),
                          cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))) > 0
        weight[ring] = 0.0
        bound = np.where(clipped[..., None], clip_level, np.minimum(lin, clip_level))
        px, py, inside = view_pixels(view, dirs)
        idx = np.flatnonzero(inside)
        if len(idx) == 0:
            continue
        layers = np.dstack([lin * weight[..., None], weight]).astype(np.float32)
        extra = np.dstack([bound, ring, clipped]).astype(np.float32)
        # a view much finer than the panorama: area-averaged first (a bilinear read would
        # alias), its coordinates scaled with it
        shrink = int(pano_step * max(view.fl_x, view.fl_y))     # panorama px / view px
        scale = 1.0
        if shrink >= 2:
            size = (max(1, view.w // shrink), max(1, view.h // shrink))
            scale = size[0] / view.w
            layers = cv2.resize(layers, size, interpolation=cv2.INTER_AREA)
            extra = cv2.resize(extra, size, interpolation=cv2.INTER_AREA)
        map_x = px[idx] * scale - 0.5
        map_y = py[idx] * scale - 0.5
        got = remap_points(layers, map_x, map_y)
        num[idx] += got[:, :3]
        den[idx] += got[:, 3]
        seen[idx] = True
        if clipped.any():
            more = remap_points(extra, map_x, map_y)
            hit = more[:, 3] >= 0.5
            bounded_any[idx[hit]] = True
            floor[idx[hit]] = np.maximum(floor[idx[hit]], more[hit, :3])
            clipped_any[idx[more[:, 4] >= 0.5]] = True
    measured = den > 1e-6
    radiance = np.zeros((n, 3))
    radiance[measured] = num[measured] / den[measured, None]
    bounded = seen & ~measured & (bounded_any | clipped_any)
    shape = (height, 2 * height)
    return ViewCoverage(radiance.reshape(*shape, 3), np.where(measured, den, 0.0).reshape(
        shape), seen.reshape(shape), (bounded & clipped_any).reshape(shape),
        np.where(bounded[:, None], floor, 0.0).reshape(*shape, 3), bounded.reshape(shape))


def splat_fit(result, views, images, height: int) -> ViewCoverage:
    """:func:`splat_views` with a :class:`~.fit.PassthroughResult`'s model (the sphere's
    units); views the fit could not fit (``fitted: false``) are left out."""
    return splat_views(views, images, result.response.table, result.exposure,
                       result.wb_gains, result.vignetting, height=height,
                       use=np.asarray(result.fitted))


def sphere_holes(sphere: np.ndarray, mask=None, nadir_cap_deg: float = 0.0) -> np.ndarray:
    """(H, W) bool: where the 360° camera sees nothing in an equirect ``sphere``: a
    non-finite pixel, a region (wider than a pixel or two) that is exactly 0 in every
    channel (a projection's unseen region, a stitcher's black tripod cap, a masked mount),
    ``mask`` (H, W, nonzero: unseen), and the cap within
    ``nadir_cap_deg`` of straight down (−Y, where its tripod stands)."""
    s = np.asarray(sphere)
    h, w = s.shape[:2]
    # a region of zeros, not a speck: resampling rings to exact 0 (or below) in a few
    # thin lines around bright edges, which the camera saw
    zero = (np.nan_to_num(s, nan=1.0) == 0).all(-1).astype(np.uint8)
    k = 2 * max(1, round(h / 256)) + 1
    holes = ~np.isfinite(s).all(-1) | (cv2.morphologyEx(zero, cv2.MORPH_OPEN,
                                                        np.ones((k, k), np.uint8)) > 0)
    if mask is not None:
        m = np.asarray(mask)
        if m.shape[:2] != (h, w):
            raise InputError(f"the sphere's mask is {m.shape[1]}×{m.shape[0]}; the sphere "
                             f"is {w}×{h}")
        holes |= (m.reshape(h, w, -1) != 0).any(-1)
    if nadir_cap_deg:
        if not 0 < nadir_cap_deg <= 180:
            raise InputError(f"the nadir cap must be between 0 and 180 degrees, got "
                             f"{nadir_cap_deg:g}")
        theta = (np.arange(h) + 0.5) / h * 180.0        # from the zenith
        holes[theta >= 180.0 - nadir_cap_deg] = True
    return holes


@dataclass
class Filled:
    """A sphere filled from the views, and what was gained."""

    sphere: np.ndarray          # (H, W, 3) float32
    holes_sr: float             # the solid angle the 360° camera did not see
    gained_sr: float            # of which the views filled (measured, or clipped: a bound)
    clipped_sr: float           # of which the views saw only clipped (filled at clip level)


def fill_sphere(sphere: np.ndarray, holes: np.ndarray, coverage: ViewCoverage) -> Filled:
    """``sphere`` with its ``holes`` taken from the views' ``coverage`` (of the same size)
    where they saw them; what no view saw stays 0."""
    s = np.nan_to_num(np.asarray(sphere, np.float64)[..., :3], nan=0.0, posinf=0.0,
                      neginf=0.0)
    if coverage.seen.shape != s.shape[:2]:
        raise InputError(f"the views' panorama is {coverage.seen.shape[1]}×"
                         f"{coverage.seen.shape[0]}; the sphere is {s.shape[1]}×{s.shape[0]}")
    fill = holes & (coverage.measured | coverage.bounded)
    out = np.where(holes[..., None], 0.0, s)
    out[fill] = coverage.lower_bound()[fill]
    return Filled(out.astype(np.float32), coverage.solid_angle(holes),
                  coverage.solid_angle(fill), coverage.solid_angle(holes & coverage.clipped))
