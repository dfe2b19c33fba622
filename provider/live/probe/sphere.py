"""A probe's latest frame as the sphere of light the room's other consumers look up.

The passthrough fit (:mod:`.passthrough`) compares a headset's views with it and the light
at points (:mod:`.points`) re-projects it through the room: both need the frame as linear
light *in the units and the frame of the probe's coefficients*, so that what they give
agrees with the SH9 a hologram is lit by. One function, one place, for both.
"""
from __future__ import annotations

import numpy as np

from ...core.errors import InputError

#: The sphere the fit samples is at most this many rows (0.35° a pixel, finer than its 1° blur;
#: three float64 copies of it are ~38 MB a headset).
SPHERE_HEIGHT = 512


def sphere_of(probe, rows: int = SPHERE_HEIGHT) -> np.ndarray:
    """The probe's latest frame as linear radiance on an equirect of at most ``rows`` rows,
    in the units and the frame of the probe's coefficients (what a hologram is lit by): a
    float frame's values, an integer one's through the probe's camera curve (sRGB without
    ``--camera``), times the probe's ``image_scale`` (``--exposure``, the frame's 1/(t·gain),
    an absolute curve's C·N²); resampled from its projection (the projector's own, with its
    lens and options) and turned by its ``--rotate`` into the world's frame."""
    from ...core.geometry.projections import make_projection
    from ...core.passthrough.sphere import to_equirect
    from ...core.radiometry.response import CameraResponse
    image, scale = probe.image, getattr(probe, "image_scale", 1.0)
    if image is None:
        raise InputError(f"probe {probe.name} has no frame yet: no sphere to fit against")
    img = np.asarray(image)
    if img.ndim != 3 or img.shape[2] < 3:
        raise InputError(f"probe {probe.name}'s frame is not RGB: no sphere to fit against")
    if scale is None:
        raise InputError(f"probe {probe.name} merges brackets: its slot frames are not the "
                         "merged light, no sphere to fit against")
    img = img[..., :3]
    h, w = img.shape[:2]
    projector = probe._projectors.get((w, h))
    if img.dtype.kind == "f":
        lin = np.nan_to_num(img.astype(np.float32), nan=0.0, posinf=0.0, neginf=0.0)
        lin = np.maximum(lin, 0.0)          # as the engine cleans a float frame's samples
    else:
        bits = 8 if img.dtype == np.uint8 else 16
        response = getattr(projector, "response", None) or CameraResponse.srgb(bits)
        if response.bits != bits:
            response = response.to_bits(bits)
        lin = response.linearise(np.ascontiguousarray(img))
    lin = lin * np.float32(scale)
    projection = getattr(projector, "full_projection", None) or make_projection(
        probe.projection, w, h)
    rotation = getattr(projector, "rotation", None)
    lin = to_equirect(lin, projection, rows, rotation)
    if lin.shape[0] > rows:
        import cv2
        lin = cv2.resize(lin, (2 * rows, rows), interpolation=cv2.INTER_AREA)
    return np.asarray(lin, np.float64)
