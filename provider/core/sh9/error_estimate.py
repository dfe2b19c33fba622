"""The per-frame error estimate (``error_estimate=True``): the relative RMS difference between
SH9 irradiance and brute-force irradiance, both from one coarse copy of the frame (about 4k
pixels), so the figure measures the SH9 truncation (and the windowing and order choices), not
the resolution. What depends on geometry (the coarse copy, its directions, the 256 normals'
cosine kernel) is built once, on the first frame."""
from __future__ import annotations

import math

import cv2
import numpy as np

from ..geometry import projections_exr, sh
from ..geometry.projections import Projection, ProjectionError


class ErrorEstimator:
    """Built once per projector from its projection; :meth:`estimate` per frame."""

    def __init__(self, p: Projection):
        # blocks that never straddle two faces of a cube; then finer where a lens circle is
        # too small for the coarse copy
        factor = wanted = projections_exr.whole_face_factor(
            p, max(1, int(math.sqrt(p.width * p.height / 4096))))
        coarse = p
        while factor > 1:
            try:
                coarse = p.scaled(factor)
                break
            except ProjectionError:     # a lens circle too small for this copy: finer
                factor //= 2
        dirs = coarse.directions().reshape(-1, 3)
        omega = coarse.solid_angle.reshape(-1)
        sh_w = coarse.sh_weights  # (P, 9), includes any fill model
        # A finer copy than wanted (a small lens circle in a large frame): only the pixels
        # that carry light, or the kernel would be (256, the whole frame).
        seen = None if factor == wanted else \
            np.flatnonzero((omega != 0) | np.any(sh_w != 0, axis=1))
        if seen is not None:
            dirs, omega, sh_w = dirs[seen], omega[seen], sh_w[seen]
        self.factor, self.coarse, self.crop = factor, coarse, p.scaled_source_size(factor)
        self.normals = sh.fibonacci_sphere(256)
        self.kernel = np.maximum(self.normals @ dirs.T, 0.0) * omega  # (256, P)
        self.sh_weights, self.seen = sh_w, seen

    def estimate(self, lin: np.ndarray, processing) -> float:
        """The relative RMS error of frame ``lin`` (linear, the projection's size), with
        ``processing(coefficients)`` the result's own order and window choices."""
        crop, coarse = self.crop, self.coarse
        small = lin if self.factor == 1 else cv2.resize(
            lin[:crop[1], :crop[0]], (coarse.width, coarse.height), interpolation=cv2.INTER_AREA)
        px = small.reshape(-1, 3).astype(np.float64)
        if self.seen is not None:
            px = px[self.seen]
        truth = self.kernel @ px
        approx = sh.irradiance(processing(self.sh_weights.T @ px), self.normals)
        return sh.relative_rms(approx, truth)
