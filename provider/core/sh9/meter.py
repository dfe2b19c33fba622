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

Where the meter faces (:func:`parse_facing`): up (the default), toward the sun, or a given
direction. An up-facing meter sees a low sun at sin(elevation): at 4° a few degrees of error
in the blob's direction scale the closed light by sin(10°)/sin(4°); a meter held toward the
sun sees it at cos(a few degrees) ≈ 1, so its reading fixes the sun's light whatever the
blob's exact direction. "sun" faces the largest clipped blob's mean direction; a clipped sky
is no sun, so for a wide blob the meter's direction is better said as AZ,EL.

The colour of the closed light: the clipped pixels do not say it, so without more it is
neutral. A chroma meter (or a sensor with colour channels) also reads the CCT and Duv of the
light it sees: then the meter's light is E · RGB(CCT, Duv) (unit luminance,
:func:`~provider.core.radiometry.colour_temperature.rgb_of_cct`), the camera explains
Σ L · max(d·n, 0) · dω of it per channel, and the rest, clamped at 0 per channel, is the
closed light's colour. A low sun is far from neutral (dawn: R:G:B ≈ 2.1 : 0.7 : 0.4), and
its colour is most of what a neutral closure misses.

Without a chroma meter, a clipped region that is the sun (:mod:`.sun_colour`: a small core
clipped in every channel, above the horizon, in daylight) takes the colour its partly
clipped rim measures or bounds, else the modelled beam's at its elevation; and the closed
light goes into that core, where the sun is (the rim's pixels are measured in some
channels: the glare around the sun, not the sun). ``meter_colour`` says which colour:
measured (a chroma meter), rim, modelled or neutral.
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError
from ..framepass.sinks import Sink
from ..geometry import sh
from ..geometry.projections import Equirect
from ..radiometry.bracket import merge
from ..radiometry.colour_temperature import rgb_of_cct
from ..radiometry.photometry import absolute_calibration, luminance
from ..radiometry.response import apply_lut
from .sun_colour import sun_colour
from .bracket_projection import captured_stats

UP = np.array([0.0, 1.0, 0.0])
#: An up-facing meter sees a blob lower than this (degrees) at grazing incidence: warned.
LOW_SUN_DEG = 15.0
#: A blob wider than this (degrees from its mean direction) is no sun: "sun" facing warns.
WIDE_BLOB_DEG = 30.0
#: The rim's channels within this many 8-bit codes of the top count as clipped (JPEG's
#: quantisation moves a clipped 255 to 250-254 next to a measured channel).
RIM_MARGIN = 6


@dataclass
class MeterClosure:
    """What the meter closed. ``lux``: its reading; ``camera_lux``: what the frame explains
    (exact, from the pixels); ``closed_lux``: what was added (0 when nothing);
    ``direction``: the blob's mean direction (world frame; zeros when nothing);
    ``solid_angle_sr``: the blob's solid angle; ``note``: why nothing was closed, or '';
    ``facing``: the meter's normal (world frame); ``colour``: the closed light's linear RGB
    per unit luminance ((1, 1, 1): neutral); ``warning``: a closure that is ill-conditioned
    (a low blob seen by an up-facing meter, a wide blob taken as the sun), or '';
    ``pixels``: the closed pixels (flat pixel numbers of the (H, W) frame, row-major; None
    when nothing) and ``added``: the linear RGB radiance each of them got (cd/m²), not on
    the wire; ``colour_source``: where ``colour`` came from (measured: a chroma meter; rim,
    modelled: :mod:`.sun_colour`; neutral)."""

    lux: float
    camera_lux: float
    closed_lux: float = 0.0
    direction: tuple = (0.0, 0.0, 0.0)
    solid_angle_sr: float = 0.0
    note: str = ""
    facing: tuple = (0.0, 1.0, 0.0)
    colour: tuple = (1.0, 1.0, 1.0)
    warning: str = ""
    pixels: np.ndarray | None = None
    added: tuple = (0.0, 0.0, 0.0)
    colour_source: str = "neutral"


def parse_facing(text) -> np.ndarray | str:
    """Where the meter faces, from ``--lux-facing``: ``up`` (the default: +Y), ``sun``
    (returned as the string: the largest clipped blob, resolved per frame), or ``AZ,EL`` in
    degrees: azimuth from the panorama's front (−Z) toward +X (clockwise seen from above:
    with the front to the north, a compass bearing), elevation above the horizon; returned
    as a unit world vector (sin az cos el, sin el, −cos az cos el). One InputError else."""
    t = str(text).strip().lower()
    if not t:           # an empty value is a script's unset variable, not "up"
        raise InputError("--lux-facing is empty: expected up, sun or AZ,EL in degrees "
                         "(e.g. 120,5)")
    if t == "up":
        return UP.copy()
    if t == "sun":
        return "sun"
    try:
        az, el = (float(v) for v in t.split(","))
    except ValueError:
        raise InputError(f"--lux-facing {text}: expected up, sun or AZ,EL in degrees "
                         "(e.g. 120,5)") from None
    if not (np.isfinite(az) and np.isfinite(el) and -90.0 <= el <= 90.0):
        raise InputError(f"--lux-facing {text}: the elevation must be within -90..90 degrees")
    a, e = np.radians(az), np.radians(el)
    return np.array([np.sin(a) * np.cos(e), np.sin(e), -np.cos(a) * np.cos(e)])


def parse_meter_colour(text) -> tuple[float, float] | None:
    """``--lux-cct K[,DUV]``: a chroma meter's CCT (K, 1,000-25,000) and Duv (default 0), or
    None for ``None``. One InputError else."""
    if text is None:
        return None
    try:
        parts = [float(v) for v in str(text).split(",")]
    except ValueError:
        parts = []
    if len(parts) not in (1, 2) or not 1000.0 <= parts[0] <= 25000.0 or \
            (len(parts) == 2 and not abs(parts[1]) <= 0.05):
        raise InputError(f"--lux-cct {text}: expected K[,DUV], K within 1000..25000 and "
                         "|DUV| ≤ 0.05 (e.g. 5600 or 3200,0.004)")
    return parts[0], parts[1] if len(parts) == 2 else 0.0


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


class UpSum(Sink):
    """The meter's up-facing sum in the frame pass (the 10th weight): ``total()``, (3,)
    float64 Σ cosine weight × linear RGB of the frame, scaled as the SH9 coefficients.
    Where the cosine weights are one more column of SH9's tables (a row of the separable
    ones, a column of the fold's or the dense ones) the SH9 sink sums them in its own
    product and this one reads them; an equirect frame under a sensor rotation (a turned
    cosine is not separable) is summed here, per pixel, band by band."""

    def __init__(self, projector, sh9):
        self.sh9, self.dense = sh9, projector._up_dense      # (H, W, 1) or None
        self.needs_bands = self.dense is not None
        if self.dense is not None:
            self.sums = np.zeros(self.dense.shape[1] * 3, np.float32)

    def band(self, lin, r0, raw, columns):
        if self.dense is not None:
            h = lin.shape[0]
            self.sums += (self.dense[r0:r0 + h] * lin).sum(axis=0).reshape(-1)

    def total(self) -> np.ndarray:
        if self.dense is None:
            return self.sh9.extra_sum() * self.sh9.scale
        return self.sums.reshape(-1, 3).astype(np.float64).sum(axis=0) * self.sh9.scale


def pixels_up_illuminance(projector, frame: np.ndarray, scale: float = 1.0) -> float | None:
    """:meth:`~provider.core.sh9.engine.SH9Projector.up_illuminance` of a frame from its
    pixels: the projector's :attr:`~provider.core.sh9.engine.SH9Projector.up_cosine_weights`
    times the linear frame (an integer one decoded by the projector, exposure included)."""
    weights = projector.up_cosine_weights
    if weights is None or frame.shape[0] * frame.shape[1] != weights.size:
        return None
    if frame.dtype in (np.uint8, np.uint16):
        lin = projector.decode(frame, {})
    else:
        lin = np.maximum(np.nan_to_num(np.asarray(frame, np.float32), nan=0.0,
                                       posinf=0.0), 0.0) * np.float32(projector.exposure)
    rgb = weights @ np.ascontiguousarray(lin, np.float32).reshape(-1, 3)
    return max(float(luminance(rgb)) * float(scale), 0.0)


def _at(image: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    """``image`` (H, W) at flat pixel numbers, without the copy that flattening a broadcast
    array (the per-row weights) would make."""
    return image[np.unravel_index(pixels, image.shape)]


def _blobs(clipped: np.ndarray) -> tuple[int, np.ndarray]:
    """cv2.connectedComponents (8-connected) of the clipped mask, run on the rows and columns
    that hold clipped pixels only (the sun: a small box of a large frame)."""
    rows, cols = np.flatnonzero(clipped.any(axis=1)), np.flatnonzero(clipped.any(axis=0))
    labels = np.zeros(clipped.shape, np.int32)
    if rows.size == 0:
        return 1, labels
    box = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
    n, labels[box] = cv2.connectedComponents(clipped[box].astype(np.uint8), connectivity=8)
    return n, labels


def _facing_weights(omega, directions, normal) -> np.ndarray:
    """Per pixel ``max(d·n, 0) · dω`` (sr): the meter's cosine for normal ``n``."""
    return np.maximum(directions @ np.asarray(normal, np.float64), 0.0) * omega


def _angle_deg(a, b) -> float:
    return float(np.degrees(np.arccos(np.clip(np.dot(a, b), -1.0, 1.0))))


def _sun(radiance, clipped, blob, pixels, rays, omega, lux, codes, clip_level):
    """:func:`~.sun_colour.sun_colour` of the blob (its pixels' rays, solid angles,
    radiance, clipped channels from ``codes`` (:data:`RIM_MARGIN`), and the sky: the
    median radiance of the unclipped pixels within 3 pixels of it)."""
    channels = at_top = None
    if codes is not None and clip_level is not None:
        top = 255 if codes.dtype == np.uint8 else 65535
        blob_codes = codes.reshape(-1, 3)[pixels]
        # a JPEG's blocks put a clipped channel a few codes under the top: near it is clipped
        channels = blob_codes >= top - RIM_MARGIN * (top // 255)
        at_top = blob_codes == top          # the core: at the top code itself
    sky = np.zeros(3)
    if channels is not None:
        rows, cols = np.flatnonzero(blob.any(axis=1)), np.flatnonzero(blob.any(axis=0))
        box = (slice(max(rows[0] - 3, 0), rows[-1] + 4), slice(max(cols[0] - 3, 0),
                                                                cols[-1] + 4))
        near = cv2.dilate(blob[box].astype(np.uint8), np.ones((7, 7), np.uint8)) > 0
        ring = near & ~clipped[box]
        if ring.any():
            sky = np.median(radiance[box][ring].astype(np.float64), axis=0)
    return sun_colour(rays[pixels], _at(omega, pixels),
                      radiance.reshape(-1, 3)[pixels].astype(np.float64), channels,
                      clip_level, sky, lux, at_top=at_top)


def close_clipped(radiance: np.ndarray, clipped: np.ndarray, weights, lux: float,
                  facing=None, colour=None, in_place=False, codes=None, clip_level=None,
                  colour_matrix=None):
    """(radiance with the meter's missing light in the clipped blob, :class:`MeterClosure`).

    ``radiance``: (H, W, 3) float32 in cd/m²; ``clipped``: (H, W) bool, samples clipped in
    every frame; ``weights``: :func:`up_weights` of the frame's projection; ``lux``: the
    meter's reading; ``facing``: where it faces (:func:`parse_facing`: None or +Y for up, a
    unit vector, or "sun"); ``colour``: (CCT K, Duv) of a chroma meter's reading, or None
    (:mod:`.sun_colour` finds it); ``in_place``: add to ``radiance`` itself (no copy);
    ``codes``: (H, W, 3) the 8/16-bit frame whose top code marks a channel clipped in every
    frame (a bracket's minimum) and ``clip_level`` (3,) the radiance of that code: the rim's
    channels (None: unknown, the sun's colour is modelled only); ``colour_matrix``: camera
    RGB → Rec. 709 (camera.json's, :mod:`~provider.core.radiometry.checker`) or None: the
    meter's luminance and colours are Rec. 709's, the frame's RGB the camera's."""
    cosw, omega, directions = weights
    omega = np.asarray(omega)
    n, labels = _blobs(clipped)
    rays = np.asarray(directions).reshape(-1, 3)    # (indexed by flat pixel numbers: fast)
    normal = UP if facing is None else facing
    wide = ""
    if isinstance(normal, str):                 # "sun": the largest clipped blob's direction
        if n <= 1:
            normal = UP
        else:
            inside = np.flatnonzero(clipped)
            sizes = np.bincount(labels.reshape(-1)[inside], weights=_at(omega, inside),
                                minlength=n)
            sun = np.flatnonzero(labels == int(np.argmax(sizes[1:])) + 1)
            mean = (rays[sun] * _at(omega, sun)[:, None]).sum(axis=0)
            normal = mean / max(np.linalg.norm(mean), 1e-12)
            spread = float(np.degrees(np.arccos(np.clip(rays[sun] @ normal, -1, 1))).max())
            if spread > WIDE_BLOB_DEG:
                wide = (f"the largest clipped region spans {spread:.0f}° from its centre: it is "
                        "more than the sun (a clipped sky?), so 'sun' is only its centre; "
                        "say where the meter faced as --lux-facing AZ,EL")
    normal = np.asarray(normal, np.float64)
    if not np.array_equal(normal, UP):
        cosw = _facing_weights(omega, directions, normal)
    # One float32 matrix-vector product over the frame (BLAS accumulates in blocks: ~1e-6
    # relative); a frame with non-finite samples takes the careful float64 sum instead.
    seen_rgb = (np.ascontiguousarray(cosw, np.float32).reshape(-1)
                @ np.ascontiguousarray(radiance, np.float32).reshape(-1, 3)).astype(np.float64)
    if not np.all(np.isfinite(seen_rgb)):
        seen_rgb = np.tensordot(cosw, np.nan_to_num(radiance, nan=0.0, posinf=0.0,
                                                    neginf=0.0).astype(np.float64),
                                axes=([0, 1], [0, 1]))
    to709 = np.eye(3) if colour_matrix is None else np.asarray(colour_matrix, np.float64)
    camera = float(luminance(to709 @ seen_rgb))
    closure = MeterClosure(float(lux), camera, facing=tuple(float(v) for v in normal),
                           warning=wide)
    missing = float(lux) - camera
    if missing <= 0:
        closure.note = (f"the meter reads {lux:.4g} lux, no more than the {camera:.4g} lux "
                        "the camera already sees: nothing to close (is the absolute scale "
                        "right, the meter beside the camera and facing as said?)")
        return radiance, closure
    if n <= 1:
        closure.note = (f"the meter sees {missing:.4g} lux more than the camera but nothing "
                        "clipped: nothing to put it in")
        return radiance, closure
    inside = np.flatnonzero(clipped)            # the clipped samples only (a small part)
    seen = np.bincount(labels.reshape(-1)[inside], weights=_at(np.asarray(cosw), inside),
                       minlength=n)[1:]
    best = int(np.argmax(seen)) + 1
    if seen[best - 1] <= 0:
        closure.note = "the clipped light is below the meter's horizon: it cannot close it"
        return radiance, closure
    blob = labels == best
    pixels = np.flatnonzero(blob)
    rgb, source, seen_best = np.ones(3), "neutral", seen[best - 1]
    found = _sun(radiance, clipped, blob, pixels, rays, omega, lux, codes, clip_level)
    if found.core is not None:                  # the sun: the light goes where it is
        core = pixels[found.core]
        seen_core = float(_at(np.asarray(cosw), core).sum())
        if seen_core > 0:
            pixels, seen_best = core, seen_core
    if colour is not None:                      # a chroma meter: the rest of its light's colour
        rest = np.maximum(float(lux) * rgb_of_cct(*colour) - to709 @ seen_rgb, 0.0)
        if float(luminance(rest)) > 0:
            rgb, source = np.linalg.solve(to709, rest), "measured"
    else:               # (the rim's colour is of the frame's RGB; the model's, Rec. 709's)
        rgb, source = found.rgb, found.source
        if source == "modelled":
            rgb = np.linalg.solve(to709, rgb)
        if found.warning:
            closure.warning = found.warning
    rgb = rgb / max(float(luminance(to709 @ rgb)), 1e-12)   # unit luminance, as the meter
    out = radiance if in_place and radiance.flags.c_contiguous else radiance.copy()
    added = (np.float32(missing / seen_best) * rgb).astype(np.float32)
    out.reshape(-1, 3)[pixels] += added           # (a view: out is contiguous)
    closure.pixels, closure.added = pixels, tuple(float(v) for v in added)
    w = _at(omega, pixels)
    mean = (rays[pixels] * w[:, None]).sum(axis=0)
    closure.closed_lux = missing
    closure.direction = tuple(float(v) for v in mean / max(np.linalg.norm(mean), 1e-12))
    closure.solid_angle_sr = float(w.sum())
    closure.colour = tuple(float(v) for v in rgb)
    closure.colour_source = source
    elevation = float(np.degrees(np.arcsin(np.clip(closure.direction[1], -1, 1))))
    if np.array_equal(normal, UP) and elevation < LOW_SUN_DEG and not closure.warning:
        closure.warning = (f"the clipped region is {elevation:.0f}° above the horizon: an "
                           "up-facing meter sees it at grazing incidence, so a few degrees "
                           "of error in its direction scale the closed light; hold the meter "
                           "toward the sun and say --lux-facing sun (or AZ,EL)")
    return out, closure


#: Each projector's meter weights (pixel-independent: built once, not per live frame;
#: 1920×960 takes ~0.4 s to build), gone with the projector.
_METER_WEIGHTS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _meter_weights(projector, projection):
    """:func:`up_weights` of ``projection`` in ``projector``'s rotation, built once per
    projector and kept (read-only)."""
    key = (projection.shape, isinstance(projection, Equirect))
    hit = _METER_WEIGHTS.get(projector)
    if hit is not None and hit[0] == key:
        return hit[1]
    weights = up_weights(projection, projector.rotation)
    for array in (weights[0], weights[2]):      # ours (the solid angle may be the projection's)
        array.setflags(write=False)
    _METER_WEIGHTS[projector] = (key, weights)
    return weights


#: The statistics of a bracket's merged result that its metered result keeps.
KEPT_STATS = ("clipped_fraction", "clipped_light_fraction", "exposure_s", "gain", "f_number",
              "iso", "radiometry", "response", "exposures_s", "coefficient_units")


def project_with_meter(projector, frames, times, gain, f_number, lux: float, *,
                       tracker=None, facing=None, colour=None, error_estimate=None,
                       stats=None, work=None):
    """(the frame(s) projected with the meter's missing light in the clipped blob,
    :class:`MeterClosure`): one decode (a bracket: one merge, hat weights), the closure, and
    one projection of the closed radiance, whose pass also sums ``illuminance_lux``. The
    result's statistics are those of the frame(s) as the camera saw them (clipping, exposure,
    units; a bracket's given as ``stats``: its merged result's, :data:`KEPT_STATS`), with the
    meter's fields (:func:`closure_fields`). ``facing``, ``colour``: as :func:`close_clipped`;
    ``tracker``, ``error_estimate``: as :meth:`~provider.core.sh9.engine.SH9Projector.project`;
    ``work``: the reflection cube's work image of a single frame, filled from this decode.
    Raises InputError before any work when the frames are not in absolute units, float, or
    the projection cannot say its pixels' directions."""
    import math

    from ..radiometry.photometry import UNITS_ABSOLUTE
    from ..options import exposure_scale
    if not (isinstance(lux, (int, float)) and math.isfinite(lux) and lux > 0):
        raise InputError(f"a lux meter's reading must be a positive number of lux, got {lux!r}")
    frames = [np.ascontiguousarray(f) for f in frames]
    own = {}                     # the frame's statistics, as SH9Projector.project says them
    bracket = len(frames) > 1
    factor = projector.absolute_scale(1.0 if bracket else
                                      exposure_scale(times[0], gain, own), f_number, own)
    if own["coefficient_units"] != UNITS_ABSOLUTE:
        raise InputError("--lux needs the frame in absolute units: a --camera calibrated with "
                         "calibrate-response --lux, and the frame's exposure (EXIF or "
                         "@SECONDS); without them the clipped light stays a lower bound "
                         "(clipped_light_fraction)")
    if frames[0].dtype not in (np.uint8, np.uint16):
        raise InputError("--lux closes what an 8/16-bit frame clipped; this frame is float")
    if frames[0].ndim != 3 or frames[0].shape[2] != 3:
        raise InputError(f"--lux needs RGB frames, got shape {frames[0].shape}")
    height, width = frames[0].shape[:2]
    if isinstance(projector.projection, Equirect) and projector.rotation is None:
        projection = Equirect(width, height)
    elif projector.projection.shape == (height, width):
        projection = projector.projection
    else:
        raise InputError("--lux with --downsample needs an equirect frame (or leave "
                         "--downsample out)")
    bits = 8 if frames[0].dtype == np.uint8 else 16
    response = projector.response.to_bits(bits)
    if bracket:              # factor: C·N²; the merge divides by each frame's t·gain
        merged = merge(frames, times, response, gain=gain)
        radiance = merged.radiance * np.float32(factor)
        # the table that gives the shortest frame's radiance in cd/m² (its clip level)
        table = response.lut(float(np.min(times)) * float(gain) / factor)
    else:                    # factor: C·N² / (t·gain), the frame's own
        merged, table = None, response.lut(1.0 / factor)
        radiance = apply_lut(frames[0], table)
    if work is not None and not bracket:   # the cube's work image: the projector's table
        work.add_band(radiance * np.float32(projector.exposure / factor), 0)
    lowest = frames[0]       # a sample clipped in every frame is clipped in their minimum
    for frame in frames[1:]:
        lowest = cv2.min(lowest, frame)
    planes = cv2.split(lowest)     # (numpy's any() over 3 samples: ~50 ms at 1920×960)
    clipped = cv2.max(cv2.max(planes[0], planes[1]), planes[2]) == (1 << bits) - 1
    top = (1 << bits) - 1                # the radiance of the top code: the clip level
    clip_level = np.asarray(table[top] if table.ndim == 1 else
                            table.reshape(top + 1, -1)[top], np.float64) * np.ones(3)
    closed, closure = close_clipped(radiance, clipped, _meter_weights(projector, projection),
                                    lux, facing=facing, colour=colour, in_place=True,
                                    codes=lowest, clip_level=clip_level,
                                    colour_matrix=projector.colour_matrix)
    new = projector.project(closed, error_estimate, tracker, units=UNITS_ABSOLUTE)
    if stats is None:        # what the integer pass would have said of the frame(s)
        # the camera's own L00: the closed frame's less what the closure added
        added = _closure_l00(projector, closure) * projector.exposure
        if projector.colour_matrix is not None:     # (the result is in Rec. 709)
            added = projector.colour_matrix @ added
        seen = new.coefficients[0] - added
        captured_stats(projector, own, seen, lowest, table, response,
                       merged=merged, gain=gain)
    else:
        own = {key: stats[key] for key in KEPT_STATS if key in stats}
    new.stats.update(own)
    new.stats.update(closure_fields(closure))
    return new, closure


def _closure_l00(projector, closure: MeterClosure) -> np.ndarray:
    """(3,) the L00 the closure put into ``projector``'s projection per unit exposure: its
    added radiance times the blob's L00 weights (equirect: C0·dω; others: the L00 weights
    the projector keeps, the projection's with its fill, summed over the closed pixels)."""
    if closure.pixels is None:
        return np.zeros(3)
    if isinstance(projector.projection, Equirect):
        weight = sh.C0 * closure.solid_angle_sr
    else:        # (the frame is the projection's size: project_with_meter checked it)
        weight = float(projector._l00_weights[closure.pixels].sum(dtype=np.float64))
    return np.asarray(closure.added, np.float64) * weight


def closure_fields(closure: MeterClosure) -> dict:
    """The message's meter fields (flat numbers): ``meter_lux``, ``meter_camera_lux``,
    ``meter_closed_lux``, ``meter_direction`` (3), ``meter_solid_angle_sr``,
    ``meter_facing`` (3: the meter's normal), ``meter_colour`` (where the closed light's
    colour came from: measured, rim, modelled or neutral)."""
    return {"meter_lux": closure.lux, "meter_camera_lux": closure.camera_lux,
            "meter_colour": closure.colour_source,
            "meter_closed_lux": closure.closed_lux,
            "meter_direction": [float(v) for v in closure.direction],
            "meter_facing": [float(v) for v in closure.facing],
            "meter_solid_angle_sr": closure.solid_angle_sr}
