"""A lux meter closes what the camera clipped (no I/O).

An 8-bit camera clips the sun in every exposure it can take: the frame holds the sun at its
clip level, a lower bound, and a sunny scene loses half its light or more
(``clipped_light_fraction``). An up-facing lux meter beside the camera measures the
illuminance ``E_meter`` that all of the light gives, the sun included. With the frame in
absolute units (cd/m², :mod:`~provider.core.radiometry.photometry`), the camera explains

    E_camera = Σ_pixels Y(L) · max(d·up, 0) · dω        (Y: Rec. 709 luminance, lux)

and the rest, ``ΔE = E_meter − E_camera``, is light the camera did not measure. It goes to
the clipped region the meter sees most (the connected clipped blob with the largest
``Σ max(d·up, 0)·dω``): every pixel of that blob gets the same extra radiance
``ΔL = ΔE / Σ_blob max(d·up, 0)·dω`` (neutral: equal R, G, B, luminance ΔL; the clipped
pixels say nothing of its colour). The closed radiance is then projected as any frame: the
light finder sees the sun as a light, SH9 holds it, and the message says what the meter
closed (:func:`closure_fields`). A meter reading below what the camera already sees closes
nothing (the calibration or the meter is off: said, not hidden); a blob the meter cannot
see (below its horizon) cannot be closed by it.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..geometry.projections import Equirect
from ..errors import InputError
from ..radiometry.photometry import absolute_calibration, luminance

UP = np.array([0.0, 1.0, 0.0])


@dataclass
class MeterClosure:
    """What the meter closed. ``lux``: its reading; ``camera_lux``: what the frame explains
    (exact, from the pixels); ``closed_lux``: what was added (0 when nothing);
    ``direction``: the blob's mean direction (world frame; zeros when nothing);
    ``solid_angle_sr``: the blob's solid angle; ``note``: why nothing was closed, or ''."""

    lux: float
    camera_lux: float
    closed_lux: float = 0.0
    direction: tuple = (0.0, 0.0, 0.0)
    solid_angle_sr: float = 0.0
    note: str = ""


def up_weights(projection, rotation=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per pixel: ``∫ max(d·up, 0) dω`` (sr, the meter's cosine), the solid angle (sr) and
    the world direction (H, W, 3). Equirect without rotation: exact per row
    (Δφ·½(sin²θ_b − sin²θ_t) over the upper hemisphere); otherwise the pixel centre's
    cosine times the pixel's solid angle (equirect: exact per row; others: the
    projection's)."""
    directions = projection.directions()
    if isinstance(projection, Equirect):
        h, w = projection.height, projection.width
        edges = np.linspace(0.0, np.pi, h + 1)
        omega = np.broadcast_to(((np.cos(edges[:-1]) - np.cos(edges[1:])) * (2 * np.pi / w))
                                [:, None], (h, w))
        if rotation is None:
            s2 = np.sin(np.minimum(edges, np.pi / 2)) ** 2
            cos_row = 0.5 * (s2[1:] - s2[:-1]) * (2 * np.pi / w)
            return np.broadcast_to(cos_row[:, None], (h, w)), omega, directions
    else:
        omega = projection.solid_angle
    if rotation is not None:
        directions = directions @ np.asarray(rotation, np.float64).T
    return np.maximum(directions @ UP, 0.0) * omega, omega, directions


def has_absolute_scale(response) -> bool:
    """Whether frames decoded with ``response`` can be in absolute units (camera.json
    ``params.absolute``); a malformed one is reported per frame, as before."""
    try:
        return absolute_calibration(response) is not None
    except InputError:
        return False


def pixels_up_illuminance(projector, frame: np.ndarray, scale: float = 1.0) -> float | None:
    """:meth:`~provider.core.sh9.engine.SH9Projector.up_illuminance` of a frame from its
    pixels: the projector's up weights (built once, kept on it) times the linear frame."""
    if projector._up is None:
        if projector.downsample != 1:     # equirect frames are never downsampled (withdrawn)
            return None
        projector._up = np.ascontiguousarray(
            up_weights(projector._full, projector.rotation)[0], np.float32).reshape(-1)
    if frame.shape[0] * frame.shape[1] != projector._up.size:
        return None
    if frame.dtype in (np.uint8, np.uint16):
        from ..radiometry.response import apply_lut
        lin = apply_lut(frame, projector._lut(frame.dtype))
    else:
        lin = np.maximum(np.nan_to_num(np.asarray(frame, np.float32), nan=0.0,
                                       posinf=0.0), 0.0) * np.float32(projector.exposure)
    rgb = projector._up @ np.ascontiguousarray(lin, np.float32).reshape(-1, 3)
    return max(float(luminance(rgb)) * float(scale), 0.0)


def close_clipped(radiance: np.ndarray, clipped: np.ndarray, weights, lux: float):
    """(radiance with the meter's missing light in the clipped blob, :class:`MeterClosure`).

    ``radiance``: (H, W, 3) float32 in cd/m²; ``clipped``: (H, W) bool, samples clipped in
    every frame; ``weights``: :func:`up_weights` of the frame's projection; ``lux``: the
    up-facing meter's reading."""
    cosw, omega, directions = weights
    camera = float(luminance(np.tensordot(cosw, np.nan_to_num(radiance, nan=0.0),
                                          axes=([0, 1], [0, 1]))))
    closure = MeterClosure(float(lux), camera)
    missing = float(lux) - camera
    if missing <= 0:
        closure.note = (f"the meter reads {lux:.4g} lux, no more than the {camera:.4g} lux "
                        "the camera already sees: nothing to close (is the absolute scale "
                        "right, the meter beside the camera and facing up?)")
        return radiance, closure
    n, labels = cv2.connectedComponents(clipped.astype(np.uint8), connectivity=8)
    if n <= 1:
        closure.note = (f"the meter sees {missing:.4g} lux more than the camera but nothing "
                        "clipped: nothing to put it in")
        return radiance, closure
    seen = np.bincount(labels.reshape(-1), weights=np.asarray(cosw).reshape(-1),
                       minlength=n)[1:]
    best = int(np.argmax(seen)) + 1
    if seen[best - 1] <= 0:
        closure.note = "the clipped light is below the meter's horizon: it cannot close it"
        return radiance, closure
    blob = labels == best
    out = radiance.copy()
    out[blob] += np.float32(missing / seen[best - 1])     # neutral: luminance = each channel
    w = np.asarray(omega)[blob]
    mean = (directions[blob] * w[:, None]).sum(axis=0)
    closure.closed_lux = missing
    closure.direction = tuple(float(v) for v in mean / max(np.linalg.norm(mean), 1e-12))
    closure.solid_angle_sr = float(w.sum())
    return out, closure


def project_with_meter(projector, frames, times, gain, f_number, result, lux: float,
                       tracker=None):
    """(the frame(s) projected again with the meter's missing light in the clipped blob,
    :class:`MeterClosure`); ``result``: the same frame(s) already projected in absolute
    units (its radiometry statistics are kept, the meter's fields added: :func:`closure_fields`).
    One frame or a bracket (merged with the hat weights). Raises InputError when the frames
    are not in absolute units, float, or the projection cannot say its pixels' directions."""
    import math

    from ..errors import InputError
    from ..radiometry.bracket import merge
    from ..radiometry.photometry import UNITS_ABSOLUTE, absolute_factor
    if not (isinstance(lux, (int, float)) and math.isfinite(lux) and lux > 0):
        raise InputError(f"a lux meter's reading must be a positive number of lux, got {lux!r}")
    if result.stats.get("coefficient_units") != UNITS_ABSOLUTE:
        raise InputError("--lux needs the frame in absolute units: a --camera calibrated with "
                         "calibrate-response --lux, and the frame's exposure (EXIF or "
                         "@SECONDS); without them the clipped light stays a lower bound "
                         "(clipped_light_fraction)")
    frames = list(frames)
    if frames[0].dtype not in (np.uint8, np.uint16):
        raise InputError("--lux closes what an 8/16-bit frame clipped; this frame is float")
    bits = 8 if frames[0].dtype == np.uint8 else 16
    response = projector.response.to_bits(bits)
    factor = np.float32(absolute_factor(response, f_number))
    if len(frames) > 1:
        radiance = merge(frames, times, response, gain=gain).radiance * factor
    else:
        radiance = response.linearise(frames[0], times[0], gain) * factor
    clipped = (np.minimum.reduce(frames) == (1 << bits) - 1).any(axis=2)
    height, width = frames[0].shape[:2]
    if isinstance(projector.projection, Equirect) and projector.rotation is None:
        projection = Equirect(width, height)
    elif projector.projection.shape == (height, width):
        projection = projector.projection
    else:
        raise InputError("--lux with --downsample needs an equirect frame (or leave "
                         "--downsample out)")
    closed, closure = close_clipped(radiance, clipped,
                                    up_weights(projection, projector.rotation), lux)
    new = projector.project(closed, tracker=tracker)
    for key in ("clipped_fraction", "clipped_light_fraction", "exposure_s", "gain",
                "f_number", "iso", "radiometry", "response", "exposures_s", "coefficient_units"):
        if key in result.stats:
            new.stats[key] = result.stats[key]
    new.stats.update(closure_fields(closure))
    lux_up = projector.up_illuminance(closed)
    if lux_up is not None:
        new.stats["illuminance_lux"] = lux_up
    return new, closure


def closure_fields(closure: MeterClosure) -> dict:
    """The message's meter fields (flat numbers): ``meter_lux``, ``meter_camera_lux``,
    ``meter_closed_lux``, ``meter_direction`` (3), ``meter_solid_angle_sr``."""
    return {"meter_lux": closure.lux, "meter_camera_lux": closure.camera_lux,
            "meter_closed_lux": closure.closed_lux,
            "meter_direction": [float(v) for v in closure.direction],
            "meter_solid_angle_sr": closure.solid_angle_sr}
