"""The SH9 engine: frames in, coefficients, matrices and statistics out (no I/O).

:class:`SH9Projector` precomputes, once per (frame size, projection, options), everything
that does not depend on pixels (per-pixel SH weights, the sRGB linearisation table, the
rotation matrix); :meth:`SH9Projector.project` then costs a few vectorised calls per frame.
:func:`compute_sh9` is the one-shot convenience (docs/contract.md §4).

Frame contract (like OpenCV's, but RGB channel order): an ``ndarray`` of shape (H, W, 3)
(or (H, W, 4): alpha ignored; or (H, W) / (H, W, 1): grey), dtype

* ``uint8``: sRGB-encoded unless ``encoding="linear"``; linearised through a table
  *before* any averaging (docs/contract.md §5);
* ``uint16``: likewise (16-bit PNG/TIFF are display-encoded), full scale 65535;
* ``float16/32/64``: linear radiance (HDR, .exr/.hdr), used as is.

Coefficients are in the units of the linear input times ``exposure`` (scene-referred for
HDR; 0..1 relative to full scale for integer frames). With a camera ``response``
(:class:`~provider.core.radiometry.response.CameraResponse`) integer frames are decoded by the
camera's own curve instead of sRGB, and a frame's ``exposure_s`` and ``gain`` given to
:meth:`SH9Projector.project` divide the coefficients: radiance per second of exposure, so
that exposure changes never rebuild a table (docs/contract.md §9). Brackets: :mod:`.bracket`.
"""
from __future__ import annotations

import math
import time
import numpy as np

from ..geometry import sh
from .clipping import ClipCount, ClippedLight
from .error_estimate import ErrorEstimator
from . import equirect_pass, lens_fold as _lens_fold
from .lens_fold import centred_on_grid
from .tables import pixel_tables
from .result import SH9Result
from .meter import UpSum, has_absolute_scale, pixels_up_illuminance, up_weights
from .support import DecodeSpans, DownsampledSpans, FoldDecode
from ..blas import one_blas_thread
from ..ufunc_buffers import cache_sized_buffers
from ..errors import InputError
from ..framepass.sinks import Sink, Sinks, SmallFrame, WholeFrame
from ..framepass.traversal import BlockMeans, FloatBands, FramePass, LutBands, band_rows
from ..lights.extractor import LightExtractor
from ..lights.views import DetectionCopy, LinearView
from ..geometry.projections import Equirect, Projection, ProjectionError, make_projection
from ..geometry import projections_probe  # noqa: F401  (registers mirrorball, angular, cross)
from ..geometry import projections_exr  # registers exr-latlong, exr-cube; the cube's rules
from ..radiometry.photometry import (UNITS_ABSOLUTE, UNITS_RELATIVE, absolute_calibration,
                                     absolute_factor, luminance)
from ..options import check_lighting, check_options, exposure_scale, freeze_options
from ..radiometry import blocks
from ..radiometry.checker import colour_matrix
from ..radiometry.decode import FrameDecoder, image_array, srgb_to_linear  # noqa: F401


class SH9Projector(FrameDecoder):
    """Projects frames of one size and projection onto SH9.

    Parameters
    ----------
    width, height : int
        Frame size in pixels.
    projection : str or Projection
        "equirect" (default), "fisheye", "dual-fisheye", "cubemap", or a built
        :class:`~provider.core.geometry.projections.Projection`.
    encoding : "auto" | "srgb" | "linear"
        Transfer function of integer frames ("auto": sRGB). Float frames are linear.
    exposure : float
        Linear scale applied to the radiance (e.g. 2**EV).
    downsample : int
        Fast path: area-average the *linearised* frame by this integer factor before
        projecting (1 = exact path). The weights are the exact integrals over each block.
    rotation : (3, 3) array or None
        Sensor rotation: maps camera-frame directions to world directions; applied to the
        coefficients, never by resampling the image.
    order : 0, 1, 2 or "auto"
        Highest SH band kept. "auto" keeps the lowest order whose irradiance differs from
        order 2 by at most ``order_budget`` (relative RMS over the sphere).
    dering : "off" | "auto"
        "auto" applies the weakest sinc⁴ window that makes irradiance non-negative
        everywhere (only when it rings); "off" keeps the exact projection.
    error_estimate : bool
        Estimate SH9's truncation error per frame against brute-force irradiance from a
        64×32-ish copy of the frame (costs one extra small resize).
    progress : callable or None
        Called with the fraction done while the per-pixel weights of a fisheye, dual-fisheye
        or cube map frame are integrated (seconds to minutes for very large frames: see
        :func:`precompute_note`).
    lights : "off" | "auto"
        "auto": model compact bright sources as directional lights plus an ambient SH9,
        keeping a light only where it lowers the measured irradiance error
        (:mod:`provider.core.lights.extractor`; docs/contract.md §10). "off": the exact path, unchanged.
    max_lights : int
        At most this many lights per frame, 1 to :data:`~provider.core.options.MAX_LIGHTS` (default 4).
    response : CameraResponse or None
        The camera's inverse response: integer frames are decoded with it (a table at
        t = 1, like the sRGB one) instead of sRGB. None (default): sRGB, as ``encoding``.
    **projection_options
        Passed to the projection (fov_deg, center, radius, K, D, fill, albedo, ...).
    """

    def __init__(self, width: int, height: int, projection="equirect", *, encoding="auto",
                 exposure=1.0, downsample=1, rotation=None, order=2, dering="off",
                 order_budget=0.02, error_estimate=False, progress=None, lights="off",
                 max_lights=4, response=None, **projection_options):
        check_options(encoding=encoding, exposure=exposure, downsample=downsample,
                      rotation=rotation, order=order, dering=dering, order_budget=order_budget,
                      lights=lights, max_lights=max_lights)
        self._init_decoder(width, height, encoding, exposure, response)
        downsample = int(downsample)
        if width // downsample < 1 or height // downsample < 1:
            raise InputError(f"--downsample {downsample} is larger than the {width}×{height} frame")
        try:
            if isinstance(projection, Projection):
                full = projection
            else:
                full = make_projection(projection, width, height, **projection_options)
            if isinstance(full, projections_exr.ExrCube):
                projections_exr.check_cube_downsample(full, downsample)
            withdrawn = isinstance(full, Equirect) and downsample > 1
            # A lens folded at full size whose half-size centre falls between pixels: the
            # small frame's dense table (9 weights a small pixel) reads as many floats as
            # the full frame's quarter tables (9 per 4 pixels), and the C fold is faster.
            dense_half = (downsample == 2 and _lens_fold.KERNEL and centred_on_grid(full)
                          and not centred_on_grid(full.scaled(2)))
            if withdrawn or dense_half:
                downsample = 1
            self.projection = full if downsample == 1 else full.scaled(downsample)
            self._full = full
            #: The projection at the frame's own size (``projection`` is the downsampled one).
            self.full_projection = full
            self._up = None             # exact up-facing cosine weights (up_illuminance)
        except ProjectionError as exc:
            raise InputError(str(exc)) from None
        #: Allowed but probably wrong (e.g. a 2:1 panorama read as a fisheye): say them.
        self.warnings = list(full.warnings)
        if withdrawn:   # separable exact weights: the fast path was slower (docs/accuracy.md)
            self.warnings.append(
                "--downsample on an equirect frame is withdrawn: its exact path is faster "
                "(separable weights), so the frame is projected exactly")
        elif dense_half:
            self.warnings.append(
                "--downsample 2 is withdrawn for this lens: its centre falls between the "
                "half-size pixels, so the small frame needs a full table and the exact path "
                "is faster; the frame is projected exactly (--downsample 4 is faster)")
        #: (x0, y0, x1, y1): the part of each frame the projection covers (a ball's box).
        self.window = getattr(full, "window", None)
        self.downsample = downsample
        self.order, self.dering, self.order_budget = order, dering, float(order_budget)
        self.rotation = None if rotation is None else np.asarray(rotation, np.float64)
        self._sh_rotation = None if rotation is None else sh.sh_rotation(self.rotation)
        self.error_estimate = bool(error_estimate)
        self.lights, self.max_lights = lights, int(max_lights)
        # Lights (pixel-independent precomputation once, like the SH weights): integer
        # frames on the exact path build the detection copy band by band while linearising.
        self._extractor = (LightExtractor(full, max_lights=self.max_lights)
                           if lights == "auto" else None)
        if self._extractor is not None and downsample == 1:
            # Bands a whole number of the detection copy's blocks high (it is built band by
            # band): see band_rows (a Theta S's 5: 30 rows).
            self.BAND_ROWS = band_rows(self._extractor.mid_factor, type(self).BAND_ROWS)
        self._fuse_lights = (self._extractor is not None and downsample == 1
                             and self._extractor.fusable(self.BAND_ROWS))

        # Pixel-independent precomputation.
        p = self.projection
        self._block = full.scaled_source_size(downsample)
        self._fold = self._spans = self._up_dense = None
        # A camera with an absolute scale reports the up-facing illuminance of every frame:
        # its cosine weights are one more column of the projection's weights (a 10th weight),
        # summed in the same pass as the SH9, never a second decode (issue 34).
        self._up_in_pass = downsample == 1 and has_absolute_scale(response)
        # camera.json's colour matrix (calibrate-response --checker): camera RGB → Rec. 709,
        # applied to what each frame gives (linear: the same as to every pixel)
        self.colour_matrix = colour_matrix(response)
        up = self.up_cosine_weights.reshape(p.shape) if self._up_in_pass else None  # (H, W) sr
        if isinstance(p, Equirect):
            rows, cols = p.row_integrals(), p.col_integrals()
            self._rows = rows.astype(np.float32)          # (6, H), 7 with the up row
            self._cols = cols                               # (6, W) float64
            self._weights = None
            if up is not None and self.rotation is None:   # Δφ·½(sin²θ_b − sin²θ_t): a row
                self._rows = np.vstack([self._rows, up[:, :1].T.astype(np.float32)])
            elif up is not None:     # a turned cosine is not separable: per pixel, same pass
                self._up_dense = self._up.reshape(p.height, p.width, 1)
        else:
            # Lenses symmetric about their centres: quarter tables instead of the dense one;
            # built once per geometry and kept on disk (.tables, provider.core.table_cache).
            tables = pixel_tables(p, None if up is None else up.reshape(-1), progress,
                                  self.warnings)
            self._fold, self._weights, seen = tables.fold, tables.weights, tables.seen
            #: The fast path's blocks with a weight, per row (decode_blocks reads only them).
            self._block_spans = (blocks.block_spans(seen)
                                 if downsample > 1 and self._extractor is None else None)
            if downsample == 1:      # 8/16-bit bands decode only the columns seen (.support)
                self._spans = DecodeSpans.of(seen, self.BAND_ROWS,
                                             self._extractor.mid_factor if self._fuse_lights else 1)
            elif self._extractor is None:   # nothing else reads the whole linear frame
                self._spans = DownsampledSpans.of(seen, downsample, self.BAND_ROWS)
            #: L00 weight of each pixel (H·W,): what the clipped samples carry.
            self._l00_weights = tables.l00
        # the lights' table cache lines, each said once (an unwritable cache: one line)
        self.warnings += [n for n in getattr(self._extractor, "table_notes", ())
                          if n not in self.warnings]
        self._clipped = ClippedLight(self)
        self._pass = None      # (fold, spans, FramePass): made on the first frame
        self._estimator = None
        self._coverage = 4 * math.pi if isinstance(p, Equirect) else tables.coverage
        if not self._coverage > 0:
            raise InputError(f"no pixel of the {p.width}×{p.height} frame sees anything with "
                             "this geometry (check --center, --radius, --fov)")
        if self._coverage > 4 * math.pi * 1.01:   # integration of a frame far too coarse
            raise InputError(f"this {p.width}×{p.height} {p.name} frame integrates to "
                             f"{self._coverage:.1f} sr, more than the whole sphere (4π = "
                             "12.6 sr): the frame is too small for this projection")

    # -- projection -------------------------------------------------------------------------
    #: Rows per band when linearising integer frames: the float32 band stays in cache (a
    #: projector with lights takes a multiple of their copy's block height: band_rows).
    BAND_ROWS = 32

    def _strategies(self) -> list:
        """The frame pass's decode strategies (:mod:`provider.core.framepass`), tried in
        order: the one place where how a frame is decoded is chosen."""
        if self.downsample > 1:
            p = self.projection
            return [BlockMeans(self.downsample, self._block, (p.width, p.height),
                               getattr(self, "_block_spans", None), self._spans)]
        bands = LutBands(self._spans)
        fused = [FoldDecode(self._fold)] if self._fold is not None else []
        if (self._fold is None and self._weights is None and self._up_dense is None
                and equirect_pass.KERNEL):
            fused.append(equirect_pass.EquirectRows(self._rows, bands))
        return fused + [bands, FloatBands()]

    def _sinks(self, frame: np.ndarray, lut, work, small: bool) -> "SH9Sinks":
        """The sinks of the products ``frame`` feeds, in the order they are fed: the SH9
        sums, the meter's up-facing sum, the clip counter, the lights' copy, the cube's
        work image and the fast path's small frame (``small``: for the error estimate),
        each where this frame needs it."""
        integer = frame.dtype in (np.uint8, np.uint16)
        sinks = {"sh9": SH9Sums(self)}
        if self._up_in_pass:
            sinks["up"] = UpSum(self, sinks["sh9"])
        sinks["clip"] = ClipCount(self._clipped)
        if self._extractor is not None and integer and self.downsample == 1:
            if self._fuse_lights:  # else the lights decode the frame again (_add_lights)
                sinks["lights"] = DetectionCopy(self._extractor)
        elif self._extractor is not None:
            sinks["lights"] = WholeFrame()
        if work is not None and lut is None and integer and self.downsample == 1:
            sinks["work"] = work
        if small and self.downsample > 1:
            sinks["small"] = SmallFrame()
        return SH9Sinks(**sinks)

    def _project_frame(self, frame: np.ndarray, stats: dict, lut: np.ndarray | None = None,
                       work=None, small: bool = False) -> "SH9Sinks":
        """Decode ``frame`` once (counting bad samples into ``stats``) and feed the sinks of
        its products (:meth:`_sinks`), which hold their results: ``sinks.sh9``,
        ``sinks.clip``, ``sinks.up``, ``sinks.lights``, ``sinks.small`` (the fast path's
        small frame, kept where ``small``). ``lut``: a table other than the projector's
        own."""
        sinks = self._sinks(frame, lut, work, small)
        made = self._pass
        if made is None or made[0] is not self._fold or made[1] is not self._spans:
            # built once; again where the fold or the spans were swapped (a test's twin)
            made = self._pass = (self._fold, self._spans,
                                 FramePass(self._strategies(), self.BAND_ROWS))
        made[2].run(self, frame, sinks, stats, lut)
        return sinks

    def clipping(self, frame: np.ndarray, lut: np.ndarray, stats: dict) -> float:
        """Sets ``stats["clipped_fraction"]`` (channel samples of an 8/16-bit frame at the top
        code) and returns the L00 those samples put into the projection through ``lut``,
        summed over the channels: light that is only a lower bound (the sun)."""
        return self._clipped.whole(frame, lut, stats)

    @one_blas_thread
    @cache_sized_buffers
    def project(self, frame: np.ndarray, error_estimate: bool | None = None,
                tracker=None, *, exposure_s: float | None = None, gain: float = 1.0,
                f_number: float | None = None, work=None, units=None) -> SH9Result:
        """Coefficients, matrices and statistics of one frame (``error_estimate``: whether
        to estimate SH9's error on this frame; None: as the projector was built).

        ``work``: a :class:`~provider.core.reflections.work_image.WorkImage`
        (``EnvironmentProjector.new_work(this projector)``) that the decoding pass of an 8- or
        16-bit frame fills on its way, so that the reflection cube of the same frame needs no
        second decode (left incomplete by float frames, ``downsample`` > 1, and 8-bit frames
        that the C fold kernel decodes inside its own pass: that pass and the cube's own
        one-pass decode cost less than a float copy of the frame shared by both).

        With ``lights="auto"`` the result also holds ``lights`` and ``ambient_coefficients``;
        ``tracker`` (a :class:`~provider.core.lights.tracking.LightTracker`, owned by the
        caller, one per stream) chooses them with hysteresis across frames instead of the
        per-frame greedy choice.

        ``exposure_s`` and ``gain`` (when the source reports them): the coefficients are
        divided by ``exposure_s · gain``, radiance per second of exposure (docs/contract.md §9),
        so that auto exposure does not make the lighting jump; the table is not rebuilt.
        With a curve that has an absolute scale (camera.json ``params.absolute``, gain =
        ISO/100) they are also multiplied by C·N² (``f_number``, or the calibration's):
        cd/m², ``stats["coefficient_units"]`` (:mod:`~provider.core.radiometry.photometry`).
        ``units="cd/m²"``: a float frame already in cd/m² (a merged bracket, a meter's closed
        frame) gets ``illuminance_lux`` from the same pass too.

        ``stats`` keys: ``compute_ms``, ``clipped_fraction`` (fraction of channel samples at
        the top code value of an integer frame), ``clipped_light_fraction`` (the share of
        L00, the mean light, that comes from those samples: a lower bound, never measured),
        ``radiometry`` ("srgb-assumed", "calibrated" or "linear"), ``response`` (the camera
        curve's method, with a response), ``exposure_s`` and ``gain`` (when given),
        ``negative_pixels`` and
        ``nonfinite_pixels`` (set to 0 and counted), ``min_irradiance`` (per channel, over
        the sphere, after windowing), ``ringing`` (the un-windowed SH irradiance went
        negative), ``window_cutoff`` (sinc⁴ cutoff applied, or None), ``order`` (kept),
        ``order_error`` (irradiance error caused by a lower order or by windowing, relative
        to the exact order-2 result), ``error_estimate`` (when enabled: relative RMS SH9
        irradiance error against brute force), ``coverage_sr`` (solid angle seen); with
        lights: ``light_error`` (relative RMS irradiance error of ambient + lights against
        brute force on a coarse copy, bright regions at mid resolution), ``sh9_error`` (the
        full SH9 alone on the same copy), ``light_candidates`` (bright regions considered).
        """
        t0 = time.perf_counter()
        stats = {"negative_pixels": 0, "nonfinite_pixels": 0}
        frame = self._prepare(frame)
        k = exposure_scale(exposure_s, gain, stats)
        k = self.absolute_scale(k, f_number, stats)
        absolute = UNITS_ABSOLUTE in (stats["coefficient_units"], units)
        estimate = self.error_estimate if error_estimate is None else error_estimate
        sinks = self._project_frame(frame, stats, work=work, small=estimate)
        coeffs, clipped = sinks.sh9.coefficients(), sinks.clip.l00
        small = None if sinks.small is None else sinks.small.image
        light_input = None if sinks.lights is None else sinks.lights.image
        clean = getattr(sinks.lights, "clean", False)
        mean_scale = getattr(sinks.lights, "scale", 1.0)
        first = getattr(sinks.lights, "first", None)
        if absolute and sinks.up is not None:     # the 10th weight's sum, from the same pass
            up = sinks.up.total()
            scale = 1.0 if k is None else float(k)     # None: no exposure known
            if self.colour_matrix is not None:
                up = self.colour_matrix @ np.asarray(up, np.float64)
            stats["illuminance_lux"] = max(float(luminance(up)) * scale, 0.0)
        if k is not None:
            coeffs, clipped = coeffs * k, clipped * k
        integer = frame.dtype in (np.uint8, np.uint16)
        self.radiometry_stats(stats, coeffs, clipped, self.radiometry if integer else "linear")
        result = self.result(coeffs, stats, exposure_s)
        if self._extractor is not None:
            self._add_lights(result, frame, coeffs, light_input, tracker, k, clean,
                             mean_scale, first)
        if estimate:
            if small is None:
                small = (self._linearise(frame) if frame.dtype in (np.uint8, np.uint16)
                         else self._clean_float(frame, {}))
            result.stats["error_estimate"] = self._estimate_error(small, result.stats["order"])
        result.stats["compute_ms"] = (time.perf_counter() - t0) * 1e3
        return result

    def absolute_scale(self, k: float | None, f_number: float | None, stats: dict):
        """``k`` (1/(t·gain), or None) times the curve's C·N² when it has an absolute scale,
        with ``coefficient_units`` ("cd/m²" or "relative") and ``f_number`` in ``stats``."""
        stats["coefficient_units"] = UNITS_RELATIVE
        factor = absolute_factor(self.response, f_number) if k is not None else None
        if factor is None:
            return k
        stats["coefficient_units"] = UNITS_ABSOLUTE
        stats["f_number"] = float(f_number or absolute_calibration(self.response)["f_number"])
        return k * factor

    def up_illuminance(self, frame: np.ndarray, scale: float = 1.0) -> float | None:
        """Exact luminance of the irradiance on an up-facing surface (world +Y) from a frame's
        pixels (not SH9's), times ``scale``: lux in absolute units; None where not at hand."""
        return pixels_up_illuminance(self, frame, scale)

    @property
    def up_cosine_weights(self) -> np.ndarray | None:
        """(H·W,) float32 ∫ max(d·up, 0) dω of each full-resolution pixel (sr, world +Y,
        rotation applied), built once; None for a downsampled projection."""
        if self._up is None and self.downsample == 1:
            self._up = up_weights(self._full, self.rotation)[0].astype(np.float32).ravel()
        return self._up

    # -- building blocks of brackets (provider.core.radiometry.bracket) ----------------------------------
    def project_part(self, frame: np.ndarray, table: np.ndarray):
        """The projection of ``table(frame)`` for an 8/16-bit frame: ``(coefficients (9, 3),
        clipped L00 (summed over the channels), stats)``, not rotated and not scaled by any exposure (one slot of
        a bracket; the sum of slots goes to :meth:`result`)."""
        stats = {"negative_pixels": 0, "nonfinite_pixels": 0}
        frame = self._prepare(frame)
        if frame.dtype not in (np.uint8, np.uint16):
            raise InputError(f"a bracket needs 8- or 16-bit frames, got {frame.dtype}")
        sinks = self._project_frame(frame, stats, lut=table)
        return (sinks.sh9.coefficients() * self.exposure, sinks.clip.l00 * self.exposure,
                stats)

    def result(self, coefficients: np.ndarray, stats: dict, exposure_s=None) -> SH9Result:
        """An :class:`SH9Result` from exact (un-rotated) coefficients: the sensor rotation,
        windowing, order choice, matrices and their statistics. Coefficients that overflowed
        (``exposure``, or ``exposure_s`` — named in the message — too extreme for the frame)
        raise :class:`InputError` (:func:`~provider.core.options.check_lighting`)."""
        check_lighting(coefficients, self.exposure, exposure_s)
        if self.colour_matrix is not None:
            coefficients = coefficients @ self.colour_matrix.T
        if self._sh_rotation is not None:
            coefficients = self._sh_rotation @ coefficients
        return self._finish(coefficients, stats)

    def radiometry_stats(self, stats: dict, coefficients: np.ndarray, clipped_l00: float,
                         radiometry: str) -> None:
        """``radiometry``, ``response`` and ``clipped_light_fraction`` (clipped L00 over all
        L00, summed over the channels; exact coefficients, before rotation) into stats."""
        stats["radiometry"] = radiometry
        if self.response is not None and radiometry != "linear":
            stats["response"] = self.response.method
        # array methods, not numpy's Python wrappers (a frame is counted in instructions)
        total = float(np.asarray(coefficients[0]).sum())
        part = float(np.sum(clipped_l00))
        stats["clipped_light_fraction"] = min(max(part / total, 0.0), 1.0) if total > 0 else 0.0

    def _finish(self, exact: np.ndarray, stats: dict) -> SH9Result:
        coeffs = exact
        E_exact = sh.sphere_irradiance(exact)
        # The channels' minima over a contiguous copy: a reduction over axis 0 of an (N, 3)
        # array runs its inner loop once a row (N calls; issue 34).
        stats["ringing"] = bool((np.ascontiguousarray(E_exact.T).min(axis=1) < 0).any())
        stats["window_cutoff"] = None
        if self.dering == "auto":
            coeffs, cutoff = sh.dering(coeffs)
            stats["window_cutoff"] = cutoff
        order = self.order
        if order == "auto":
            order = 2
            for candidate in (0, 1):
                err = sh.relative_rms(sh.sphere_irradiance(sh.truncate_order(coeffs, candidate)),
                                      sh.sphere_irradiance(coeffs))
                if err <= self.order_budget:
                    order = candidate
                    break
        if order < 2:
            coeffs = sh.truncate_order(coeffs, order)
        # neither windowed nor truncated (the default): the same product, not made again
        E = E_exact if coeffs is exact else sh.sphere_irradiance(coeffs)
        stats["order"] = order
        stats["order_error"] = 0.0 if E is E_exact else sh.relative_rms(E, E_exact)
        stats["min_irradiance"] = np.ascontiguousarray(E.T).min(axis=1).tolist()
        stats["coverage_sr"] = self._coverage
        return SH9Result(coeffs, sh.irradiance_matrices(coeffs), stats)

    def _add_lights(self, result, frame, exact, light_input, tracker, k=None,
                    clean=False, mean_scale=1.0, first=None) -> None:
        """Directional lights + ambient of one frame (provider.core.lights.extractor), in the units
        and frame of the coefficients: exposure scales them like the coefficients, the
        sensor rotation turns light directions and the ambient like the coefficients, and
        the ambient gets the same deringing and order as the coefficients."""
        integer = frame.dtype in (np.uint8, np.uint16)
        scale = 1.0 if integer else self.exposure  # integer frames: folded into the LUT
        if k is not None:                           # per second of exposure, as the coefficients
            scale *= k
        if light_input is None:                     # an integer frame that was not fused
            light_input = self._linearise(frame)
        full = light_input if light_input.shape[:2] == frame.shape[:2] else \
            LinearView(frame, self._linearise)
        order = result.stats["order"]
        found = self._extractor.extract(
            light_input, exact / scale, tracker=tracker, full=full,
            process=lambda ambient: self._same_processing(ambient, order), clean=clean,
            mean_scale=mean_scale, first=first)
        found = found.transformed(scale, self.rotation, self._sh_rotation, self.colour_matrix)
        result.lights, result.ambient_coefficients = found.lights, found.ambient
        result.stats.update(light_error=found.light_error, sh9_error=found.sh9_error,
                            light_candidates=len(found.candidates))

    # -- error estimate ---------------------------------------------------------------------
    def _estimate_error(self, lin: np.ndarray, order: int) -> float:
        """Relative RMS difference between SH9 irradiance and brute-force irradiance
        (:class:`~.error_estimate.ErrorEstimator`, built on the first frame)."""
        if self._estimator is None:
            self._estimator = ErrorEstimator(self.projection)
        return self._estimator.estimate(lin, lambda c: self._same_processing(c, order))

    def _same_processing(self, coeffs, order):
        out = coeffs
        if self.dering == "auto":
            out, _ = sh.dering(out)
        return sh.truncate_order(out, order)


#: Equirect.SEPARABLE_TERMS as arrays (coefficient, constant, row, column function): one
#: numpy call a frame adds them, in their order (the same sums as a loop of 11).
_TERM_K, _TERM_CONST, _TERM_ROW, _TERM_COL = (np.array(c) for c in
                                              zip(*Equirect.SEPARABLE_TERMS))


class SH9Sums(Sink):
    """SH9's sink in the frame pass: a frame's sums against the projection's weights (the
    separable rows and columns of an equirect frame, a lens's fold, or dense tables), the
    meter's up-facing cosine one more weight where it rides in the pass (:class:`UpSum`).
    ``coefficients()``: (9, 3) float64, times the exposure for a float frame (an integer
    frame's is in its table)."""

    at_projection = True
    scale = 1.0
    #: Set by the equirect pass: acc's columns folded into their first half (a half turn)
    folded = False

    def __init__(self, projector: SH9Projector):
        self.p = p = projector
        if p._fold is not None:
            self.acc = p._fold.new(p.BAND_ROWS)
        elif p._weights is None:
            self.acc = np.zeros((len(p._rows), p.projection.width * 3), np.float32)
        else:
            self.acc = np.zeros((3, p._weights.shape[1]), np.float32)

    def start(self, frame, table, stats):
        if table is None:
            self.scale = self.p.exposure

    def band(self, lin, r0, raw, columns):
        p, acc = self.p, self.acc
        h, w = lin.shape[:2]
        if p._weights is None:
            # a frame of huge values overflows here: refused after, in one line
            # (check_lighting), so numpy's own warning is not printed
            with np.errstate(over="ignore", invalid="ignore"):
                acc += p._rows[:, r0:r0 + h] @ lin.reshape(h, w * 3)
        elif p._fold is not None:
            p._fold.add(lin, r0, acc)
        else:
            acc += lin.reshape(-1, 3).T @ p._weights[r0 * w:(r0 + h) * w]

    def whole(self, lin):
        fold = self.p._fold
        if fold is not None and fold.decodes(lin):
            fold.decode_project(lin, None, self.acc)        # the C kernel, no decode
        else:
            self.band(lin, 0, None, None)

    def coefficients(self) -> np.ndarray:
        """(9, 3) float64 coefficients of the frame (not rotated)."""
        p, acc = self.p, self.acc
        if p._fold is not None:
            return p._fold.coefficients(acc) * self.scale
        if p._weights is not None:
            return acc.T[:9].astype(np.float64) * self.scale
        # folded (equirect_pass): the columns' second half holds nothing
        w = p.projection.width // 2 if self.folded else p.projection.width
        rowsum = acc[:6, :w * 3].reshape(6, w, 3).astype(np.float64)
        out = np.zeros((9, 3))
        with np.errstate(over="ignore", invalid="ignore"):     # as in band
            partial = np.matmul(p._cols[:, :w], rowsum)   # (6 row fns, 6 col fns, 3): BLAS
            np.add.at(out, _TERM_K, _TERM_CONST[:, None] * partial[_TERM_ROW, _TERM_COL])
        return out * self.scale

    def extra_sum(self) -> np.ndarray:
        """(3,) float64: the frame's sum against the 10th weight column (not scaled)."""
        p, acc = self.p, self.acc
        if p._fold is not None:
            return p._fold.extra_sums(acc)[0]
        if p._weights is not None:
            return acc[:, 9].astype(np.float64)
        return acc[6].reshape(-1, 3).astype(np.float64).sum(axis=0)


class SH9Sinks(Sinks):
    """The sinks of one frame's pass in the SH9 engine (:meth:`SH9Projector._sinks`), each
    None where the frame does not feed it."""

    sh9: SH9Sums
    clip: ClipCount
    up: UpSum | None = None
    lights: DetectionCopy | WholeFrame | None = None
    work = None                 # the cube's WorkImage
    small: SmallFrame | None = None


_PROJECTOR_CACHE: dict = {}


def compute_sh9(image, projection: str = "equirect", **options) -> SH9Result:
    """SH9 lighting of one image (docs/contract.md §4).

    ``image`` is an (H, W, C) array in RGB order (see the module docstring) or a path to
    an image file (.exr, .hdr, .png, .jpg, .tif, ...). Options are those of
    :class:`SH9Projector`; ``error_estimate`` defaults to True here. Projectors are cached
    per (size, projection, options), so calling this per frame is cheap after the first.
    """
    image = image_array(image)
    options.setdefault("error_estimate", True)
    key = (image.shape[1], image.shape[0], projection, freeze_options(options))
    projector = _PROJECTOR_CACHE.get(key)
    if projector is None:
        projector = SH9Projector(image.shape[1], image.shape[0], projection, **options)
        if len(_PROJECTOR_CACHE) > 16:
            _PROJECTOR_CACHE.clear()
        _PROJECTOR_CACHE[key] = projector
    return projector.project(image)
