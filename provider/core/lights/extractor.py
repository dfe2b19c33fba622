"""Directional lights plus SH9 ambient (docs/contract.md §10): finding the lights of a frame.

Maths only (numpy + OpenCV; no I/O, no threads). A scene's compact bright sources (a sun, a
lamp, a window) are modelled as directional lights, the rest stays in SH9, and a light is
kept only where it lowers the measured irradiance error. Everything that does not depend on
pixels is precomputed once per projection and frame size in :class:`LightExtractor` (mid
and coarse geometry, seam pixels, the brute-force kernel at 256 normals, the SH9 irradiance
basis there, a fisheye's fill term).

Per frame:

1. **Detect** on a *mid* copy of the linear frame, area-averaged to ~32k pixels (256×128 for
   512×256, 240×120 for 1920×960, 256×144 for a Theta S's 1280×720: ~1.5°/px): a source
   keeps its flux and centroid even when a 0.5° sun is far smaller than a pixel. At each
   *level* t of ``thresholds`` (4, 8, 16, 32, 64 × the frame's mean luminance, solid-angle
   weighted) the 8-connected components of {Y > tμ} are candidates (at most 6 per level,
   each ≥ 1 % of the frame's flux). Components that touch across an image seam (equirect
   wrap-around and poles, cube faces, dual-fisheye lens edges) are merged: seam pixels are
   found once from the projection's directions, so no projection needs its own code.
2. **Split** a light from the rest: a candidate takes only the radiance in *excess* of its
   level, ``L · (1 − tμ/Y)`` (chromaticity kept), so what stays in SH9 is the frame clipped
   at tμ near the source, which SH9 represents well, and a large dim lamp yields little.
   Direction = excess-weighted mean direction d; irradiance ``I_c = Σ excess_c ω_i (d_i·d)``,
   exactly the region's irradiance for every normal that sees the whole region.
3. **Ambient** = the engine's exact SH9 − Σ_k I_k Y(d_k), so ambient + the lights'
   projection is the full SH9 (clients that ignore lights lose nothing).
4. **Measure** like the engine's ``error_estimate``: brute-force irradiance at 256 normals
   from a ~4k-pixel coarse copy of the *rest* plus every candidate's excess at mid
   resolution (a bright source is never smeared by the coarse grid); see
   :class:`~provider.core.lights.analysis.Analysis`.
5. **Choose** greedily up to ``max_lights``: a light is kept only if the error drops by
   ≥ ``min_gain`` (0.2 points) and ≥ ``min_rel_gain`` (10 %). Nested candidates (one source
   at two levels) are never chosen together. Live, the
   :class:`~provider.core.lights.tracking.LightTracker` makes this choice with hysteresis.
   An *elongated* region (major-axis spread ≥ ``ELONGATION`` × its minor one) is scored
   and served as a **chain of discs**: equal-flux segments along its axis, one light each,
   within the lights left free (:func:`~provider.core.lights.analysis.split_chain`,
   :meth:`~provider.core.lights.analysis.Analysis.result`; docs/shadows.md).
6. **Refine** (:meth:`LightExtractor.refine`): a compact light's direction is sharpened on the
   full-resolution pixels under it (a 0.5° sun: from 0.2-0.4° off to 0.02-0.05°).

Measured on the nine shared panoramas (`shlight bench --sections scenes`, lights.md): never
worse than SH9; sky (the sun) 6.1 % → 0.3 % RMS irradiance error.

Usage (one extractor per projection and size; the engine builds it for ``lights="auto"``)::

    x = LightExtractor(projection, max_lights=3)
    result = x(frame, coefficients)                 # stateless: one frame, greedy choice
    analysis = x.analyse(frame_or_mid_copy, coefficients)
    result = x.refine(tracker.update(analysis), analysis, frame)   # live, with hysteresis
"""
from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np

from .. import table_cache
from .caps import excess_irradiance, touching_pairs
from .coarse_truth import CoarseTruth
from .first_pass import first_pass
from ..geometry import sh
from .analysis import (LUMA, Analysis, Candidate, Light, LightsResult, angular_radius_deg,
                       chain_count, elongation, measure, model_irradiance)
from ..geometry.projections import Fisheye, Projection

__all__ = ["LightExtractor", "Analysis", "Candidate", "Light", "LightsResult", "LUMA",
           "model_irradiance"]


class LightExtractor:
    """Finds directional lights in frames of one projection and size.

    Parameters
    ----------
    projection : Projection
        The full-resolution projection of the frames (Equirect, Fisheye, DualFisheye,
        CubeMap, ...): only ``scaled``, ``scaled_source_size``, ``directions()`` and
        ``solid_angle`` are used (plus a Fisheye's fill model, for the truth).
    max_lights : int
        At most this many lights per frame (K).
    thresholds : sequence of float
        Detection levels, in multiples of the frame's mean luminance (solid-angle weighted
        over what the projection sees). At each level every connected bright region is a
        candidate that takes only the radiance in excess of its level. Several levels let
        one frame offer a window wall as one light *or* its two brightest windows as two;
        the measured error decides (nested candidates are never chosen together).
    detect_pixels : int
        Pixel budget of the mid (detection) copy: a factor near ``sqrt(W·H / budget)`` that
        divides W and H (see :meth:`_mid_factor`).
    coarse_pixels : int
        Pixel budget of the coarse copy of the brute-force truth (like error_estimate);
        factor from the mid copy ``ceil(sqrt(w·h / budget))``.
    normals : int
        Number of fibonacci normals at which errors are measured.
    min_gain, min_rel_gain : float
        A light is kept only if it lowers the measured relative RMS error by at least
        ``min_gain`` (absolute; 0.002 = 0.2 points) and ``min_rel_gain`` × the error before.
    min_flux_fraction : float
        Candidates whose excess luminance flux is below this fraction of the frame's total
        are ignored.
    max_candidates : int
        At most this many candidates (largest excess flux first) per level.
    refine_max_px : float
        :meth:`refine` sharpens lights whose region radius is at most this many mid pixels.
    """

    def __init__(self, projection: Projection, *, max_lights: int = 4,
                 thresholds=(4.0, 8.0, 16.0, 32.0, 64.0), detect_pixels: int = 32768,
                 coarse_pixels: int = 4096,
                 normals: int = 256, min_gain: float = 0.002, min_rel_gain: float = 0.1,
                 min_flux_fraction: float = 0.01, max_candidates: int = 6,
                 refine_max_px: float = 4.0):
        self.full = projection
        self.max_lights = int(max_lights)
        self.thresholds = tuple(sorted(float(t) for t in np.atleast_1d(thresholds)))
        self.min_gain, self.min_rel_gain = float(min_gain), float(min_rel_gain)
        self.min_flux_fraction = float(min_flux_fraction)
        self.max_candidates = int(max_candidates)
        self.refine_max_px = float(refine_max_px)

        # Mid (detection) copy.
        W, H = projection.width, projection.height
        fm = self._mid_factor(W, H, detect_pixels)
        self.mid_factor = fm
        self.mid = projection if fm == 1 else projection.scaled(fm)
        self._mid_crop = projection.scaled_source_size(fm)
        h, w = self.mid.height, self.mid.width
        # The mid copy's geometry, most of the lights' build (0.35 s of 0.37 s for a Theta
        # S on a desktop): kept on disk as the SH9 tables are (provider.core.table_cache),
        # so a restart reads it; read-only arrays. Lines about the cache: table_notes.
        self.table_notes: list = []
        geometry = table_cache.cached(
            "lights", table_cache.key_of("lights", table_cache.state_of(projection), fm),
            self._mid_geometry, self.table_notes)
        dirs, omega = geometry["dirs"], geometry["omega"]
        self._dirs, self._omega = dirs, omega                         # (P, 3), (P,)
        self._dirs32 = dirs.astype(np.float32)
        self._omega32 = omega.astype(np.float32).reshape(h, w)
        self._coverage = float(omega.sum())
        self._pixel_angle = _pixel_angle(omega)                      # largest pixel, rad
        self._seam_pairs = geometry["seam_pairs"]                     # (a, b) flat indices
        self._footprint2 = geometry["footprint2"]                     # (P,) rad²

        # Coarse copy and brute-force kernel at the normals.
        fc = max(1, math.ceil(math.sqrt(w * h / coarse_pixels)))
        self.normals = sh.fibonacci_sphere(normals)                    # (N, 3)
        self._normals32 = self.normals.astype(np.float32)
        self._luma32 = LUMA[None].astype(np.float32)
        self._irr_basis = sh.sh_basis(self.normals) * sh.A_HAT_PER_COEFF  # (N, 9)
        self._prefill()
        self.coarse_truth = CoarseTruth(self.mid, fc, self._brute_kernel, self.normals,
                                        linear=self._fill is None)
        self.coarse_factor, self.coarse = fc, self.coarse_truth.coarse

    # -- precomputation -------------------------------------------------------------------------
    #: Rows per band of the engine's integer path (SH9Projector.BAND_ROWS): a mid factor
    #: that divides it keeps the engine's bands at 32 rows, which a cube's work image of 2,
    #: 4, 8 or 16 × 16 blocks shares (its own decode saved).
    BAND_ROWS = 32

    @classmethod
    def _mid_factor(cls, W: int, H: int, budget: int) -> int:
        """Integer factor for the mid copy, one that divides W and H (exact block averages;
        the engine makes its bands a whole number of blocks high): one that divides
        :data:`BAND_ROWS` within 1.2× of sqrt(W·H/budget), else the nearest within 1.5×,
        else the target rounded down.

        Not a divisor of 32 rows further off: a Theta S's 1280×720 takes 5 (256×144, ~1.5°
        a pixel), not 4 (320×180, 1.76× the budget), and its lights' working set fits a
        512 KB cache (issue 44: 14.5 → 11.7 MB of DRAM traffic a frame); 3840×1920 keeps 16
        (1.07× off 15), so its bands stay 32 rows that a 32² cube's work image shares."""
        target = math.sqrt(W * H / budget)
        if target <= 1:
            return 1
        divisors = [f for f in range(1, int(2 * target) + 1) if W % f == 0 and H % f == 0]
        near = [f for f in divisors if abs(math.log(f / target)) < math.log(1.5)]
        close = [f for f in near
                 if cls.BAND_ROWS % f == 0 and abs(math.log(f / target)) < math.log(1.2)]
        for pool in (close, near):
            if pool:
                return min(pool, key=lambda f: (round(abs(math.log(f / target)), 2), f))
        return int(target)

    def _mid_geometry(self) -> dict:
        """The mid copy's pixel-independent tables: ``dirs`` (P, 3) and ``omega`` (P,)
        float64 (unit directions, 0 where unseen; solid angles, sr), ``seam_pairs`` (a, b)
        (the seam's pixels that touch across the sphere: :func:`touching_pairs`) and
        ``footprint2`` (P,) float64 (rad², :func:`pixel_footprint2`)."""
        h, w = self.mid.height, self.mid.width
        dirs = self.mid.directions().reshape(-1, 3).astype(np.float64)
        omega = self.mid.solid_angle.reshape(-1).astype(np.float64)
        angle = _pixel_angle(omega)
        seam = self._seam_pixels(dirs.reshape(h, w, 3), omega.reshape(h, w) > 0, angle)
        py, px = np.mgrid[0:h, 0:w] + 0.5
        return {"dirs": dirs, "omega": omega,
                "seam_pairs": touching_pairs(dirs, seam, math.cos(1.6 * angle)),
                "footprint2": pixel_footprint2(self.mid, px, py).reshape(-1)}

    @staticmethod
    def _seam_pixels(dirs, valid, pixel_angle: float) -> np.ndarray:
        """Flat indices of mid pixels where the image is not the whole neighbourhood: the
        image border, next to an unseen pixel, or next to a pixel more than 3 pixel sizes
        (``pixel_angle``, rad) away (a face or lens boundary). Regions can touch across the
        sphere only there."""
        h, w = valid.shape
        seam = np.zeros((h, w), bool)
        seam[0, :] = seam[-1, :] = seam[:, 0] = seam[:, -1] = True
        far = math.cos(3 * pixel_angle)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                if dx == dy == 0:
                    continue
                ys = slice(max(dy, 0), h + min(dy, 0))
                yd = slice(max(-dy, 0), h + min(-dy, 0))
                xs = slice(max(dx, 0), w + min(dx, 0))
                xd = slice(max(-dx, 0), w + min(-dx, 0))
                nb_valid = valid[ys, xs]
                cosang = np.sum(dirs[ys, xs] * dirs[yd, xd], axis=-1)
                seam[yd, xd] |= ~nb_valid | (cosang < far)
        return np.flatnonzero(seam & valid)

    def _prefill(self):
        """What a fisheye's fill model (the unseen cap) adds to brute-force irradiance."""
        self._fill = None
        p = self.full
        if isinstance(p, Fisheye) and p.fill != "zero" and p.albedo > 0:
            axis = p.lens.frame[0]
            if p.fill == "ground":
                # ∫_cap max(0, n·ω) dω per normal, by quadrature on a dense lattice.
                lattice = sh.fibonacci_sphere(20000)
                in_cap = np.arccos(np.clip(lattice @ axis, -1, 1)) > p.lens.theta_max
                cap = (np.maximum(self.normals @ lattice[in_cap].T, 0.0).sum(axis=1)
                       * (4 * math.pi / len(lattice)))
                self._fill = ("ground", axis, cap, p.albedo, p.lens.theta_max)
            else:
                self._fill = ("mirror", axis, None, p.albedo, p.lens.theta_max)

    def _brute_kernel(self, dirs: np.ndarray, omega: np.ndarray, normals=None) -> np.ndarray:
        """(N, n): irradiance at the normals per unit radiance of each pixel (with fill)."""
        normals = self.normals if normals is None else normals
        K = np.maximum(normals @ dirs.T, 0.0) * omega
        if self._fill is not None:
            kind, axis, cap, albedo, tmax = self._fill
            cos_axis = dirs @ axis
            if kind == "ground":
                K = K + (albedo / math.pi) * np.outer(cap, np.maximum(cos_axis, 0.0) * omega)
            else:
                theta = np.arccos(np.clip(cos_axis, -1, 1))
                into = (math.pi - theta) > tmax
                refl = dirs - 2 * cos_axis[:, None] * axis
                K = K + albedo * np.maximum(normals @ refl.T, 0.0) * (omega * into)
        return K

    def _excess_irradiance(self, pix, excess, region) -> np.ndarray:
        """(N, 3) brute-force irradiance at the normals of ``excess`` (n, 3) float32 radiance
        on the mid pixels ``pix`` in ``region`` s (their level-0 groups), by caps
        (:func:`~provider.core.lights.caps.excess_irradiance`: the full kernel was 17 M
        of the lit Theta room's 38 M instructions of lights a frame, callgrind)."""
        omega = np.take(self._omega32.reshape(-1), pix)
        if self._fill is not None:          # the fill's mirror term is no cap: the kernel
            return self._brute_kernel(self._dirs32[pix], omega,
                                      self._normals32).astype(np.float64) @ excess
        return excess_irradiance(self.normals, self._normals32, self._dirs, self._dirs32,
                                 excess * omega[:, None], pix, region)

    def _residual(self, d: np.ndarray) -> np.ndarray:
        """g(n) = max(0, n·d) − SH9 irradiance of a unit directional light d, at the normals:
        (N,) for one direction (3,), (N, m) for m directions (m, 3)."""
        d = np.asarray(d, np.float64)
        return np.maximum(self.normals @ d.T, 0.0) - self._irr_basis @ sh.sh_basis(d).T

    # -- per frame ------------------------------------------------------------------------------
    def reduce(self, frame: np.ndarray, clean: bool = False) -> np.ndarray:
        """The mid copy (h, w, 3) float32 of a linear frame given at full or at mid size.

        Area averaging (cv2.INTER_AREA) of *linear* radiance keeps every source's flux and
        centroid, however small it is. Negatives (resampling ringing) are clamped to 0.
        ``clean``: ``frame`` is a mid copy that holds no negative or non-finite sample (a
        table's block means, :class:`DetectionCopy`): returned as it is.
        """
        f = frame if frame.dtype == np.float32 else frame.astype(np.float32)
        if f.shape[:2] == (self.mid.height, self.mid.width):
            if clean:
                return f
            small = f
        else:
            bw, bh = self._mid_crop
            small = cv2.resize(f[:bh, :bw], (self.mid.width, self.mid.height),
                               interpolation=cv2.INTER_AREA)
        return cv2.max(small, 0.0)

    def fusable(self, band_rows: int) -> bool:
        """True when :meth:`reduce_band` can build the mid copy from bands of ``band_rows``
        rows (the factor divides the frame and the band height)."""
        f = self.mid_factor
        return (f == 1 or (self.full.width % f == 0 and self.full.height % f == 0
                           and band_rows % f == 0
                           and self._mid_crop == (self.full.width, self.full.height)))

    def new_mid(self) -> np.ndarray:
        """An empty mid copy (h, w, 3) float32 for :meth:`reduce_band`."""
        return np.empty((self.mid.height, self.mid.width, 3), np.float32)

    def reduce_band(self, band: np.ndarray, r0: int, mid: np.ndarray, spans=None) -> None:
        """Area-average rows [r0, r0 + len) of the *linear* frame into ``mid`` (exact block
        means: the same mid copy as :meth:`reduce` of the whole frame; see :meth:`fusable`).
        ``spans``: [(a, b)] column ranges (multiples of the factor, increasing) outside which
        the band is zero: only they are averaged, the rest of the mid rows set to 0."""
        f = self.mid_factor
        if f == 1:
            mid[r0:r0 + band.shape[0]] = band
            return
        h = band.shape[0] // f
        spans = spans if spans is not None else [(0, band.shape[1])]
        edge = 0
        for a, b in spans + [(band.shape[1], band.shape[1])]:
            if a > edge:
                mid[r0 // f:r0 // f + h, edge // f:a // f] = 0.0
            edge = b
        halvings = f.bit_length() - 1 if f & (f - 1) == 0 else 0
        for a, b in spans:
            if halvings:
                # f a power of two: halved again and again with INTER_LINEAR, which at
                # exactly half size weighs each pixel pair ½, ½: the block means to float
                # rounding at 2.7 instructions a float, against 4.0 for the row sums and
                # column area resize below (callgrind, a 32×1272 band, f = 4; issue 34).
                part, hh, ww = band[:h * f, a:b], h * f, b - a
                for _ in range(halvings):
                    hh, ww = hh // 2, ww // 2
                    part = cv2.resize(part, (ww, hh), interpolation=cv2.INTER_LINEAR)
                mid[r0 // f:r0 // f + h, a // f:b // f] = part
                continue
            # Rows first (a sum of f contiguous rows), then columns on a 1/f-size band: the
            # same block means as one area resize, at a quarter of its instructions (f = 4).
            rows = np.add.reduce(band[:h * f, a:b].reshape(h, f, (b - a) * 3), axis=1)
            rows *= np.float32(1.0 / f)
            mid[r0 // f:r0 // f + h, a // f:b // f] = cv2.resize(
                rows.reshape(h, b - a, 3), ((b - a) // f, h), interpolation=cv2.INTER_AREA)

    def analyse(self, frame: np.ndarray, coefficients: np.ndarray,
                clean: bool = False, mean_scale: float = 1.0, first=None) -> Analysis:
        """Candidates and truth of one frame.

        frame : (H, W, 3) linear float32 radiance at full size, or its mid copy
            (``mid.height × mid.width``, see :meth:`reduce`; ``clean``: a mid copy with no
            negative or non-finite sample; ``mean_scale``: what makes a mid copy of block sums
            the block means, applied in place; ``first``: the first pass's (Y, total,
            coarse, Ymax) of a clean mid copy where a fused kernel ran it).
        coefficients : (9, 3) the exact SH9 of the full frame (what the engine serves).
        """
        # C-contiguous float32 (a copy where not), scaled in place by the first pass
        small = np.ascontiguousarray(self.reduce(frame, clean), np.float32)
        h, w = small.shape[:2]
        Y, total, coarse, Ymax = first if first is not None else first_pass(
            small, mean_scale, *self.first_pass_args((h, w)))
        mu = total / self._coverage if self._coverage > 0 else 0.0
        candidates, groups = [], []
        rest, extra = small, None
        idx0 = np.zeros(0, np.intp)
        if mu > 0 and math.isfinite(mu):   # in the rows that hold a pixel above (Ymax)
            rows = np.flatnonzero(Ymax > self.thresholds[0] * mu)
            k = np.flatnonzero(Y[rows] > self.thresholds[0] * mu)
            idx0 = rows[k // w] * w + k % w
        if idx0.size:
            # Everything below works on the pixels above the lowest level only (a few %).
            flat = small.reshape(-1, 3)
            Y0_32 = Y.reshape(-1)[idx0]
            Y0 = Y0_32.astype(np.float64)
            # np.take: a row gather at a tenth of fancy indexing's instructions
            L0 = np.take(flat, idx0, axis=0).astype(np.float64)
            top = float(Y0.max())
            mask = np.zeros((h, w), np.uint8)
            for level, t in enumerate(self.thresholds):
                if top <= t * mu:
                    break                    # no pixel above this level (nor any higher)
                # Every pixel above a level is one of idx0: its mask is set from them, not
                # from another pass over Y (the same float32 comparison); 16-bit labels (a
                # Theta S's 36,864 mid pixels hold fewer components). Each pass over the mid
                # copy's planes goes to DRAM on a 512 KB cache (issue 44).
                mask.reshape(-1)[idx0] = Y0_32 > t * mu
                n, labels = cv2.connectedComponents(mask, connectivity=8, ltype=cv2.CV_16U)
                found, group_local = self._level(idx0, Y0, L0, labels.reshape(-1), n, t * mu,
                                                 total, level)
                candidates += found
                groups.append(group_local)
        if candidates:
            # Truth: the coarse copy of the rest plus, at mid resolution, every candidate
            # pixel's radiance above the lowest level (no source is smeared by the coarse grid).
            inside = np.zeros(idx0.size, bool)
            for c in candidates:
                inside[c.local] = True
            ul = np.flatnonzero(inside)
            union = idx0[ul]
            exc = (np.take(L0, ul, axis=0) * (1.0 - self.thresholds[0] * mu / Y0[ul])[:, None]
                   ).astype(np.float32)
            extra = self._excess_irradiance(union, exc, groups[0][ul])
            if coarse is not None:
                rest = self.coarse_truth.rest(small, union, exc, coarse)
            else:
                rest = flat.copy()
                at = (union[:, None] * 3 + np.arange(3)).reshape(-1)     # flat, as above
                rest.reshape(-1)[at] -= exc.reshape(-1)
                rest = rest.reshape(h, w, 3)
        if rest is small and coarse is not None:
            rest = coarse
        elif self.coarse_factor > 1 and rest.shape[:2] == (h, w):   # still at mid size
            rest = self.coarse_truth.rest(rest)
        truth = self.coarse_truth(rest)
        if extra is not None:
            truth += extra
        return Analysis(self, coefficients, candidates, truth, groups, mu)

    def first_pass_args(self, shape: tuple) -> tuple:
        """(luma (3,), omega (h, w), coarse (wc, hc) where its pixels are whole blocks else
        None, factor): the first pass's arguments for a mid copy of ``shape`` (h, w) but the
        copy and its scale (a fused kernel runs it: :meth:`.LensFold.decode_project`)."""
        t = self.coarse_truth
        whole = t.blocks and tuple(shape) == (self.mid.height, self.mid.width)
        return (self._luma32.reshape(3), self._omega32,
                (t.coarse.width, t.coarse.height) if whole else None, t.factor)

    def _level(self, idx0, Y0, L0, labels, n, level_value, total, level):
        """Candidates of one threshold level. ``idx0`` are the flat indices of the pixels
        above the lowest level (``Y0``, ``L0`` their luminance and RGB); returns the
        candidates and the group id (0: none) of each of those pixels at this level."""
        if n <= 1:
            return [], np.zeros(idx0.size, np.int32)
        # Merge components that touch across a seam (union-find on the seam's pairs of
        # touching pixels, found once: _touching_pairs).
        root = np.arange(n)
        if len(self._seam_pairs[0]):
            la, lb = labels[self._seam_pairs[0]], labels[self._seam_pairs[1]]
            differ = np.flatnonzero((la != lb) & (la > 0) & (lb > 0))
            if len(differ):
                la, lb = la[differ], lb[differ]
                lo, hi = np.minimum(la, lb), np.maximum(la, lb)
                code = np.unique(lo.astype(np.int64) * n + hi)
                pairs = np.stack([code // n, code % n], 1)

                def find(a):
                    while root[a] != a:
                        root[a] = root[root[a]]
                        a = root[a]
                    return a
                for a, b in pairs:
                    ra, rb = find(a), find(b)
                    if ra != rb:
                        root[max(ra, rb)] = min(ra, rb)
                for a in np.unique(pairs):
                    root[a] = find(a)
        glocal = root[labels[idx0]]                               # group of each bright pixel
        loc = np.flatnonzero(glocal)
        g = glocal[loc]
        pix_all = idx0[loc]
        keep = 1.0 - level_value / Y0[loc]                        # excess fraction
        ex = np.take(L0, loc, axis=0) * keep[:, None]             # (m, 3) excess radiance
        om = self._omega[pix_all]
        wgt = (ex @ LUMA) * om                                    # excess luminance flux
        fluxY = np.bincount(g, wgt, minlength=n)
        order = np.argsort(-fluxY)
        order = [int(k) for k in order[: self.max_candidates]
                 if k > 0 and fluxY[k] > 0 and fluxY[k] >= self.min_flux_fraction * total]
        out = []
        for k in order:
            sel = np.flatnonzero(g == k)
            pix, exm = pix_all[sel], np.take(ex, sel, axis=0)
            dk = np.take(self._dirs, pix, axis=0)
            (whole,), ang = measure(dk, exm, om[sel], self._footprint2[pix])
            out.append(Candidate(whole.direction, whole.flux, whole.irradiance,
                                 whole.spread_deg, math.degrees(float(ang.max())), level, k,
                                 pix, exm, local=loc[sel],
                                 angular_radius_deg=whole.angular_radius_deg))
            # An elongated region may become a chain of discs (docs/shadows.md).
            ratio, major, position = elongation(dk, wgt[sel], whole.direction)
            most = chain_count(ratio, major, self._pixel_angle, self.max_lights)
            if most > 1:
                out[-1].most_segments = most
                out[-1].position = position
        return out, glocal

    def refine(self, result: LightsResult, analysis: Analysis, frame) -> LightsResult:
        """Sharpen the direction of compact lights on the full-resolution frame.

        A source smaller than a mid pixel (a real 0.5° sun at 1920×960 against 1.5° mid
        pixels) gets the direction of the pixel centre(s) it fell in: up to half a mid pixel
        off. For each light whose region spans at most ``refine_max_px`` mid pixels in
        radius, the excess-weighted mean direction is recomputed from the full-resolution
        pixels under the region's bounding box (a few hundred pixels: directions and solid
        angles from ``projection.pixel_to_direction``, by finite differences, so any
        projection works). Irradiance is kept (area averaging preserves flux) and the
        ambient is recomputed so ambient + lights stays equal to the full SH9.

        frame : the full-resolution linear radiance (H, W, 3), or any object whose 2-D
            slices ``frame[r0:r1, c0:c1]`` return linear float radiance (e.g. a wrapper
            that applies the engine's sRGB table to an 8-bit frame on demand).
        """
        f = self.mid_factor
        if f == 1 or not result.lights:
            return result
        W, w = self.full.width, self.mid.width
        lights, ambient = [], analysis.coefficients.copy()
        for light in result.lights:
            c = analysis.candidates[light.source] if light.source >= 0 else None
            d = light.direction
            radius = light.angular_radius_deg
            compact = c is not None and c.radius_deg <= math.degrees(self.refine_max_px
                                                                     * self._pixel_angle)
            if compact and light.chain == 1:                  # a segment keeps its own
                rows, cols = c.pixels // w, c.pixels % w
                if cols.max() - cols.min() < w // 2:          # not split by a seam
                    r0, r1 = max(0, (rows.min() - 1) * f), min(self.full.height,
                                                                (rows.max() + 2) * f)
                    c0, c1 = max(0, (cols.min() - 1) * f), min(W, (cols.max() + 2) * f)
                    roi = np.asarray(frame[r0:r1, c0:c1], np.float64)
                    py, px = np.mgrid[r0:r1, c0:c1] + 0.5
                    dirs, valid = self.full.pixel_to_direction(px, py)
                    dx, dy = pixel_sides(self.full, px, py)
                    om = np.linalg.norm(np.cross(dx, dy), axis=-1) * valid
                    level = self.thresholds[c.level] * analysis.mu
                    ex = np.maximum(roi @ LUMA - level, 0.0) * om
                    v = np.tensordot(ex, dirs, axes=([0, 1], [0, 1]))
                    nv = np.linalg.norm(v)
                    if nv > 0 and float(v @ d) / nv > math.cos(2 * self._pixel_angle):
                        d = v / nv
                        ang = np.arccos(np.clip(dirs @ d, -1.0, 1.0))
                        fp2 = _footprint2(dx, dy)
                        radius = angular_radius_deg(ex[valid], ang[valid], fp2[valid])
            ambient -= sh.sh_basis(d)[:, None] * light.irradiance[None, :]
            lights.append(replace(light, direction=d, angular_radius_deg=radius))
        return LightsResult(lights, ambient, result.light_error, result.sh9_error,
                            result.candidates)

    def extract(self, frame, coefficients, *, tracker=None, full=None,
                process=None, clean: bool = False, mean_scale: float = 1.0,
                first=None) -> LightsResult:
        """The lights of one frame, as the engine serves them.

        frame : linear float32 radiance at full size or the mid copy (see :meth:`analyse`).
        coefficients : (9, 3) the frame's exact SH9, in the units of ``frame``.
        tracker : a :class:`~provider.core.lights.tracking.LightTracker` (live, hysteresis),
            or None for the per-frame greedy choice (a single image).
        full : the full-resolution linear frame (an array or a :class:`LinearView`) to
            :meth:`refine` compact lights on, or None.
        process : a function applied to the ambient (9, 3), e.g. the engine's deringing and
            order truncation; ``light_error`` then measures the processed ambient.
        clean, mean_scale, first : ``frame`` is a mid copy with no negative or non-finite
            sample; what makes it block means; its first pass (see :meth:`analyse`).
        """
        a = self.analyse(frame, coefficients, clean, mean_scale, first)
        if tracker is None:
            a.rank()
            r = a.result(a.greedy())
        else:
            r = tracker.update(a)
        if full is not None:
            r = self.refine(r, a, full)
        if process is not None:
            processed = process(r.ambient)
            if not np.array_equal(processed, r.ambient):
                r.light_error = a.error_of(a.served_model(r.lights)
                                           + self._irr_basis @ (processed - r.ambient))
                r.ambient = processed
        return r

    def __call__(self, frame: np.ndarray, coefficients: np.ndarray) -> LightsResult:
        """Stateless per-frame lights: greedy by measured error (no hysteresis); lights
        are refined on ``frame`` when it is the full-resolution frame."""
        full = frame if frame.shape[:2] == (self.full.height, self.full.width) else None
        return self.extract(frame, coefficients, full=full)


def _pixel_angle(omega: np.ndarray) -> float:
    """The side of the largest pixel of solid angles ``omega`` (sr): rad."""
    return float(np.sqrt(omega.max()))


def pixel_sides(projection, px, py) -> tuple[np.ndarray, np.ndarray]:
    """The direction vectors a pixel's width and height span at centres (px, py): central
    differences of ``projection.pixel_to_direction``, so any projection works."""
    dx = (projection.pixel_to_direction(px + 0.5, py)[0]
          - projection.pixel_to_direction(px - 0.5, py)[0])
    dy = (projection.pixel_to_direction(px, py + 0.5)[0]
          - projection.pixel_to_direction(px, py - 0.5)[0])
    return dx, dy


def _footprint2(dx, dy) -> np.ndarray:
    """``(w² + h²) / 12`` from a pixel's sides (:func:`pixel_sides`)."""
    return (np.sum(dx * dx, axis=-1) + np.sum(dy * dy, axis=-1)) / 12.0


def pixel_footprint2(projection, px, py) -> np.ndarray:
    """Mean squared angular offset (rad²) of a pixel's area about its centre, per pixel:
    ``(w² + h²) / 12`` with w, h the angles its sides span (:func:`pixel_sides`; 0 where
    invalid)."""
    valid = projection.pixel_to_direction(px, py)[1]
    return np.where(valid, _footprint2(*pixel_sides(projection, px, py)), 0.0)
