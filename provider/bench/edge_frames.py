"""The edge bench's Theta S frame: a lit room as the camera records it.

A synthetic pattern of walls and two small clipped dots held no light the extractor would
take (each dot under 1 % of the frame's flux), so "SH9 + lights" counted the detection but
never the work of lights found. This frame is :mod:`provider.bench.room`'s analytic room (a
6 × 3 × 5 m box lit by two ceiling panels and a window) seen from a tripod, resampled
through the project's own dual-fisheye projection into a 1280×720 8-bit sRGB frame: the
extractor finds the ceiling panels as lights (``tests/bench/test_edge_frames.py``).
"""
from __future__ import annotations

import functools

#: The tripod: 1.4 m up, off the room's centre, so the two panels are not symmetric.
THETA_AT = (3.0, 1.4, 2.2)
#: Exposure below the camera's auto exposure (median luminance at mid-grey), in stops: a
#: lighting probe is set so its lamps do not clip (a clipped lamp's excess is lost).
EXPOSURE_STOPS = -2.0


@functools.lru_cache(maxsize=2)
def lit_theta_frame(width: int = 1280, height: int = 720):
    """The lit room as a Ricoh Theta S live frame: (height, width, 3) uint8 sRGB, black
    outside the two image circles; read-only (cached: the bench and its callers share one)."""
    from . import room
    from .common import _auto_exposure, _to_srgb8
    panorama = room.panorama(THETA_AT, height=max(64, height // 2), supersample=2)
    fisheye = to_dual_fisheye(panorama, width, height)
    frame = _to_srgb8(fisheye, _auto_exposure(panorama) * 2.0 ** EXPOSURE_STOPS)
    frame.setflags(write=False)
    return frame


def to_dual_fisheye(panorama, width: int = 1280, height: int = 720):
    """An equirect ``panorama`` (h, w, 3) resampled through the project's dual-fisheye
    projection into a (height, width, 3) float32 Theta S frame, black outside the two image
    circles (bilinear, wrapping at the panorama's seam)."""
    import cv2
    import numpy as np
    from ..core.geometry.projections import DualFisheye
    ph, pw = panorama.shape[:2]
    py, px = np.mgrid[0:height, 0:width].astype(np.float32) + 0.5
    d, valid = DualFisheye(width, height).pixel_to_direction(px, py)
    # equirect lookup in the contract's frame (docs/contract.md §1: +Y up, -Z the centre)
    theta = np.arccos(np.clip(d[..., 1], -1, 1))
    phi = np.arctan2(d[..., 0], -d[..., 2])
    mapx = ((phi / (2 * np.pi) + 0.5) * pw - 0.5).astype(np.float32)
    mapy = (theta / np.pi * ph - 0.5).astype(np.float32)
    out = cv2.remap(np.ascontiguousarray(panorama, np.float32), mapx, mapy, cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_WRAP)
    out[~valid] = 0
    return out
