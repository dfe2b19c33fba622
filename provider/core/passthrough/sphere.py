"""The sphere in any projection the engine reads, as the equirect panorama the fit samples.

The fit (:mod:`.fit`) looks the sphere up in arbitrary directions; an equirect panorama
(docs/contract.md §1) is the simplest table for that. A fisheye, a dual fisheye or a cube
map is resampled into one through the projection's own inverse direction map
(:func:`provider.core.geometry.sphere_views.direction_to_pixel`); what the projection does
not see is 0, which the fit reads as "nothing to compare here".
"""
from __future__ import annotations

import cv2
import numpy as np

from ..geometry.projections import Equirect, Projection
from ..geometry.sphere_views import direction_to_pixel

#: The equirect's height when resampling: 0.35° a pixel, finer than the fit's 1° blur.
HEIGHT = 512


def to_equirect(image: np.ndarray, projection: Projection, height: int = HEIGHT,
                rotation=None) -> np.ndarray:
    """``image`` (H, W, 3) seen through ``projection``, resampled bilinearly to a 2:1
    equirect of ``height`` rows (float32); 0 where the projection sees nothing.
    ``rotation`` (3 × 3, camera → world, as :class:`~provider.core.sh9.engine.SH9Projector`
    takes it): the equirect is in the world's frame, as the coefficients are."""
    if isinstance(projection, Equirect) and rotation is None:
        return np.asarray(image, np.float32)
    height = int(min(height, max(image.shape[0], 64)))
    target = Equirect(2 * height, height)
    ys, xs = np.mgrid[0:height, 0:2 * height]
    dirs, _ = target.pixel_to_direction(xs + 0.5, ys + 0.5)
    if rotation is not None:        # world d seen by the camera along Rᵀd (row vectors: d R)
        dirs = np.asarray(dirs, np.float64) @ np.asarray(rotation, np.float64)
    px, py, seen = direction_to_pixel(projection, dirs)
    pad = 2
    src = cv2.copyMakeBorder(np.asarray(image, np.float32), pad, pad, pad, pad,
                             cv2.BORDER_REPLICATE)
    map_x = np.where(seen, px - 0.5 + pad, -10).astype(np.float32)
    map_y = np.where(seen, py - 0.5 + pad, -10).astype(np.float32)
    return cv2.remap(src, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                     borderValue=0)
