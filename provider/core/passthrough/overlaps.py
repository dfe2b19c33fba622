"""The views' exposures and white balance from their overlaps alone, without a sphere.

Without a 360° camera there is no reference in absolute units, so what the views can tell
is relative: where two views see the same directions, the ratio of their linear light is
the ratio of their exposures (per channel: of exposure × white balance). Per pair of views
that overlap, :func:`relative_exposures` takes the median over the shared directions of
log(g(z_i) / V) − log(g(z_j) / V) (on a copy of each view a quarter of its size, where
neither view is near clipping or black and the light is flat, so that a degree of pose
error and the parallax at edges do not count), and solves for every view's log exposure
per channel by least squares over the pairs, reweighted toward least absolute deviations
(a pair that sees a near object differently does not pull the others).

Two constants are left that the views cannot know: the level (every exposure × k) and the
average white balance. The level is the views' own: their mean log exposure is 0 (a code
at the anchor of the curve, g(118) = 0.18, in the average view reads 0.18), or, when every
view says its ``exposure_s`` (and ``gain``/``iso``), that exposure, so the light is per
second of exposure per unit gain as ``shlight compute`` reports a frame with ``@SECONDS``.
The white balance's mean over the views is taken as neutral.

What it needs and cannot find: the curve. It is given (a camera.json from ``shlight
passthrough`` or ``calibrate-response``), or sRGB, which is not most headsets' curve: the
exposures and the light then carry the curve's error (docs/passthrough.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError
from .extend import remap_points, view_pixels, vignetting_map
from .fit import CODE_HI, CODE_LO

#: Each view is compared at this many pixels across (area-averaged): ~1.1° a pixel for a
#: 90° view, about the pose error a headset's tracking leaves.
SIZE = 80
#: A pair needs this many shared usable samples to count.
MIN_SHARED = 60
#: The flattest fraction of a pair's shared samples that is kept.
KEEP_FLAT = 0.6


@dataclass
class Overlaps:
    """The views' exposures and white balance from their overlaps (module doc)."""

    exposure: np.ndarray        # (V,) green-channel exposure: code units of g per unit light
    wb_gains: np.ndarray        # (V, 3), green = 1
    connected: np.ndarray       # (V,) bool: in the largest group of views that overlap
    pairs: int                  # pairs of views that shared enough samples
    residual_stops: np.ndarray  # (V,) median |log2 residual| of its pairs, worst channel
    metadata: bool              # whether the views' exposure_s set the level


@dataclass
class _Small:
    log: np.ndarray         # (h, w, 3) log of the linear light g(z) / V, a quarter size
    usable: np.ndarray      # (h, w) float: 1 where no code near is clipped or black
    contrast: np.ndarray    # (h, w) the log light's range over 3 × 3 pixels
    scale: float            # small pixels per view pixel


def _small(view, image, table, vignetting) -> _Small:
    image = np.asarray(image)
    if image.dtype != np.uint8 or image.shape != (view.h, view.w, 3):
        raise InputError(f"{view.file_path}: expected {view.w}×{view.h} 8-bit RGB, got "
                         f"{image.dtype} {image.shape}")
    lin = np.stack([table[image[..., c], c] for c in range(3)], -1) \
        / vignetting_map(view, vignetting)[..., None]
    kernel = np.ones((3, 3), np.uint8)
    ok = ((cv2.erode(image, kernel) >= CODE_LO).all(-1)
          & (cv2.dilate(image, kernel) <= CODE_HI).all(-1)).astype(np.float32)
    scale = min(1.0, SIZE / view.w)
    size = (max(8, int(round(view.w * scale))), max(6, int(round(view.h * scale))))
    scale = size[0] / view.w
    small = cv2.resize(lin.astype(np.float32), size, interpolation=cv2.INTER_AREA)
    usable = cv2.resize(ok, size, interpolation=cv2.INTER_AREA)
    log = np.log(np.maximum(small, 1e-9))
    lum = log.mean(-1)
    contrast = cv2.dilate(lum, np.ones((3, 3), np.uint8)) - cv2.erode(lum, np.ones((3, 3),
                                                                                  np.uint8))
    return _Small(log, usable, contrast, scale)


def _pair(vi, si: _Small, vj, sj: _Small):
    """(median log ratio (3,), shared samples) of view i over view j, or None."""
    h, w = si.log.shape[:2]
    ys, xs = np.mgrid[0:h, 0:w]
    keep_i = si.usable.reshape(-1) >= 0.999
    if keep_i.sum() < MIN_SHARED:
        return None
    px = (xs.reshape(-1)[keep_i] + 0.5) / si.scale
    py = (ys.reshape(-1)[keep_i] + 0.5) / si.scale
    dirs = vi.directions(px, py)
    u, v, inside = view_pixels(vj, dirs)
    if inside.sum() < MIN_SHARED:
        return None
    at_j = remap_points(np.dstack([sj.log, sj.usable, sj.contrast]).astype(np.float32),
                        u[inside] * sj.scale - 0.5, v[inside] * sj.scale - 0.5)
    log_j, use_j, con_j = at_j[:, :3], at_j[:, 3], at_j[:, 4]
    log_i = si.log.reshape(-1, 3)[keep_i][inside]
    con_i = si.contrast.reshape(-1)[keep_i][inside]
    ok = use_j.reshape(-1) >= 0.999
    if ok.sum() < MIN_SHARED:
        return None
    contrast = np.maximum(con_i, con_j.reshape(-1))[ok]
    flat = contrast <= np.quantile(contrast, KEEP_FLAT)
    ratio = (log_i[ok] - log_j.reshape(-1, 3)[ok])[flat]
    return np.median(ratio, axis=0), int(flat.sum())


def _components(n: int, edges) -> np.ndarray:
    """Each view's group label (views joined by the pairs)."""
    parent = list(range(n))

    def root(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a
    for i, j in edges:
        parent[root(i)] = root(j)
    return np.array([root(a) for a in range(n)])


def relative_exposures(views, images, table, vignetting=(0.0, 0.0)) -> Overlaps:
    """Every view's exposure and white balance from its overlaps with the others (module
    doc). ``table``: the curve (256, 3), g(118) = 0.18; ``vignetting``: (v₁, v₂) of the
    fit's model, if known."""
    n = len(views)
    if n == 0:
        raise InputError("no views")
    table = np.asarray(table, np.float64)
    smalls = [_small(v, im, table, vignetting) for v, im in zip(views, images)]
    forward = np.array([-v.rotation[:, 2] for v in views])
    reach = np.array([math.atan(math.hypot(v.w / 2 / v.fl_x, v.h / 2 / v.fl_y))
                      for v in views])
    edges, ratios, counts = [], [], []
    for i in range(n):
        for j in range(i + 1, n):
            angle = math.acos(float(np.clip(forward[i] @ forward[j], -1, 1)))
            if angle >= reach[i] + reach[j]:
                continue                      # their frames cannot share a direction
            got = _pair(views[i], smalls[i], views[j], smalls[j])
            if got is not None:
                edges.append((i, j))
                ratios.append(got[0])
                counts.append(got[1])
    label = _components(n, edges)
    sizes = np.bincount(label, minlength=n)
    main = int(np.argmax(sizes))
    connected = label == main
    log_e = np.zeros((n, 3))
    resid = np.full(n, np.nan)
    use = [k for k, (i, j) in enumerate(edges) if connected[i]]
    if use:
        members = np.flatnonzero(connected)
        col = {v: c for c, v in enumerate(members)}
        a = np.zeros((len(use) + 1, len(members)))
        for r, k in enumerate(use):
            i, j = edges[k]
            a[r, col[i]], a[r, col[j]] = 1.0, -1.0
        a[-1] = 1.0 / len(members)            # the level: their mean log exposure is 0
        b = np.vstack([np.array([ratios[k] for k in use]), np.zeros((1, 3))])
        base = np.sqrt(np.minimum([counts[k] for k in use], 400.0))
        solution = np.zeros((len(members), 3))
        for c in range(3):
            w = np.append(base, 100.0)
            for _ in range(6):                # toward least absolute deviations
                x = np.linalg.lstsq(a * w[:, None], b[:, c] * w, rcond=None)[0]
                res = np.abs(a[:-1] @ x - b[:-1, c])
                w = np.append(base / np.maximum(res, 0.02), 100.0 / 0.02)
            solution[:, c] = x
        log_e[members] = solution
        res = np.abs(a[:-1] @ solution - b[:-1]).max(-1) / math.log(2)
        per_view = [[] for _ in range(n)]
        for r, k in enumerate(use):
            for v in edges[k]:
                per_view[v].append(res[r])
        resid = np.array([np.median(p) if p else np.nan for p in per_view])
    else:
        connected[:] = False
    if (~connected).any() and connected.any():
        log_e[~connected] = np.median(log_e[connected], axis=0)
    metadata = [v.exposure_product() for v in views]
    known = all(m is not None for m in metadata)
    wb = log_e - log_e[:, 1:2]
    wb -= wb[connected].mean(axis=0) if connected.any() else 0.0   # neutral on average
    green = np.log(np.array(metadata, np.float64)) if known else log_e[:, 1]
    return Overlaps(exposure=np.exp(green), wb_gains=np.exp(wb), connected=connected,
                    pairs=len(use), residual_stops=resid, metadata=known)


def anchored_to_fit(result, views, images, tolerance_stops: float = 0.25):
    """``(exposure (V,), wb_gains (V, 3), use (V,) bool, from_overlaps (V,) bool)``: the
    fit's model of each view (:class:`~.fit.PassthroughResult`), except where the views'
    overlaps (:func:`relative_exposures`, with the fit's curve and vignetting, brought to the
    sphere's units by the median over the fitted views) say otherwise by more than
    ``tolerance_stops``, and for the views the fit could not fit (``fitted: false``: they
    look where the sphere sees nothing). A view at the edge of what the sphere sees is
    fitted on a few samples; its overlaps may know it better. ``use``: the views with a
    model; ``from_overlaps``: those whose model is their overlaps'."""
    fitted = np.asarray(result.fitted, bool)
    exposure = np.array(result.exposure, np.float64)
    wb = np.array(result.wb_gains, np.float64)
    none = np.zeros(len(fitted), bool)
    if not fitted.any() or len(views) < 2:
        return exposure, wb, fitted, none
    rel = relative_exposures(views, images, result.response.table, result.vignetting)
    log_fit = np.log(exposure)[:, None] + np.log(wb)
    log_rel = np.log(rel.exposure)[:, None] + np.log(rel.wb_gains)
    both = fitted & rel.connected
    if not both.any():
        return exposure, wb, fitted, none
    log_rel = log_rel + np.median(log_fit[both] - log_rel[both], axis=0)
    off = np.abs(log_fit - log_rel).max(-1) > tolerance_stops * math.log(2)
    swap = rel.connected & (~fitted | off)
    exposure[swap] = np.exp(log_rel[swap, 1])
    wb[swap] = np.exp(log_rel[swap] - log_rel[swap, 1:2])
    return exposure, wb, fitted | swap, swap
