"""The passthrough camera's response, exposures and white balance, fitted against the sphere.

The model (docs/passthrough.md): a pixel of view i that sees sphere radiance L_c (in the
sphere's units) records the code

    z_c = g_c⁻¹(exposure_i · wb_i,c · V(ρ) · L_c)

with g_c the camera's inverse response per channel (a 256-entry table anchored at
g_c(118) = 0.18, the ``shlight-camera-response`` format of
:mod:`provider.core.radiometry.response`), ``exposure_i`` the view's exposure (green
channel), ``wb_i`` its white-balance gains (green = 1) and V(ρ) = exp(v₁ρ² + v₂ρ⁴) the
lens's vignetting at ρ, the distance from the principal point over the half-diagonal.

How it is fitted, robustly (every step a median, an L1 fit):

0. Poses: each view is turned (about its right and up axes, within ``refine_deg``, 3°) to
   where its log codes correlate best with the sphere's log radiance, a grid of 1° and then
   of 0.25° steps; a correlation needs neither the curve nor the exposure. Tracking a few
   degrees off would otherwise bias the dark codes (a dark thing is usually small, so a
   wrong direction sees something brighter).
1. Samples: a grid of a few thousand pixels per view. The view (in about-linear light) and
   the sphere are blurred by the same angle (``sigma_deg``, 1°: the pose error left), and
   samples where the sphere's radiance changes within a few sigma (edges, where pose error
   and parallax swap one surface for another) are dropped: per band of codes, the flattest
   60 % are kept. So are dropped samples near a clipped or black pixel (in any channel).
2. Alternation from sRGB: given g and V, each view's ``log(exposure · wb_c)`` is the median
   over its samples of ``log g_c(z) − log L_c − log V``; given those, V is an L1 fit of
   the rest against ρ², ρ⁴; and g_c is, for each code, the median of
   ``log(exposure · wb_c · V · L_c)`` over the samples that recorded that code, smoothed
   (a Whittaker smoother in log(code + 1): least squares plus a penalty on second
   differences, which extends the curve as a power law where no sample recorded a code),
   made increasing and anchored at code 118. Binning by code puts the noise where it is (the sphere's radiance
   in a slightly wrong direction), so the curve is not flattened by it.
3. Exposure metadata (``exposure_s`` and ``gain``/``iso`` in every view) fixes the views'
   exposures up to one constant (the fit's); white balance stays free per view.

Where it fails: a view that sees only clipped light or black (no samples: its exposure is
the median of the others, flagged ``fitted: false``); codes no view recorded between the
black and clip limits (extrapolated); a sphere that does not see what the headset sees
(its mount, the floor under it, a person in the room: dropped only when it disagrees with
most other samples of that view).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..errors import InputError
from ..radiometry.photometry import METER_K
from ..radiometry.response import ANCHOR_CODE_8, ANCHOR_VALUE, CameraResponse, srgb_decode
from .views import PassthroughView

#: The pose error (deg) the sphere and the views are blurred by.
SIGMA_DEG = 1.0
#: Codes a sample must stay within in every channel (and its neighbourhood): darker is JPEG
#: noise on the toe, brighter is the shoulder next to clipping.
CODE_LO, CODE_HI = 6, 250
#: The fraction of the flattest samples of the sphere that the fit keeps.
KEEP_FLAT = 0.6
#: A view with fewer usable samples than this gets the median exposure of the others.
MIN_SAMPLES = 30
#: The curve is smooth in log(code + 1): its extension past the codes seen is a power law
#: (the dark end of every camera curve is near one), not an exponential.
CODE_AXIS = np.log(np.arange(256) + 1.0)
#: How far (deg) each view's pose is searched for the turn that fits the sphere best.
REFINE_DEG = 3.0


_SRGB_LUT = srgb_decode(np.arange(256) / 255.0).astype(np.float32)


def _srgb_codes(lin: np.ndarray) -> np.ndarray:
    """Continuous 8-bit codes of sRGB-linear values (the inverse of ``_SRGB_LUT``)."""
    x = np.clip(lin.astype(np.float64), 0.0, 1.0)
    return 255.0 * np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def _wrap_blur(pano: np.ndarray, sigma_px: float) -> np.ndarray:
    """Gaussian blur of an equirect panorama, wrapping around horizontally."""
    if sigma_px <= 0:
        return pano
    pad = int(math.ceil(4 * sigma_px)) + 1
    padded = np.concatenate([pano[:, -pad:], pano, pano[:, :pad]], axis=1)
    out = cv2.GaussianBlur(padded, (0, 0), sigma_px, borderType=cv2.BORDER_REFLECT)
    return np.ascontiguousarray(out[:, pad:-pad])


def sample_equirect(pano: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Bilinear radiance (..., 3) of an equirect panorama (docs/contract.md §1) in the unit
    world directions ``dirs`` (..., 3); wraps around horizontally, clamps at the poles."""
    h, w = pano.shape[:2]
    d = np.asarray(dirs, np.float64)
    theta = np.arccos(np.clip(d[..., 1], -1.0, 1.0))
    phi = np.arctan2(d[..., 0], -d[..., 2])
    x = (phi / (2 * math.pi) + 0.5) * w - 0.5
    y = np.clip(theta / math.pi * h - 0.5, 0.0, h - 1.0)
    x0 = np.floor(x)
    fx = (x - x0)[..., None]
    x0 = x0.astype(np.int64) % w
    x1 = (x0 + 1) % w
    y0 = np.floor(y).astype(np.int64)
    fy = (y - y0)[..., None]
    y1 = np.minimum(y0 + 1, h - 1)
    top = pano[y0, x0] * (1 - fx) + pano[y0, x1] * fx
    bot = pano[y1, x0] * (1 - fx) + pano[y1, x1] * fx
    return top * (1 - fy) + bot * fy


def check_sphere(pano) -> np.ndarray:
    """The sphere as float64 linear radiance (H, W, 3), 2:1 equirect; negatives -> 0."""
    a = np.asarray(pano)
    if a.ndim != 3 or a.shape[2] < 3:
        raise InputError(f"the sphere must be an RGB panorama, got shape {a.shape}")
    if a.shape[1] != 2 * a.shape[0]:
        raise InputError(f"the sphere must be a 2:1 equirect panorama (docs/contract.md §1), "
                         f"got {a.shape[1]}×{a.shape[0]}")
    a = np.nan_to_num(a[..., :3].astype(np.float64), nan=0.0, posinf=0.0, neginf=0.0)
    return np.maximum(a, 0.0)


@dataclass
class _Samples:
    code: np.ndarray      # (n, 3) blurred codes
    usable: np.ndarray    # (n,) bool: no clipped / black pixel near, sphere flat there
    radiance: np.ndarray  # (n, 3) blurred sphere radiance
    rho2: np.ndarray      # (n,) squared distance from the principal point / half-diagonal
    contrast: np.ndarray  # (n,) how much the sphere's log radiance changes nearby
    turned_deg: float = 0.0   # the pose correction the samples were taken with


@dataclass
class PassthroughResult:
    """A fit: the camera's curve, and per view exposure, white balance and residual."""

    response: CameraResponse
    exposure: np.ndarray        # (V,) green-channel exposure, sphere units -> g's units
    wb_gains: np.ndarray        # (V, 3), green = 1
    residual_stops: np.ndarray  # (V,) median |log2 residual|, worst channel
    samples: np.ndarray         # (V,) samples each view's fit used
    vignetting: tuple = (0.0, 0.0)
    file_paths: list = field(default_factory=list)
    pose_correction_deg: np.ndarray | None = None   # (V,) the turn each view's pose needed

    @property
    def fitted(self) -> np.ndarray:
        return self.samples >= MIN_SAMPLES

    def ev100(self) -> np.ndarray:
        """Per view, the EV100 whose meter renders sphere radiance 0.18 / exposure as
        mid-grey: log2((0.18 / exposure) · 100 / K), in the sphere's units (absolute when
        the sphere is in cd/m²)."""
        return np.log2(ANCHOR_VALUE / self.exposure * 100.0 / METER_K)

    def sensor_exposure(self, radiance, view: int, rho2=None) -> np.ndarray:
        """X = exposure · wb · V · L of sphere radiance (..., 3) in view ``view``."""
        gain = self.exposure[view] * self.wb_gains[view]
        x = np.asarray(radiance, np.float64) * gain
        if rho2 is not None:
            v1, v2 = self.vignetting
            r2 = np.asarray(rho2, np.float64)
            x = x * np.exp(v1 * r2 + v2 * r2 * r2)[..., None]
        return x

    def predict_codes(self, radiance, view: int, rho2=None) -> np.ndarray:
        """Continuous codes (..., 3) in [0, 255] the camera records for sphere radiance
        (..., 3) in view ``view`` (a hologram rendered through the model)."""
        return codes_of(self.response.table, self.sensor_exposure(radiance, view, rho2))

    def to_json(self) -> dict:
        """``{"camera": camera.json object, "views": [...]}`` (docs/contract.md §15)."""
        ev = self.ev100()
        views = []
        for i in range(len(self.exposure)):
            v = {"file_path": self.file_paths[i] if i < len(self.file_paths) else None,
                 "exposure": float(self.exposure[i]),
                 "wb_gains": [float(g) for g in self.wb_gains[i]],
                 "ev100": float(ev[i]),
                 # null where no sample was usable (``fitted: false``): nothing was explained
                 "residual_stops": (float(self.residual_stops[i])
                                    if math.isfinite(self.residual_stops[i]) else None),
                 "samples": int(self.samples[i])}
            if self.pose_correction_deg is not None:
                v["pose_correction_deg"] = float(self.pose_correction_deg[i])
            if not self.fitted[i]:
                v["fitted"] = False
            views.append(v)
        return {"camera": self.response.to_dict(), "views": views}


def codes_of(table: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The inverse of an increasing inverse-response table: continuous codes (..., 3) of
    sensor exposure ``x`` (..., 3), clamped to the table's ends."""
    x = np.asarray(x, np.float64)
    codes = np.arange(table.shape[0], dtype=np.float64)
    out = np.empty(x.shape)
    for c in range(3):
        out[..., c] = np.interp(x[..., c], table[:, c], codes)
    return out


def log_table_at(log_table: np.ndarray, z: np.ndarray) -> np.ndarray:
    """log g_c at continuous codes z (n, 3), per channel (linear interpolation)."""
    codes = np.arange(log_table.shape[0], dtype=np.float64)
    return np.stack([np.interp(z[:, c], codes, log_table[:, c]) for c in range(3)], -1)


def _whittaker(values, weights, lam, u=None) -> np.ndarray:
    """Least squares to ``values`` with ``weights`` plus ``lam`` × ∫ (d²x/du²)² du over
    the abscissae ``u`` (default 0, 1, 2, ...): a smooth curve that extends linearly in
    ``u`` where the weights are 0."""
    n = len(values)
    u = np.arange(n, dtype=np.float64) if u is None else np.asarray(u, np.float64)
    h = np.diff(u)
    d = np.zeros((n - 2, n))
    rows = np.arange(n - 2)
    h1, h2 = h[:-1], h[1:]
    span = 0.5 * (h1 + h2)
    d[rows, rows] = 1 / (h1 * span)
    d[rows, rows + 1] = -(1 / h1 + 1 / h2) / span
    d[rows, rows + 2] = 1 / (h2 * span)
    d *= np.sqrt(span)[:, None]          # the integral's measure
    a = np.diag(weights) + lam * d.T @ d
    return np.linalg.solve(a, weights * values)


def _grouped_median(keys, values, n_groups):
    """(median, count) of ``values`` for each integer key in [0, n_groups)."""
    med = np.zeros(n_groups)
    cnt = np.zeros(n_groups, np.int64)
    if len(keys) == 0:
        return med, cnt
    order = np.argsort(keys, kind="stable")
    k, v = keys[order], values[order]
    bounds = np.flatnonzero(np.diff(k)) + 1
    for grp_k, grp_v in zip(np.split(k, bounds), np.split(v, bounds)):
        med[grp_k[0]] = np.median(grp_v)
        cnt[grp_k[0]] = len(grp_v)
    return med, cnt


class PassthroughFit:
    """The joint fit, fed one view at a time (:meth:`add_view`), solved on demand
    (:meth:`solve`). Holds only each view's samples (a few thousand pixels), so memory
    grows by ~160 kB a view; ``max_views`` keeps the newest that many (a live feed)."""

    def __init__(self, sphere, *, sigma_deg: float = SIGMA_DEG, samples_per_view: int = 2500,
                 max_views: int | None = None, fit_vignetting: bool = True,
                 refine_deg: float = REFINE_DEG):
        self.sigma_deg = float(sigma_deg)
        self.set_sphere(sphere)
        self.samples_per_view = int(samples_per_view)
        self.max_views = max_views
        self.fit_vignetting = fit_vignetting
        self.refine_deg = float(refine_deg)
        self.views: list[PassthroughView] = []
        self._samples: list[_Samples] = []
        self._last = None       # (log g, vignetting) of the last solve, for a warm start

    def set_sphere(self, sphere) -> None:
        """Compare the views added from now on with ``sphere`` (an H × 2H × 3 linear
        equirect, in the units of the first): a live room whose light changed. Views already
        added keep their samples of the sphere of their time, which is what they saw."""
        self.sphere = check_sphere(sphere)
        px_per_deg = self.sphere.shape[1] / 360.0
        self._near = _wrap_blur(self.sphere, self.sigma_deg * px_per_deg)
        self._wide = _wrap_blur(self.sphere, 3 * self.sigma_deg * px_per_deg)
        # Where the sphere sees nothing (0: a projection's unseen part, a masked mount), its
        # blur near the edge mixes that black in: samples whose blur reaches it are dropped
        # (a region of zeros: the specks resampling rings to around bright edges are seen)
        from .extend import sphere_holes
        holes = sphere_holes(self.sphere)
        self._seen = None if not holes.any() else _wrap_blur(
            (~holes).astype(np.float32)[..., None], 3 * self.sigma_deg * px_per_deg)[..., None]

    # -- views -------------------------------------------------------------------------------
    def add_view(self, view: PassthroughView, image: np.ndarray) -> int:
        """Sample one view (its 8-bit RGB codes, H × W × 3); returns its index."""
        image = np.asarray(image)
        if image.dtype != np.uint8 or image.shape != (view.h, view.w, 3):
            raise InputError(f"{view.file_path}: expected {view.w}×{view.h} 8-bit RGB, got "
                             f"{image.dtype} {image.shape}")
        sigma_px = max(math.radians(self.sigma_deg) * 0.5 * (view.fl_x + view.fl_y), 0.5)
        # Blurred in (about) linear light, as the sphere is: a blur of codes would be darker
        # than the code of the blurred light wherever the curve bends (the toe, the shoulder).
        lin = _SRGB_LUT[image]
        blurred = _srgb_codes(cv2.GaussianBlur(lin, (0, 0), sigma_px,
                                               borderType=cv2.BORDER_REPLICATE))
        k = 2 * int(math.ceil(sigma_px)) + 1
        kernel = np.ones((k, k), np.uint8)
        hi = cv2.dilate(image, kernel)     # the brightest and darkest code near each pixel
        lo = cv2.erode(image, kernel)
        step = max(1, int(round(math.sqrt(view.w * view.h / self.samples_per_view))))
        ys, xs = np.mgrid[step // 2:view.h:step, step // 2:view.w:step]
        xs, ys = xs.ravel(), ys.ravel()
        dirs = view.directions(xs + 0.5, ys + 0.5)
        turned = 0.0
        if self.refine_deg > 0:
            dirs, turned = self._refined(dirs, blurred[ys, xs], view.rotation)
        near = sample_equirect(self._near, dirs)
        wide = sample_equirect(self._wide, dirs)
        tiny = 1e-6 * max(float(self.sphere.mean()), 1e-12)
        contrast = np.abs(np.log((near + tiny) / (wide + tiny))).max(axis=-1)
        ok = (lo[ys, xs] >= CODE_LO).all(-1) & (hi[ys, xs] <= CODE_HI).all(-1) \
            & (near > tiny).all(-1)
        if self._seen is not None:
            ok &= sample_equirect(self._seen, dirs)[..., 0] > 0.99
        half_diag2 = 0.25 * (view.w ** 2 + view.h ** 2)
        rho2 = ((xs + 0.5 - view.cx) ** 2 + (ys + 0.5 - view.cy) ** 2) / half_diag2
        self.views.append(view)
        self._samples.append(_Samples(blurred[ys, xs].astype(np.float64), ok, near, rho2,
                                      contrast, turned))
        if self.max_views and len(self.views) > self.max_views:
            del self.views[0], self._samples[0]
        return len(self.views) - 1

    def _refined(self, dirs, codes, rotation):
        """The sample directions turned by the small rotation (within ``refine_deg``, about
        the view's right and up axes) under which the view's log codes correlate best with
        the sphere's log radiance: a correlation, so it needs neither the curve nor the
        exposure. A grid of 1° steps, then of a quarter of that around the best."""
        lin = np.log(_SRGB_LUT[np.clip(np.rint(codes), 0, 255).astype(np.int64)].mean(-1)
                     + 1e-4)
        use = ((codes > CODE_LO) & (codes < CODE_HI)).all(-1)
        if use.sum() < MIN_SAMPLES:
            return dirs, 0.0
        cam = dirs[use] @ rotation             # the rays in the camera's own axes
        tiny = 1e-6 * max(float(self.sphere.mean()), 1e-12)
        x = lin[use] - lin[use].mean()

        def corr(rx, ry):
            turn = cv2.Rodrigues(np.array([[rx], [ry], [0.0]]))[0]
            lum = np.log(sample_equirect(self._near, cam @ turn.T @ rotation.T).mean(-1)
                         + tiny)
            y = lum - lum.mean()
            return float(x @ y) / max(math.sqrt(float(x @ x) * float(y @ y)), 1e-300)

        best = (0.0, 0.0)
        for step in (1.0, 0.25):
            span = int(round(self.refine_deg / step)) if step == 1.0 else 3
            grid = [(best[0] + math.radians(i * step), best[1] + math.radians(j * step))
                    for i in range(-span, span + 1) for j in range(-span, span + 1)]
            best = max(grid, key=lambda r: corr(*r))
        turn = cv2.Rodrigues(np.array([[best[0]], [best[1]], [0.0]]))[0]
        return (dirs @ rotation) @ turn.T @ rotation.T, math.degrees(math.hypot(*best))

    def estimate(self, index: int = -1):
        """One view's ``(exposure, wb_gains (3,), residual_stops, samples)`` under the last
        solve's curve and vignetting (sRGB and none before the first solve): :meth:`solve`'s
        per-view median alone, cheap, for a live feed between two solves. Exposure metadata
        is not used here. None when the view has fewer than ``MIN_SAMPLES`` usable samples."""
        s = self._samples[index]
        keep = _flattest([s])[0]
        if int(keep.sum()) < MIN_SAMPLES:
            return None
        if self._last is not None:
            log_g, vig = self._last
        else:
            log_g = np.log(np.maximum(srgb_decode(np.arange(256) / 255.0), 1e-6))[:, None] \
                .repeat(3, 1)
            vig = np.zeros(2)
        rho2 = s.rho2[keep]
        vterm = vig[0] * rho2 + vig[1] * rho2 ** 2
        r = log_table_at(log_g, s.code[keep]) - np.log(s.radiance[keep]) - vterm[:, None]
        a = np.median(r, axis=0)
        resid = float(np.median(np.abs(r - a), axis=0).max() / math.log(2))
        return math.exp(a[1]), np.exp(a - a[1]), resid, int(keep.sum())

    # -- the fit -----------------------------------------------------------------------------
    def solve(self, iterations: int = 12, smoothing: float = 0.03,
              warm: bool = False) -> PassthroughResult:
        """The joint fit over the views held (module doc). ``warm``: start from the last
        solve's curve and vignetting rather than sRGB (a live fit, re-solved as views
        arrive, then needs a few rounds, not twelve)."""
        n_views = len(self.views)
        if n_views == 0:
            raise InputError("no views to fit")
        keep = _flattest(self._samples)
        z = np.concatenate([s.code[k] for s, k in zip(self._samples, keep)])
        log_l = np.log(np.concatenate([s.radiance[k] for s, k in zip(self._samples, keep)]))
        rho2 = np.concatenate([s.rho2[k] for s, k in zip(self._samples, keep)])
        vid = np.concatenate([np.full(int(k.sum()), i) for i, k in enumerate(keep)])
        counts = np.bincount(vid, minlength=n_views)
        if len(z) < MIN_SAMPLES:
            raise InputError(f"only {len(z)} usable pixels in {n_views} views: the views are "
                             "clipped or black, or the sphere is black where they look")
        codes = np.arange(256, dtype=np.float64)
        log_g = np.log(np.maximum(srgb_decode(codes / 255.0), 1e-6))[:, None].repeat(3, 1)
        zi = np.clip(np.rint(z), 0, 255).astype(np.int64)
        metadata = [v.exposure_product() for v in self.views]
        known = all(m is not None for m in metadata)
        log_meta = np.log(np.array(metadata, np.float64)) if known else None
        vig = np.zeros(2)
        if warm and self._last is not None:
            log_g, vig = self._last[0].copy(), self._last[1].copy()
        a = np.zeros((n_views, 3))
        for _ in range(iterations):
            vterm = vig[0] * rho2 + vig[1] * rho2 ** 2
            lg = log_table_at(log_g, z)
            r = lg - log_l - vterm[:, None]
            for c in range(3):
                med, cnt = _grouped_median(vid, r[:, c], n_views)
                fallback = np.median(med[cnt >= MIN_SAMPLES]) if (cnt >= MIN_SAMPLES).any() \
                    else 0.0
                a[:, c] = np.where(cnt >= MIN_SAMPLES, med, fallback)
            if known:   # exposures from metadata up to one constant; wb stays free
                shift = a[:, 1] - log_meta
                ok = counts >= MIN_SAMPLES
                const = np.median(shift[ok]) if ok.any() else np.median(shift)
                wb = a - a[:, 1:2]
                a = wb + (log_meta + const)[:, None]
            if self.fit_vignetting:
                rest = (lg - log_l - a[vid]).ravel()
                basis = np.stack([rho2, rho2 ** 2], -1).repeat(3, 0)
                vig = _l1_fit(basis, rest, vig)
                vterm = vig[0] * rho2 + vig[1] * rho2 ** 2
            y = log_l + a[vid] + vterm[:, None]
            for c in range(3):
                med, cnt = _grouped_median(zi[:, c], y[:, c], 256)
                w = np.minimum(cnt, 200).astype(np.float64)
                w /= max(w.mean(), 1e-9)
                s = _whittaker(med, w, smoothing, CODE_AXIS)
                s = np.maximum.accumulate(s) + codes * 1e-6
                log_g[:, c] = s - s[ANCHOR_CODE_8] + math.log(ANCHOR_VALUE)
        # the last exposures for the last curve
        vterm = vig[0] * rho2 + vig[1] * rho2 ** 2
        r = log_table_at(log_g, z) - log_l - vterm[:, None] - a[vid]
        for c in range(3):
            med, cnt = _grouped_median(vid, r[:, c], n_views)
            a[:, c] += np.where(cnt >= MIN_SAMPLES, med, 0.0)
        if known:
            const = np.median((a[:, 1] - log_meta)[counts >= MIN_SAMPLES]) \
                if (counts >= MIN_SAMPLES).any() else 0.0
            a = (a - a[:, 1:2]) + (log_meta + const)[:, None]
        r = log_table_at(log_g, z) - log_l - vterm[:, None] - a[vid]
        resid = np.zeros(n_views)
        for c in range(3):
            med, _ = _grouped_median(vid, np.abs(r[:, c]), n_views)
            resid = np.maximum(resid, med / math.log(2))
        resid[counts < MIN_SAMPLES] = float("nan")
        self._last = (log_g, vig)
        response = CameraResponse(np.exp(log_g), method="table", params={
            "source": "shlight passthrough", "views": n_views, "samples": int(len(z)),
            "sigma_deg": self.sigma_deg, "metadata_exposures": known,
            "vignetting": {"v1": float(vig[0]), "v2": float(vig[1]),
                           "model": "exp(v1·ρ² + v2·ρ⁴), ρ from the principal point over "
                                    "the half-diagonal"}})
        return PassthroughResult(
            response=response, exposure=np.exp(a[:, 1]), wb_gains=np.exp(a - a[:, 1:2]),
            residual_stops=resid, samples=counts, vignetting=(float(vig[0]), float(vig[1])),
            file_paths=[v.file_path for v in self.views],
            pose_correction_deg=np.array([s.turned_deg for s in self._samples]))


def _flattest(samples: list) -> list:
    """Per view, the usable samples among the flattest ``KEEP_FLAT`` of the sphere, chosen
    within each band of codes (so that the dark and bright ends, where the sphere is rarely
    flat, still have samples)."""
    code = np.concatenate([s.code.mean(-1) for s in samples])
    usable = np.concatenate([s.usable for s in samples])
    contrast = np.concatenate([s.contrast for s in samples])
    band = np.minimum((code / 16).astype(np.int64), 15)
    keep = usable.copy()
    for b in range(16):
        m = usable & (band == b)
        if m.any():
            keep[m] = contrast[m] <= np.quantile(contrast[m], KEEP_FLAT)
    return np.split(keep, np.cumsum([len(s.usable) for s in samples])[:-1])


def _l1_fit(basis, target, start, iterations: int = 8) -> np.ndarray:
    """Least absolute deviations of ``target`` on ``basis`` (n, k), by reweighting."""
    coef = np.asarray(start, np.float64).copy()
    for _ in range(iterations):
        res = target - basis @ coef
        w = 1.0 / np.maximum(np.abs(res), 1e-3)
        bw = basis * w[:, None]
        try:
            coef = np.linalg.solve(basis.T @ bw + 1e-9 * np.eye(basis.shape[1]), bw.T @ target)
        except np.linalg.LinAlgError:
            break
    return coef


def fit_views(sphere, views, images, **options) -> PassthroughResult:
    """The joint fit of views (:class:`PassthroughView`) and their 8-bit images."""
    fit = PassthroughFit(sphere, **{k: v for k, v in options.items()
                                    if k in ("sigma_deg", "samples_per_view",
                                             "fit_vignetting", "refine_deg")})
    for view, image in zip(views, images):
        fit.add_view(view, image)
    return fit.solve(**{k: v for k, v in options.items() if k in ("iterations", "smoothing")})
