"""The reflection cube: frames in, an HDR radiance cube and its GGX-prefiltered mips out
(no I/O; docs/contract.md §12).

:class:`EnvironmentProjector` precomputes, once per (frame size, projection, options),
everything that does not depend on pixels, as :class:`~provider.core.sh9.engine.SH9Projector`
does for SH9 (and decodes frames the same way: :class:`~provider.core.radiometry.decode.FrameDecoder`):

1. *work image*: the linear frame area-averaged to a few pixels per base texel (equirect:
   at most 8 pixels per texel side; other projections: the integer downsample the SH9 fast
   path uses), so per-frame work does not grow with the camera's resolution;
2. *overlap*: a sparse map from work pixels to the base cube (64² for 16² and 32² cubes, 32²
   for 8², the size itself beyond): each work pixel is split into sub-pixels with exact solid
   angles and sent, with the sensor rotation, to the texels it overlaps. A base texel is the
   solid-angle-weighted mean of the input over its footprint: a 0.5° sun keeps its flux and
   its place. Directions a lens does not see get the projection's fill (a fisheye's
   ``ground``: albedo·E_axis/π; ``zero``: black);
3. *pyramid*: exact 2×2 solid-angle pools of the base; mip 0 is the level of ``size``;
4. *prefilter* (:mod:`provider.core.reflections.prefilter`): one sparse operator from the pyramid to the
   texel centres of every mip k ≥ 1, perceptual roughness k/(K−1) (α = roughness²); the
   light of the brightest work pixels above the rest (a sun) is added from their own
   directions, exactly. Cubes above 32² read the pyramid from 64² down and evaluate mips
   above 32² at 32², upsampled (the bench says what that costs).

Per frame: decode and shrink (8-bit frames in one pass where the crop is whole blocks:
:func:`~provider.core.radiometry.blocks.decode_blocks`), one gather-and-sum for the base,
the pools, one for the mips.
Units are those of the SH9 coefficients of the same options (exposure, ``exposure_s``/``gain``
divide the same way), so the cube and SH9 describe the same light.
"""
from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field

import cv2
import numpy as np

from .. import table_cache
from ..geometry import cubemap
from . import prefilter
from .bright import bright_split
from .overlap import overlap_sums
from .work_image import WorkImage
from ..geometry import projections_probe  # noqa: F401  (registers mirrorball, angular, cross)
from ..geometry import projections_exr  # registers exr-latlong, exr-cube; the cube's rules
from ..radiometry import blocks
from ..radiometry.checker import colour_matrix
from ..radiometry.decode import FrameDecoder, image_array
from ..options import check_options, exposure_scale, freeze_options
from ..blas import one_blas_thread
from ..ufunc_buffers import cache_sized_buffers
from ..errors import InputError
from ..geometry.projections import Equirect, Projection, ProjectionError, make_projection

#: Options of :class:`~provider.core.sh9.engine.SH9Projector` that only concern SH9 (accepted and
#: ignored, so that one options dict drives both products).
SH9_ONLY = ("order", "dering", "order_budget", "error_estimate", "lights", "max_lights",
            "downsample", "progress")
#: Base texels per side of the work image's pixels (equirect): the overlap's resolution.
WORK_PIXELS_PER_TEXEL = 4
#: Widest work image (equirect): bounds the per-frame cost and memory of large cubes.
WORK_MAX_WIDTH = 1024
#: Sub-pixels per axis when a work pixel is split among the texels it overlaps.
SUBPIXELS = 4
#: Largest pyramid level the prefilter reads, and largest face it evaluates directly.
PREFILTER_MAX_SOURCE, PREFILTER_MAX_FACE = 64, 32


@dataclass
class EnvironmentResult:
    """A radiance cube and its prefiltered mips (docs/contract.md §12).

    Attributes
    ----------
    mips : list of (6, n_k, n_k, 3) float32
        Face order +X −X +Y −Y +Z −Z, texel [f, i, j] at s = (j+½)/n, t = (i+½)/n
        (:mod:`provider.core.geometry.cubemap`), our frame; n_0 = size, halving down to 2. Mip 0 is
        radiance, mip k ≥ 1 the GGX-prefiltered radiance PF at ``roughness[k]``.
    roughness : list of float
        Perceptual roughness of each mip: k/(K−1), 0 for mip 0, 1 for the last.
    stats : dict
        ``compute_ms``, ``coverage_sr``, ``negative_pixels``, ``nonfinite_pixels``,
        ``radiometry``, ``exposure_s``/``gain`` (when given).
    prefilter_source : optional
        What the prefiltered mips were made of (the frame's pyramid), kept so that
        :meth:`EnvironmentProjector.refilter` can prefilter the same frame at another
        roughness without projecting it again.
    """

    mips: list
    roughness: list
    stats: dict = field(default_factory=dict)
    prefilter_source: object = field(default=None, repr=False, compare=False)

    @property
    def size(self) -> int:
        return int(self.mips[0].shape[1])

    def irradiance(self, normals: np.ndarray) -> np.ndarray:
        """E(n) = Σ L·max(0, n·d)·Ω over mip 0's texels, at unit normals (..., 3) → (..., 3)."""
        n = self.size
        d = cubemap.texel_directions(n).reshape(-1, 3)
        w = cubemap.texel_solid_angles(n).reshape(-1)
        normals = np.asarray(normals, np.float64)
        cos = np.maximum(normals.reshape(-1, 3) @ d.T, 0.0) * w
        out = cos @ self.mips[0].reshape(-1, 3).astype(np.float64)
        return out.reshape(normals.shape[:-1] + (3,))


class EnvironmentProjector(FrameDecoder):
    """Makes reflection cubes from frames of one size and projection.

    Parameters
    ----------
    width, height : int
        Frame size in pixels.
    projection : str or Projection
        As :class:`~provider.core.sh9.engine.SH9Projector` ("equirect", "fisheye", ...).
    size : int
        Face size of mip 0: a power of two from 8 to 256 (default 32).
    encoding, exposure, rotation, response, **options
        As :class:`~provider.core.sh9.engine.SH9Projector`; ``rotation`` (camera → world) turns
        the cube as it turns the coefficients. SH9-only options are accepted and ignored.
    mip_roughness : sequence of float, optional
        Perceptual roughness of each mip (one per mip, mip 0 must be 0: the radiance), for a
        consumer that reads its mips at other roughnesses than k/(K−1) (Babylon.js:
        :func:`provider.core.reflections.gltf_ibl.babylon_roughness`). Default k/(K−1).
    """

    def __init__(self, width: int, height: int, projection="equirect", *, size: int = 32,
                 encoding="auto", exposure=1.0, rotation=None, response=None,
                 mip_roughness=None, **options):
        for key in SH9_ONLY:
            options.pop(key, None)
        try:
            self.size = cubemap.check_size(size)
        except ValueError as exc:
            raise InputError(str(exc)) from None
        check_options(encoding=encoding, exposure=exposure, rotation=rotation)
        self._init_decoder(width, height, encoding, exposure, response)
        self.colour_matrix = colour_matrix(response)     # camera RGB → Rec. 709, or None
        try:
            full = (projection if isinstance(projection, Projection)
                    else make_projection(projection, width, height, **options))
        except ProjectionError as exc:
            raise InputError(str(exc)) from None
        self.warnings = list(full.warnings)
        #: (x0, y0, x1, y1): the part of each frame the projection covers (a ball's box).
        self.window = getattr(full, "window", None)
        self.rotation = None if rotation is None else np.asarray(rotation, np.float64)
        self.sizes = cubemap.mip_sizes(self.size)
        self.roughness = _check_roughness(mip_roughness, len(self.sizes))
        # The finest level: 64² for 16² and 32² cubes (the narrow lobe of mip 1 needs it),
        # 4× the size for 8², the size itself beyond.
        self.base = min(4 * self.size, 64) if self.size <= 32 else self.size
        self.levels = cubemap.mip_sizes(self.base)
        self._omega = [cubemap.texel_solid_angles(n) for n in self.levels]
        # one share a channel: a (6, n, n, 1) share broadcast over three channels made numpy
        # multiply in runs of three (~2 M instructions of the 32² cube's pools; issue 34)
        self._shares = [np.repeat(cubemap.pool_shares(fine, coarse), 3, axis=-1)
                        for fine, coarse in zip(self._omega, self._omega[1:])]
        self._work, self._crop = self._work_geometry(full)
        #: The work image's block side in frame pixels where the crop is whole blocks of it
        #: (1 without a crop), else None: an 8-bit frame is then decoded and averaged in one
        #: pass (:func:`~provider.core.radiometry.blocks.decode_blocks`).
        self._block_factor = self._whole_blocks()
        #: Lines about the table cache (a damaged file rebuilt), also in ``warnings``.
        self.table_notes = []
        key = table_cache.key_of("cube", table_cache.state_of(full), width, height, self.size,
                                 self.rotation, self.roughness)
        vars(self).update(table_cache.cached("cube", key, self._build_tables, self.table_notes))
        self.warnings += self.table_notes

    # -- pixel-independent precomputation --------------------------------------------------
    #: What :meth:`_build_tables` makes: all a frame reads, kept on disk
    #: (:mod:`provider.core.table_cache`), so a restart reads it instead of building it.
    TABLES = ("coverage", "_pix", "_tex", "_val", "_overlap_op", "_fill_share",
              "_fill_weights", "_pix_omega", "_pix_dir", "_source_first", "_outputs",
              "_norms", "_prefilter")

    def _build_tables(self) -> dict:
        self._build_overlap(self._work)
        if not self.coverage > 0:
            raise InputError("no pixel of the frame sees anything with this geometry "
                             "(check --center, --radius, --fov)")
        self._build_prefilter()
        return {name: getattr(self, name) for name in self.TABLES}
    def _work_geometry(self, full: Projection):
        """The projection of the work image and the crop of a full frame it covers."""
        # Equirect width: 4 px per base texel (the work image's pixels, split into sub-pixels,
        # are what the overlap integrates), at most WORK_MAX_WIDTH.
        target = min(WORK_PIXELS_PER_TEXEL * self.base * 2, WORK_MAX_WIDTH)
        if isinstance(full, Equirect):
            # An integer factor: OpenCV's area resize has a fast path for those.
            factor = max(1, round(full.width / target))
            if factor == 1 or full.width // factor < 2 * self.base:
                return full, None
            return full.scaled(factor), full.scaled_source_size(factor)
        area = target * target / 2
        factor = projections_exr.whole_face_factor(
            full, max(1, int(math.sqrt(full.width * full.height / area))))
        if factor == 1:
            return full, None
        try:
            return full.scaled(factor), full.scaled_source_size(factor)
        except (NotImplementedError, ProjectionError):
            return full, None

    def _whole_blocks(self) -> int | None:
        if self._crop is None:
            return 1
        (cw, ch), w = self._crop, self._work
        f = ch // w.height
        return f if (cw, ch) == (f * w.width, f * w.height) else None

    def _build_overlap(self, p: Projection) -> None:
        n = self.base
        ntex = 6 * n * n
        q = SUBPIXELS
        while True:     # a frame coarser than the base cube: finer sub-pixels reach every texel
            sums = overlap_sums(p, n, self.rotation, q)
            if (sums["seen"] > 0).all() or q >= 4 * SUBPIXELS or \
                    sums["coverage"] < 4 * math.pi * 0.999:
                break
            q *= 2
        # chunks of whole pixel rows: the keys (pixel-major) come sorted and distinct
        uniq = np.concatenate(sums.pop("keys"))
        weight = np.concatenate(sums.pop("weights"))
        covered = sums["covered"]
        omega = self._omega[0].reshape(-1)
        self.coverage = sums["coverage"]
        # A texel seen over (nearly) all of its footprint is the mean of what is seen; one
        # partly seen is completed by the fill (the quantisation of sub-pixels is ~1/q²).
        frac = np.clip(covered / omega, 0.0, 1.0)
        whole = self.coverage > 4 * math.pi * 0.999      # the whole sphere is seen
        frac[(frac > 0.97) | (whole & (covered > 0))] = 1.0
        tex_u = uniq % ntex
        self._pix = (uniq // ntex).astype(np.int32)
        self._tex = tex_u.astype(np.int64)
        self._val = (weight / np.maximum(covered[tex_u], 1e-300) * frac[tex_u]).astype(np.float32)
        del uniq, weight, tex_u
        # The same map as an operator (texels that see nothing get one zero weight).
        empty = np.flatnonzero(np.bincount(self._tex, minlength=ntex) == 0)
        self._overlap_op = prefilter.SparseOperator(
            np.concatenate([self._tex, empty]), np.concatenate([self._pix, np.zeros_like(empty)]),
            np.concatenate([self._val, np.zeros(empty.size, np.float32)]),
            (ntex, p.width * p.height))
        self._fill_share = (1.0 - frac).astype(np.float32)          # (6n²,)
        self._fill_weights = self._fill_model(p, sums["axis"])
        # Each work pixel's solid angle and mean direction (world frame): where the light
        # of its brightest pixels is sent exactly (see :func:`.bright.bright_split`).
        self._pix_omega = sums["omega"]
        dsum = sums["dsum"].T
        self._pix_dir = dsum / np.maximum(np.linalg.norm(dsum, axis=1, keepdims=True), 1e-300)

    def _fill_model(self, p, g):
        """Per work pixel (H·W,) weights giving the fill radiance of unseen directions
        (``ground``/``mirror``: albedo·E_axis/π, E_axis the irradiance on a surface facing
        the lens axis: ``g``, each pixel's Σ max(d·axis, 0)·ω), or None (``zero``, or
        nothing unseen)."""
        if not np.any(self._fill_share > 0):
            return None
        fill, albedo = getattr(p, "fill", "zero"), float(getattr(p, "albedo", 0.0))
        if fill == "zero" or albedo == 0 or getattr(p, "lens", None) is None:
            return None
        return (g * albedo / math.pi).astype(np.float32)

    def _build_prefilter(self) -> None:
        # Large cubes: the operator reads the pyramid from PREFILTER_MAX_SOURCE² down and
        # evaluates mips larger than PREFILTER_MAX_FACE² at that size, upsampled bilinearly
        # (their lobes span several texels of it; the bench measures what this costs).
        self._source_first = next(a for a, n in enumerate(self.levels)
                                  if n <= PREFILTER_MAX_SOURCE)
        geom = prefilter.PyramidGeometry(self.levels[self._source_first:])
        mips = []
        self._outputs, self._norms = [], []
        for k, n in enumerate(self.sizes[1:], start=1):
            n = min(n, PREFILTER_MAX_FACE)
            out = cubemap.texel_directions(n).reshape(-1, 3)
            r, c, v, norm = prefilter.build_operator(out, self.roughness[k] ** 2, geom,
                                                     prefilter.mip_tolerance(k, n))
            mips.append(prefilter.fold_cheapest(r, c, v, len(out), geom))
            self._outputs.append(out)
            self._norms.append(norm)
        self._prefilter = prefilter.MipChain(mips) if mips else None

    def at_roughness(self, mip_roughness) -> "EnvironmentProjector":
        """A projector of the same frames, geometry and options whose mips are prefiltered at
        ``mip_roughness`` instead (one per mip, 0 first; Babylon.js:
        :func:`provider.core.reflections.gltf_ibl.babylon_roughness`): it shares this one's work image,
        overlap and pyramid (mip 0 is the same), builds only its own prefilter operator, and
        accepts this one's :class:`WorkImage`; its :meth:`refilter` turns this one's result
        into its own with the prefilter alone."""
        twin = copy.copy(self)
        twin.roughness = _check_roughness(mip_roughness, len(self.sizes))
        twin._build_prefilter()
        return twin

    def _same_geometry(self, other) -> bool:
        """Whether ``other`` makes the same work image (itself, or an :meth:`at_roughness`
        twin of it)."""
        return other is self or other._overlap_op is self._overlap_op

    @property
    def nnz(self) -> int:
        """Sparse entries of the per-frame operators (overlap + the prefilter's sparse parts;
        its dense parts hold ``_prefilter.dense_elements`` more, each ~1/30 of an entry's
        cost: :data:`~provider.core.reflections.prefilter.DENSE_COST`)."""
        return int(self._val.size) + (self._prefilter.nnz if self._prefilter else 0)

    # -- per frame ------------------------------------------------------------------------
    @one_blas_thread
    @cache_sized_buffers
    def project(self, frame: np.ndarray, *, exposure_s: float | None = None,
                gain: float = 1.0, work: "WorkImage | None" = None) -> EnvironmentResult:
        """The cube of one frame (the frame contract of :mod:`provider.core.sh9.engine`).

        ``exposure_s`` and ``gain`` divide the radiance as they divide the coefficients.
        ``work``: this frame's :class:`WorkImage`, filled by the pass that decoded it already
        (:meth:`~provider.core.sh9.engine.SH9Projector.project`'s ``work``): the frame is then
        not decoded again. An incomplete one is ignored."""
        t0 = time.perf_counter()
        stats = {"negative_pixels": 0, "nonfinite_pixels": 0}
        frame = self._prepare(frame)
        k = exposure_scale(exposure_s, gain, stats)
        integer = frame.dtype in (np.uint8, np.uint16)
        scale = (1.0 if integer else self.exposure) * (1.0 if k is None else k)
        if integer and work is not None and work.complete and self._same_geometry(work.projector):
            result = self._project_work(work.array, scale)
            stats["shared_decode"] = True
        elif frame.dtype == np.uint8 and self._block_factor is not None and blocks.KERNEL:
            # the table and the block means in one pass: no float copy of the frame (issue 34;
            # without the C kernel, the bands below keep their float copies in cache)
            result = self._project_work(self._decode_blocks(frame), scale)
        elif integer and self._whole_rows():   # decode and shrink band by band, in cache
            result = self._project_work(self._decode_work(frame), scale)
        else:
            result = self.project_linear(self.decode(frame, stats), scale)
        stats["radiometry"] = self.radiometry if integer else "linear"
        stats["coverage_sr"] = self.coverage
        stats["compute_ms"] = (time.perf_counter() - t0) * 1e3
        result.stats = stats
        return result

    def project_linear(self, lin: np.ndarray, scale: float = 1.0) -> EnvironmentResult:
        """The cube of an already decoded, clean (H, W, 3) float32 linear frame of this
        projector's size, times ``scale``."""
        if self._crop is not None:
            cw, ch = self._crop
            lin = cv2.resize(lin[:ch, :cw], (self._work.width, self._work.height),
                             interpolation=cv2.INTER_AREA)
        return self._project_work(lin, scale)

    def new_work(self, decoder: FrameDecoder | None = None,
                 band_rows: int = 32) -> "WorkImage | None":
        """An empty :class:`WorkImage` for ``decoder``'s band-by-band pass over an integer
        frame (bands of ``band_rows`` rows), or None where its bands cannot make this
        projector's work image: another table (encoding, exposure, response) or bands that
        do not fall on the work image's blocks."""
        if decoder is not None and (
                (decoder.width, decoder.height) != (self.width, self.height)
                or decoder.encoding != self.encoding or decoder.exposure != self.exposure
                or decoder.response is not self.response
                or getattr(decoder, "window", None) != self.window):
            return None
        if self._crop is not None and (not self._whole_rows()
                                       or band_rows % (self._crop[1] // self._work.height)):
            return None
        return WorkImage(self)

    def _whole_rows(self) -> bool:
        """Whether the crop's rows are whole rows of work-image blocks (bands of them make
        the work image): not where an equirect's height is no multiple of the work image's
        (950 rows to 135: the whole-frame area resize spreads the rows, 7.04 a work row)."""
        return self._crop is not None and self._crop[1] % self._work.height == 0

    def _decode_blocks(self, frame: np.ndarray) -> np.ndarray:
        """The work image of an 8-bit frame in one call: each block of ``_block_factor``²
        pixels of the crop linearised through the table and averaged (equal to
        :meth:`_decode_work`'s decode-then-area-resize to float rounding, ~1e-7 relative)."""
        if self._crop is not None:
            cw, ch = self._crop
            frame = frame[:ch, :cw]
        return blocks.decode_blocks(frame, self._lut(np.uint8), self._block_factor)

    def _decode_work(self, frame: np.ndarray) -> np.ndarray:
        """The work image of an integer frame: linearised and area-averaged band by band
        (each band's float copy stays in cache; the same numbers as the whole frame)."""
        work = WorkImage(self)
        f = self._crop[1] // self._work.height
        rows = max(1, 32 // f) * f
        for r0 in range(0, self._crop[1], rows):
            work.add_band(self._linearise(frame[r0:r0 + rows]), r0)
        return work.array

    def _project_work(self, lin: np.ndarray, scale: float) -> EnvironmentResult:
        px = np.ascontiguousarray(lin, np.float32).reshape(-1, 3)
        if scale != 1.0:
            with np.errstate(over="ignore"):   # said below, in one line, not as a warning
                px = px * np.float32(scale)
            if not np.isfinite(px).all():
                raise InputError(
                    f"the lighting overflows at exposure {scale:g}: the cube's float32 texels "
                    f"hold at most {np.finfo(np.float32).max:.3g} (lower --exposure)")
        if self.colour_matrix is not None:     # (calibrate-response --checker)
            px = px @ self.colour_matrix.T.astype(np.float32)
        base = self._overlap_op.apply(px)
        if self._fill_weights is not None:
            fill = self._fill_weights @ px                     # (3,)
            base += self._fill_share[:, None] * fill[None, :].astype(np.float32)
        at = self.levels.index(self.size)
        if self._prefilter is None:
            mip0 = self._pyramid(base, at)[at]
            source = _PrefilterSource(self._overlap_op, mip0, None, None, None)
            return EnvironmentResult([mip0], list(self.roughness), {}, source)
        bright, excess = bright_split(px)
        if bright is None:
            levels = self._pyramid(base)
            mip0 = levels[at]
        else:   # the pyramid the operator reads keeps the smooth rest
            mip0 = self._pyramid(base, at)[at]
            # the overlap's entries are sorted by pixel: each bright pixel's run of them
            lo = np.searchsorted(self._pix, bright)
            hi = np.searchsorted(self._pix, bright, side="right")
            pos = np.repeat(np.arange(bright.size), hi - lo)
            sel = np.arange(pos.size) - np.repeat(np.cumsum(hi - lo) - (hi - lo), hi - lo) \
                + np.repeat(lo, hi - lo)
            base = base - self._overlap(excess, pos, self._val[sel], self._tex[sel])
            levels = self._pyramid(base)
        levels = levels[self._source_first:]
        source = _PrefilterSource(self._overlap_op, mip0,
                                  np.concatenate([lv.reshape(-1, 3) for lv in levels]),
                                  bright, excess)
        return EnvironmentResult(self._prefiltered(source), list(self.roughness), {}, source)

    @one_blas_thread
    @cache_sized_buffers
    def refilter(self, result: EnvironmentResult) -> EnvironmentResult:
        """The cube of the frame that ``result`` was made from, its mips prefiltered at this
        projector's roughness: ``result`` is from a projector of the same geometry (this
        one, or the one this is an :meth:`at_roughness` twin of). Only the prefilter runs:
        the frame is not decoded, overlapped nor pooled again. ``stats`` are ``result``'s
        with this call's ``compute_ms``."""
        t0 = time.perf_counter()
        source = result.prefilter_source
        if source is None or source.geometry is not self._overlap_op:
            raise ValueError("refilter needs a result made by a projector of this geometry "
                             "(this one, or the one it is an at_roughness twin of)")
        out = EnvironmentResult(self._prefiltered(source), list(self.roughness),
                                dict(result.stats), source)
        out.stats["compute_ms"] = (time.perf_counter() - t0) * 1e3
        return out

    def _prefiltered(self, source: "_PrefilterSource") -> list:
        """[mip 0, prefiltered mips…] of one frame's pyramid (and its bright pixels)."""
        mips = [source.mip0]
        if self._prefilter is None:
            return mips
        bright, excess = source.bright, source.excess
        filtered = self._prefilter.apply(source.pyramid)
        for mip, size, out, norm in zip(filtered, self.sizes[1:], self._outputs, self._norms):
            n = min(size, PREFILTER_MAX_FACE)
            if bright is not None:
                k = len(mips)
                kern = prefilter.ggx_weight(out[:, None, :], self._pix_dir[bright][None],
                                            self.roughness[k] ** 2)
                kern *= self._pix_omega[bright][None, :] / norm[:, None]
                mip = mip + (kern @ excess).astype(np.float32)
            mip = mip.reshape(6, n, n, 3)
            if size != n:
                mip = np.stack([_upsample_face(f, size) for f in mip])
            mips.append(mip)
        return mips

    def _overlap(self, px, pix, val, tex=None) -> np.ndarray:
        """(6·base², 3) float32: Σ val · px[pix] into texels ``tex`` (default: all entries)."""
        tex = self._tex if tex is None else tex
        ntex = 6 * self.base * self.base
        gathered = px[pix] * val[:, None]
        return np.stack([np.bincount(tex, weights=gathered[:, c], minlength=ntex)
                         for c in range(3)], axis=1).astype(np.float32)

    def _pyramid(self, base: np.ndarray, last: int | None = None) -> list:
        """The base cube and its exact 2×2 solid-angle pools (:func:`cubemap.pool`), down
        to level ``last`` (default: all)."""
        levels = [base.reshape(6, self.base, self.base, 3)]
        for share in self._shares[:last]:
            levels.append(cubemap.pool(levels[-1], share))
        return levels


@dataclass(frozen=True)
class _PrefilterSource:
    """What a frame's prefiltered mips are made of, at any roughness: mip 0, the pyramid the
    operator reads (levels from PREFILTER_MAX_SOURCE² down, bright pixels' excess taken out),
    the bright pixels and their excess; ``geometry``: the overlap operator it was made by."""

    geometry: object
    mip0: np.ndarray
    pyramid: np.ndarray
    bright: np.ndarray | None
    excess: np.ndarray | None


def _check_roughness(mip_roughness, mips: int) -> list:
    """The roughness of each of ``mips`` mips: k/(K−1) by default, else the given list
    (InputError unless it has one finite value in [0, 1] per mip, 0 first, non-decreasing)."""
    if mip_roughness is None:
        return [k / (mips - 1) for k in range(mips)]
    try:
        r = [float(x) for x in mip_roughness]
    except (TypeError, ValueError):
        raise InputError("mip_roughness must be a list of numbers") from None
    if len(r) != mips or r[0] != 0.0 or not all(math.isfinite(x) and 0 <= x <= 1 for x in r) \
            or any(b < a for a, b in zip(r, r[1:])):
        raise InputError(f"mip_roughness must hold {mips} non-decreasing values in [0, 1], "
                         f"the first 0 (mip 0 is the radiance), got {mip_roughness!r}")
    return r


def _upsample_face(face: np.ndarray, size: int) -> np.ndarray:
    """Bilinear upsampling of one (n, n, 3) face to (size, size, 3), texel centres aligned."""
    return cv2.resize(face, (size, size), interpolation=cv2.INTER_LINEAR)


_CACHE: dict = {}


def compute_environment(image, size: int = 32, projection: str = "equirect",
                        **options) -> EnvironmentResult:
    """The reflection cube of one image (a path or an (H, W, C) array; docs/contract.md §12).

    Options are those of :func:`~provider.core.sh9.engine.compute_sh9` (SH9-only ones ignored).
    Projectors are cached per (size, projection, options), a few at a time."""
    image = image_array(image)
    key = (image.shape[1], image.shape[0], size, projection, freeze_options(options))
    projector = _CACHE.pop(key, None)
    if projector is None:
        projector = EnvironmentProjector(image.shape[1], image.shape[0], projection,
                                         size=size, **options)
    _CACHE[key] = projector
    while len(_CACHE) > 4:          # least recently used first
        _CACHE.pop(next(iter(_CACHE)))
    return projector.project(image)
