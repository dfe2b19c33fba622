"""Fisheye, dual-fisheye and probe-disc SH9 without a per-pixel 9-weight table (no I/O).

A fisheye lens is radially symmetric about its centre, and the SH basis in the lens's own
frame (x image right, y image up, z the optical axis) has a definite parity under each
mirror of the image: 1, z, 3z²−1 and x²−y² are even in x and y; x and xz odd in x; y and yz
odd in y; xy odd in both. So when the pixel grid is symmetric about the lens centre (its
centre at a pixel corner or a pixel centre, as the defaults and most calibrations are), the
four pixels (±dx, ±dy) carry the same lens-frame weights up to those signs, and

    Σ_p w_k(p) I(p) = Σ_quarter w_k(q) (I(+,+) ± I(−,+) ± I(+,−) ± I(−,−)),

exactly. Per frame each lens's square around its centre is folded (two adds and two
subtractions of its halves, then of its rows against the stored mirror rows), and the
folded quarter meets a quarter table of one weight per coefficient: 9 floats per 4 pixels
instead of 36, the lens-frame coefficients turned to the world by the lens's SH rotation.
Pixels with no mirror partner (a centre row or column, a circle clipped by the frame's
edge) keep their own 9 world weights (a short list). The fold is checked against the dense
table when it is built: a lens whose weights are not symmetric to 1e-7 (an off-grid centre,
a skewed calibration) keeps the dense table (:func:`lens_fold` returns None).

The quarter tables themselves are not kept (issue 44: at 36 bytes a quarter pixel they were
most of a frame's DRAM traffic through a Pi's 512 KB cache): in the lens frame each SH9
weight of a radially symmetric lens is a function of the pixel's distance r from the centre
times a monomial of its offset (dx, dy) (1, dx, dy, dx·dy or dx² − dy²), so a lens keeps a
*radial table* per weight, linear in bins of a quarter pixel (fitted to the dense pixel
integrals by least squares: 20 floats a bin, 8 bins a pixel, ~200 KB for a Theta S lens, which
stays in a Pi's cache from frame to frame), and the kernel
makes each row's weights from it. The few quarter pixels where that form does not hold to
:data:`RADIAL_TOLERANCE` of the weight's largest (the image circle's edge, where a pixel is
partly outside; a blend's seam) keep an exact correction (a sparse list). The weights so made
are checked against the dense ones when the fold is built.

The lens is reached only through the projection's dense weights and its lens (centre,
``frame``; :class:`~provider.core.geometry.projections.FisheyeLens`): any r(θ), the check decides.

Extra weight columns (world-frame scalars such as an up-facing meter's cosine, summed in the
same pass as the SH9) need no symmetry: any weight on a symmetric grid is the sum of its four
parity parts, ``w_EE = (w(+,+) + w(−,+) + w(+,−) + w(−,−))/4`` and so on, each of which meets
the fold of its own parity; each non-zero part is one more row of that parity's table.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import cv2
import numpy as np

from ..geometry import radial_fit, sh
from ..geometry.radial_fit import centred_on_grid  # noqa: F401 - the engine's, from here
from ..geometry.radial_fit import lens_region, on_grid, symmetric_images
from .fold_twin import RADIAL_COLUMNS, SH_MONOMIAL, SH_PARITY, radial_weights
from .fold_twin import fold_lens as _fold_twin

try:
    from ._fold import fold_lens as _fold_kernel
except ImportError:          # built without a C compiler: its Python twin (same signature)
    _fold_kernel = _fold_twin

#: True when the C kernel (an 8-bit frame decoded inside the fold) is built (setup.py): the
#: projectors take :meth:`LensFold.decode_project`; else the band fold (faster than the twin).
KERNEL = _fold_kernel is not _fold_twin
#: The kernel's code of each (x parity, y parity) fold (see ``_fold.c``).
_PARITY_CODE = {("E", "E"): 0, ("O", "E"): 1, ("E", "O"): 2, ("O", "O"): 3}
_PARITY_NAME = {code: parity for parity, code in _PARITY_CODE.items()}

#: Largest |mirror weight − sign × weight| accepted, relative to the coefficient's largest
#: weight: float64 rounding is ~1e-13; float32 tables round at 6e-8.
SYMMETRY_TOLERANCE = 1e-7
#: Most pixels left unfolded (residual list), as a share of the pixels that see anything.
MAX_RESIDUAL_SHARE = 0.1
#: Radial tables: bins per pixel of radius (linear in each: ~1e-8 of a weight's largest on a
#: Theta S or Pi lens; half-pixel bins leave 1e-6, and a Theta S lens's blend towards the
#: other keeps 6061 corrections at 4 bins a pixel, 960 at 8), and the largest error a
#: quarter pixel's made weights may have, relative to the weight's largest, before it keeps
#: an exact correction (10× float32's rounding of the old quarter tables: the coefficients
#: stay within 1e-6 of the dense table's, their tests ask 1e-5).
RADIAL_BINS_PER_PIXEL = 8
RADIAL_TOLERANCE = 1e-6


@dataclass
class _FoldedLens:
    """One lens's folded square: centre twice (X, Y, integers), pairs per axis (nx, ny),
    lens→world SH rotation D (9, 9), the lens-frame SH9 weights as a radial table (B, 20)
    float32 with its bins' 1 / width and exact corrections of the quarter pixels it does not
    fit (``fix_at`` (F,) int32, ``fixes`` (F, 9) float32), the extra columns' parity groups
    of quarter tables (k, ny·nx) float32, and per row pair the columns that carry a weight."""

    X: int
    Y: int
    nx: int
    ny: int
    D: np.ndarray
    radial: np.ndarray
    inv_step: float
    fix_at: np.ndarray
    fixes: np.ndarray
    groups: list            # [(("E"|"O", "E"|"O"), k indices, table (len(k), ny·nx))]:
    #                         k ≥ 9, the extra column k − 9
    extent: np.ndarray      # (ny,) int32

    @property
    def geometry(self) -> tuple:
        """(xl, xr, yt, yb, nx, ny), the kernel's."""
        xl, yt = self.X // 2, self.Y // 2
        return xl, self.X - xl, yt, self.Y - yt, self.nx, self.ny

    def sh_quarter(self) -> np.ndarray:
        """(9, ny·nx) float32: the lens-frame SH9 weight of every quarter pixel (the band by
        band path's; made on first use, not kept by the table cache)."""
        q = radial_weights(self.radial, self.inv_step, self.geometry)
        q[:, self.fix_at] += self.fixes.T
        q.reshape(9, self.ny, self.nx)[:, np.arange(self.nx) >= self.extent[:, None]] = 0
        return q.astype(np.float32)

    @functools.cached_property
    def group_ks(self) -> list:
        """Parity groups of every weight, SH9 and extras: [(parity, k indices)], the order
        of the sums the fold hands back."""
        sh9 = {}
        for k, code in enumerate(SH_PARITY):
            sh9.setdefault(_PARITY_NAME[code], []).append(k)
        return sorted(list(sh9.items()) + [(parity, ks) for parity, ks, _ in self.groups],
                      key=lambda g: g[0])

    @functools.cached_property
    def all_groups(self) -> list:
        """:attr:`group_ks` with each group's quarter tables (len(k), ny·nx) float32, the
        SH9's made from the radial table: the band by band path's (without the kernel)."""
        q = self.sh_quarter()
        # keyed by parity too: one extra column (an up-facing cosine) has a part of each
        # parity, the same k in two groups
        extra = {(parity, tuple(ks)): t for parity, ks, t in self.groups}
        return [(parity, ks, q[ks] if ks[0] < 9 else extra[(parity, tuple(ks))])
                for parity, ks in self.group_ks]

    @property
    def rows(self):
        """(first, skip): the lens's folded rows are frame rows [first, first + ny) (top)
        and [first + ny + skip, first + 2·ny + skip) (bottom); skip = 1 for a centre row
        through pixel centres (unpaired: the residual list)."""
        return self.Y // 2 - self.ny, self.Y % 2

    @functools.cached_property
    def kernel_data(self) -> tuple:
        """The C kernel's constant arguments (made once): geometry, per row pair the columns
        to read (up to the last where some weight is non-zero), the radial table, its bins'
        1 / width, the corrections, the extras' stacked quarter tables (K, ny·nx) (K may be
        0) and each one's fold code."""
        tables = np.ascontiguousarray(
            np.concatenate([t for _, _, t in self.groups]) if self.groups
            else np.zeros((0, self.ny * self.nx)), np.float32)
        codes = np.array([_PARITY_CODE[parity] for parity, k, _ in self.groups for _ in k],
                         np.int32)
        return (self.geometry, self.extent, self.radial, self.inv_step, self.fix_at,
                self.fixes, tables, codes)

    @property
    def table_floats(self) -> int:
        """Floats (and indices) a frame reads for this lens's weights."""
        return (self.radial.size + self.fix_at.size + self.fixes.size
                + sum(t.size for _, _, t in self.groups))

    def x_fold(self, rows: np.ndarray, even: np.ndarray, odd: np.ndarray,
               flipped: np.ndarray) -> None:
        """``even``, ``odd`` (h, nx, 3) = right half + and − the mirrored left half of
        ``rows``; ``flipped`` a scratch buffer of the same shape."""
        xl, xr = self.X // 2, self.X - self.X // 2
        right = rows[:, xr:xr + self.nx]
        cv2.flip(rows[:, xl - self.nx:xl], 1, dst=flipped)
        cv2.add(right, flipped, dst=even)
        cv2.subtract(right, flipped, dst=odd)


class LensFold:
    """The folded projection of one fisheye or dual-fisheye geometry: :meth:`new` an
    accumulator per frame, :meth:`add` rows in increasing order (bands, or the whole
    frame), :meth:`coefficients` at the end.

    Per band only the x fold runs (three cv2 calls a lens, into the frame's per-lens
    buffers); the y fold, the split into planes and the products with the quarter tables run
    once per lens at the end of the frame (:meth:`_reduce`): a few dozen calls a frame
    instead of ~30 a band and lens (issue 34: the Python calls cost more than their work).
    The buffers (7 × 3 floats a quarter pixel: 17 MB for a Theta S 1280×720 frame) stay with
    the fold from frame to frame, one set a frame in flight."""

    def __init__(self, lenses, residual_index, residual_weights, width, extras=0):
        self.lenses = lenses
        self.width = width
        self.extras = extras                        # extra world-frame weight columns
        self._res_index = residual_index            # sorted flat pixel indices
        self._res_weights = residual_weights        # (R, 9 + extras) float32, world frame
        self._pool = []
        self._res_rows = {}     # (r0, r1) -> (band-local residual indices, their weights)
        self._ops = {}          # (r0, r1) -> the band's x folds (:meth:`_band_ops`)

    def __getstate__(self):      # buffers and lookups are per process, not pickled
        return {**self.__dict__, "_pool": [], "_res_rows": {}, "_ops": {}}

    @property
    def table_floats(self) -> int:
        """Weights read per frame (floats): radial tables and corrections (once where lenses
        share them), extras' quarter tables and the residual list."""
        shared = {id(L.radial): L.radial.size + L.fix_at.size + L.fixes.size
                  for L in self.lenses}
        return (sum(shared.values()) + self._res_weights.size
                + sum(t.size for L in self.lenses for _, _, t in L.groups))

    def _buffers(self, band_rows: int) -> list:
        """Per lens: x-folded (even, odd) rows (2·ny, nx, 3) float32, the y fold's flipped
        top halves and its output (ny, nx, 3), and a band's flip scratch; reused across
        frames (one set a frame in flight): allocating them a frame costs page faults."""
        try:
            return self._pool.pop()
        except IndexError:
            f32 = np.float32
            return [{"E": np.empty((2 * L.ny, L.nx, 3), f32),
                     "O": np.empty((2 * L.ny, L.nx, 3), f32),
                     "topE": np.empty((L.ny, L.nx, 3), f32),
                     "topO": np.empty((L.ny, L.nx, 3), f32),
                     "fold": np.empty((L.ny, L.nx, 3), f32),
                     "flip": np.empty((max(band_rows, 1), L.nx, 3), f32)}
                    for L in self.lenses]

    def new(self, band_rows: int = 32) -> dict:
        return {"buffers": None, "band_rows": band_rows, "sums": None,
                "res": np.zeros((3, 9 + self.extras))}

    def add(self, lin: np.ndarray, r0: int, state: dict) -> None:
        """Add linear float32 rows [r0, r0 + len(lin)) (full width) of the frame."""
        if lin.dtype != np.float32:
            lin = lin.astype(np.float32)
        r1 = r0 + lin.shape[0]
        buffers = state["buffers"]
        if buffers is None:
            buffers = state["buffers"] = self._buffers(max(state["band_rows"], lin.shape[0]))
        for i, a, b, i0 in self._band_ops(r0, r1):
            L, buf = self.lenses[i], buffers[i]
            flip = buf["flip"]
            if flip.shape[0] < b - a:
                flip = buf["flip"] = np.empty((b - a, L.nx, 3), np.float32)
            L.x_fold(lin[a - r0:b - r0], buf["E"][i0:i0 + b - a], buf["O"][i0:i0 + b - a],
                     flip[:b - a])
        if self._res_index.size:
            rows = self._res_rows.get((r0, r1))
            if rows is None:        # the same bands every frame: looked up once
                lo, hi = np.searchsorted(self._res_index, [r0 * self.width, r1 * self.width])
                rows = self._res_rows[(r0, r1)] = (
                    (self._res_index[lo:hi] - r0 * self.width, self._res_weights[lo:hi])
                    if hi > lo else None)
            if rows is not None:
                px = lin.reshape(-1, 3)[rows[0]]
                state["res"] += px.T @ rows[1]

    def decodes(self, frame: np.ndarray, mid_shape: tuple | None = None,
                factor: int = 1) -> bool:
        """True when :meth:`decode_project` takes ``frame``: an 8-bit (H, W, 3) frame of
        this geometry (or a float32 one: no decode) and the C kernel built; ``mid_shape``:
        the lights' (h, w) copy of ``factor`` × ``factor`` block means, which must tile the
        frame."""
        if (not KERNEL or frame.dtype not in (np.uint8, np.float32) or frame.ndim != 3
                or frame.shape[2] != 3 or frame.shape[1] != self.width):
            return False
        h, w = frame.shape[:2]
        return mid_shape is None or (h % factor == 0 and w % factor == 0
                                     and tuple(mid_shape) == (h // factor, w // factor))

    def decode_project(self, frame: np.ndarray, table: np.ndarray | None, state: dict,
                       mid: np.ndarray | None = None, factor: int = 1,
                       clip: np.ndarray | None = None, mean: bool = True, first=None):
        """The whole 8-bit ``frame`` decoded through ``table`` inside the fold (the C
        kernel, one call a lens: no float copy of the frame), into ``state`` as :meth:`add`
        of every row would; ``table`` None: ``frame`` is linear float32 already. ``mid``
        (see :meth:`decodes`) gets the block means of the pixels that carry a weight, the
        others counted as black (as a lens's surround). ``clip`` (4,) float64: the kernel's
        clip tally of the lenses' squares and of the unpaired pixels' L00 (``_fold.c``).
        ``mean`` False: ``mid`` is left as block sums (its reader scales them in cache).
        ``first`` (luma, omega, coarse_size, coarse_factor): the lights' first pass
        (:func:`~provider.core.lights.first_pass.first_pass`) run by the kernel on each band
        of ``mid`` as it completes (in cache) where one call folds every lens: returns its
        (Y, total, coarse, Ymax), ``mid`` made block means; else None."""
        t = None if table is None else np.ascontiguousarray(table, np.float32).reshape(-1)
        item = frame.itemsize
        if frame.strides[2] != item or frame.strides[1] != 3 * item:
            frame = np.ascontiguousarray(frame)
        calls, fused = self._kernel_calls(), None
        if first is not None and mid is not None and len(calls) == 1:
            luma, omega, size, cf = first      # its Y and coarse copy, for the kernel to fill
            fused = (np.empty(mid.shape[:2], np.float32),
                     None if size is None else np.empty((size[1], size[0], 3), np.float32),
                     np.empty(mid.shape[0], np.float32))
            first = (luma, omega, *fused[:2], int(cf), 1.0 / (factor * factor), fused[2])
        sums, total, residual = [None] * len(self.lenses), None, None
        if self._res_index.size:
            residual = (*self._residual_args(frame.shape[0]), np.zeros((self.extras + 9, 3)))
        for n, (lead, rest) in enumerate(calls):
            L = self.lenses[lead]
            geometry, extent, radial, inv, fix_at, fixes, tables, codes = L.kernel_data
            others = np.array([self.lenses[m].geometry[:2] for m in rest], np.int32
                              ).reshape(-1, 2)
            out = np.zeros((1 + len(rest), 9 + tables.shape[0], 3))
            # The first call zeroes mid and takes the unpaired pixels (at their rows).
            total = _fold_kernel(frame, t, geometry, others, extent, radial, inv, fix_at,
                                 fixes, tables, codes, out, mid, factor, n == 0, clip,
                                 residual if n == 0 else None, first if fused else None)
            # rows: the SH9 weights, then the extras in their groups' order (keyed by parity
            # too: an extra column has a part of each parity, the same k in two groups)
            rows, at = {}, 9
            for parity, ks, _ in L.groups:
                rows[(parity, tuple(ks))] = list(range(at, at + len(ks)))
                at += len(ks)
            for lens_out, m in zip(out, (lead, *rest)):
                sums[m] = [lens_out[rows.get((parity, tuple(ks)), ks)].T
                           for parity, ks in L.group_ks]
        state["sums"] = sums
        if residual is not None:
            state["res"] += residual[3].T
        if fused:
            return fused[0], float(total), fused[1], fused[2]
        if mid is not None and mean:
            mid *= np.float32(1.0 / (factor * factor))
        return None

    def _residual_args(self, height: int) -> tuple:
        """The unpaired pixels' row starts (H + 1,), columns and world-frame weights (the
        kernel's ``residual`` but its sums), made once."""
        if ("residual", height) not in self._ops:
            rows, cols = np.divmod(self._res_index, self.width)
            self._ops[("residual", height)] = (
                np.searchsorted(rows, np.arange(height + 1)).astype(np.int32),
                cols.astype(np.int32), np.ascontiguousarray(self._res_weights, np.float32))
        return self._ops[("residual", height)]

    def _kernel_calls(self) -> list:
        """[(lens, [other lenses])]: lenses whose weights are the same (a dual fisheye's two
        lenses, each the other mirrored in the world, no extra columns: the same lens-frame
        weights, rows and centre offset) go in one call, which makes each row pair's
        weights once for both."""
        calls = self._ops.get("calls")
        if calls is None:
            calls = []
            for n, L in enumerate(self.lenses):
                for first, rest in calls:
                    F = self.lenses[first]
                    if (not L.groups and not F.groups and L.Y == F.Y and L.nx == F.nx
                            and L.ny == F.ny and L.X % 2 == F.X % 2
                            and L.inv_step == F.inv_step
                            and all(np.array_equal(a, b) for a, b in (
                                (L.radial, F.radial), (L.fix_at, F.fix_at),
                                (L.fixes, F.fixes), (L.extent, F.extent)))):
                        rest.append(n)
                        break
                else:
                    calls.append((n, []))
            self._ops["calls"] = calls
        return calls

    def _band_ops(self, r0: int, r1: int) -> list:
        """[(lens, frame rows a, b, buffer row)] of frame rows [r0, r1): the same bands every
        frame, so worked out once."""
        ops = self._ops.get((r0, r1))
        if ops is None:
            ops = []
            for i, L in enumerate(self.lenses):
                first, skip = L.rows
                # Frame rows → buffer rows: the top ny rows, then the bottom ny past the
                # centre row.
                for f0, at in ((first, 0), (first + L.ny + skip, L.ny)):
                    a, b = max(f0, r0), min(f0 + L.ny, r1)
                    if a < b:
                        ops.append((i, a, b, at + a - f0))
            self._ops[(r0, r1)] = ops
        return ops

    def _reduce(self, state: dict) -> list:
        """Per lens, per parity group: (3, len(k)) float64 sums of the whole frame (after
        every row was added): the y fold of the stored rows, then one dot product
        per weight and plane. The buffers go back to the pool."""
        if state["sums"] is not None:
            return state["sums"]
        buffers = state["buffers"]
        if buffers is None:                     # no rows were added
            state["sums"] = [[np.zeros((3, len(k))) for _, k in L.group_ks]
                             for L in self.lenses]
            return state["sums"]
        sums = []
        for L, buf in zip(self.lenses, buffers):
            ny = L.ny
            halves = {}
            for name in {parity[0] for parity, _, _ in L.all_groups}:
                # Top rows by distance from the centre row (flipped), against the bottom's.
                cv2.flip(buf[name][:ny], 0, dst=buf["top" + name])
                halves[name] = (buf[name][ny:], buf["top" + name])
            out, folded = [], buf["fold"]
            for parity, k, table in L.all_groups:
                bottom, top = halves[parity[0]]
                if parity[1] == "E":
                    cv2.add(bottom, top, dst=folded)
                else:
                    cv2.subtract(bottom, top, dst=folded)
                acc = np.empty((3, len(k)))
                for c, plane in enumerate(cv2.split(folded)):
                    flat = plane.reshape(-1)
                    # One BLAS sdot a weight: 0.4 instructions a float against sgemv's 1.2
                    # for k = 3 rows at once, and 14 for a product with the 3 interleaved
                    # channels (callgrind, 320² quarter).
                    for j, row in enumerate(table):
                        acc[c, j] = np.dot(flat, row)
                out.append(acc)
            sums.append(out)
        self._pool.append(buffers)
        state["buffers"], state["sums"] = None, sums
        return sums

    def coefficients(self, state: dict) -> np.ndarray:
        """(9, 3) float64 world-frame coefficients of the rows added."""
        out = state["res"].T[:9].astype(np.float64)
        for L, sums in zip(self.lenses, self._reduce(state)):
            local = np.zeros((9 + self.extras, 3))
            for a, (_, k) in zip(sums, L.group_ks):
                local[k] += a.T
            out += L.D @ local[:9]
        return out

    def extra_sums(self, state: dict) -> np.ndarray:
        """(extras, 3) float64: the frame's sums against the extra weight columns."""
        out = state["res"].T[9:].astype(np.float64)
        for L, sums in zip(self.lenses, self._reduce(state)):
            for a, (_, k) in zip(sums, L.group_ks):
                for j, kk in enumerate(k):
                    if kk >= 9:
                        out[kk - 9] += a[:, j]
        return out


def _fold_lens(lens, region, weights, height, extra=None, like=()):
    """A :class:`_FoldedLens` of ``lens`` over columns ``region`` of the (H, W, 9) world
    weights (and the (H, W, E) ``extra`` world-frame columns, split into parity parts), and
    the mask of the pixels it folds; None where the grid is not symmetric. ``like``: lenses
    already folded, whose radial tables this one shares where they give its weights."""
    if not on_grid(lens):
        return None
    X, Y = int(round(2 * lens.cx)), int(round(2 * lens.cy))
    a, b = region
    nx = min(X // 2 - a, b - (X - X // 2))
    ny = min(Y // 2, height - (Y - Y // 2))
    if nx < 1 or ny < 1:
        return None
    f, r, u = lens.frame
    D = sh.sh_rotation(np.stack([r, u, f], axis=1))     # lens frame -> world
    local = weights[:, a:b] @ D          # (H, b − a, 9), the lens's columns: w_world = D w_local
    xl, xr, yt, yb = X // 2, X - X // 2, Y // 2, Y - Y // 2
    cl, cr = xl - a, xr - a              # the same columns in ``local``
    def quadrants(arr):  # (x parity sign source, y parity sign source): the quadrant, flipped
        return {(1, 1): arr[yb:yb + ny, cr:cr + nx],
                (-1, 1): arr[yb:yb + ny, cl - nx:cl][:, ::-1],
                (1, -1): arr[yt - ny:yt, cr:cr + nx][::-1],
                (-1, -1): arr[yt - ny:yt, cl - nx:cl][::-1, ::-1]}
    quads = quadrants(local)
    q = quads[(1, 1)]
    scale = np.maximum(local.max(axis=(0, 1)), -local.min(axis=(0, 1)))   # no |local| copy
    groups = {}
    for k in range(9):
        tol = SYMMETRY_TOLERANCE * max(scale[k], 1e-300)
        sx = 1 if np.sum(quads[(-1, 1)][..., k] * q[..., k]) >= 0 else -1
        sy = 1 if np.sum(quads[(1, -1)][..., k] * q[..., k]) >= 0 else -1
        for (mx, my), w in quads.items():
            sign = (sx if mx < 0 else 1) * (sy if my < 0 else 1)
            if np.max(np.abs(w[..., k] - sign * q[..., k])) > tol:
                return None
        parity = ("E" if sx > 0 else "O", "E" if sy > 0 else "O")
        if parity != _PARITY_NAME[SH_PARITY[k]] and np.any(q[..., k] != 0):
            return None       # not a lens frame aligned with the image (kept dense)
    groups, columns = {}, {}
    if extra is not None:
        ex = extra[:, a:b]
        eq = quadrants(ex)
        for e in range(ex.shape[-1]):
            for px in ("E", "O"):
                for py in ("E", "O"):
                    part = sum(w[..., e] * ((-1 if px == "O" and mx < 0 else 1)
                                            * (-1 if py == "O" and my < 0 else 1))
                               for (mx, my), w in eq.items()) / 4.0
                    if np.any(part != 0):
                        groups.setdefault((px, py), []).append(9 + e)
                        columns.setdefault((px, py), []).append(part)
    tables = [(parity, ks, np.ascontiguousarray(
                  np.stack(columns[parity]).reshape(len(ks), ny * nx), np.float32))
              for parity, ks in sorted(groups.items())]     # (k, ny·nx): one row a weight
    seen = np.any(q != 0, axis=-1)
    for _, _, t in tables:
        seen |= np.any(t.reshape(-1, ny, nx) != 0, axis=0)
    extent = np.where(seen.any(axis=1), nx - np.argmax(seen[:, ::-1], axis=1), 0)
    geometry = (xl, xr, yt, yb, nx, ny)
    made = None
    for F in like:      # a lens already made whose weights are these (a dual fisheye's twin)
        if (F.Y == Y and F.X % 2 == X % 2 and (F.nx, F.ny) == (nx, ny) and not tables
                and not F.groups and np.array_equal(F.extent, extent)
                and _gives_back(q, geometry, extent, F.radial, F.inv_step, F.fix_at,
                                F.fixes)):
            made = F.radial, F.inv_step, F.fix_at, F.fixes
            break
    else:
        made = _radial_table(q, geometry, extent)
    if made is None:
        return None
    mask = np.zeros(weights.shape[:2], bool)
    rows = np.r_[yt - ny:yt, yb:yb + ny]
    mask[np.ix_(rows, np.r_[xl - nx:xl, xr:xr + nx])] = True
    return _FoldedLens(X, Y, nx, ny, D, *made, tables, extent.astype(np.int32)), mask


def _radial_table(q, geometry, extent):
    """(radial table (B, 20) float32, its bins' 1 / width, fix_at, fixes) of the lens-frame
    SH9 quarter weights ``q`` (ny, nx, 9) float64 (see ``_fold.c``), fitted to the quarter
    pixels read (columns j < ``extent[i]``); None where the made weights and their
    corrections do not give ``q`` back to :data:`RADIAL_TOLERANCE`."""
    nx, ny = geometry[4], geometry[5]
    read = np.arange(nx)[None, :] < extent[:, None]
    inv = float(RADIAL_BINS_PER_PIXEL)
    if not read.any():
        return (np.zeros((1, RADIAL_COLUMNS), np.float32), inv, np.zeros(0, np.int32),
                np.zeros((0, 9), np.float32))
    dy, dx = np.nonzero(read)
    dx = dx + (geometry[1] - geometry[0] + 1) / 2
    dy = dy + (geometry[3] - geometry[2] + 1) / 2
    monomials = {"1": np.ones_like(dx), "dx": dx, "dy": dy, "dx dy": dx * dy,
                 "dx2 - dy2": dx * dx - dy * dy}
    scale = np.maximum(np.maximum(q.max(axis=(0, 1)), -q.min(axis=(0, 1))), 1e-300)
    R = radial_fit.fit_profiles(np.hypot(dx, dy) * inv, lambda k: q[..., k][read],
                                [monomials[m] for m in SH_MONOMIAL],
                                10 * RADIAL_TOLERANCE * scale)
    radial = np.zeros((R.shape[0] - 1, RADIAL_COLUMNS), np.float32)
    radial[:, 0:8] = R[:-1, :8]
    radial[:, 8:16] = R[1:, :8] - R[:-1, :8]
    radial[:, 16] = R[:-1, 8]
    radial[:, 17] = R[1:, 8] - R[:-1, 8]
    # The check: the weights the kernel makes, and exact corrections where they miss.
    flat = read.reshape(-1)
    miss = np.zeros(ny * nx, bool)
    for k in range(9):          # a weight at a time (the build's peak memory)
        made = radial_weights(radial, inv, geometry, (k,))[0]
        miss |= flat & (np.abs(q[..., k].reshape(-1) - made) > RADIAL_TOLERANCE * scale[k])
    fix_at = np.flatnonzero(miss).astype(np.int32)
    fixes = np.empty((fix_at.size, 9), np.float32)
    for k in range(9):
        fixes[:, k] = q[..., k].reshape(-1)[fix_at] - radial_weights(radial, inv, geometry,
                                                                     (k,))[0, fix_at]
    if not _gives_back(q, geometry, extent, radial, inv, fix_at, fixes):
        return None
    return radial, inv, fix_at, fixes


def _gives_back(q, geometry, extent, radial, inv, fix_at, fixes) -> bool:
    """Whether the weights the kernel makes from ``radial`` with the corrections are the
    lens-frame SH9 quarter weights ``q`` (ny, nx, 9) to :data:`RADIAL_TOLERANCE` of each
    weight's largest, on the quarter pixels read."""
    nx, ny = geometry[4], geometry[5]
    flat = (np.arange(nx)[None, :] < extent[:, None]).reshape(-1)
    for k in range(9):
        made = radial_weights(radial, inv, geometry, (k,))[0]
        made[fix_at] += fixes[:, k]
        if not np.all(np.abs(q[..., k].reshape(-1)[flat] - made[flat])
                      <= RADIAL_TOLERANCE * max(np.abs(q[..., k]).max(), 1e-300)):
            return False
    return True


def lens_fold(projection, weights: np.ndarray,
              extra: np.ndarray | None = None) -> LensFold | None:
    """The folded projection of a fisheye (``projection.lens``), dual fisheye
    (``projection.lenses``) or probe disc (mirror ball, angular map: ``cx``, ``cy``) with dense
    world weights ``weights`` (H·W, 9) and optional extra world-frame columns ``extra``
    (H·W, E) summed in the same pass (:meth:`LensFold.extra_sums`), or None (not such a
    geometry, a grid not symmetric about a centre, too many unpaired pixels)."""
    lenses = symmetric_images(projection)
    if not lenses:
        return None
    h, w = projection.height, projection.width
    dense = np.asarray(weights, np.float64).reshape(h, w, 9)
    ex = None if extra is None else np.asarray(extra, np.float64).reshape(h, w, -1)
    folded, covered = [], np.zeros((h, w), bool)
    for i, lens in enumerate(lenses):
        region = lens_region(projection, i, len(lenses))
        made = _fold_lens(lens, region, dense, h, ex, folded)
        if made is None:
            return None
        folded.append(made[0])
        covered |= made[1]
    seen = np.any(dense != 0, axis=-1)
    if ex is not None:
        dense = np.concatenate([dense, ex], axis=-1)
        seen |= np.any(ex != 0, axis=-1)
    residual = np.flatnonzero((seen & ~covered).reshape(-1))
    if residual.size > MAX_RESIDUAL_SHARE * max(int(seen.sum()), 1):
        return None
    return LensFold(folded, residual.astype(np.int64),
                    dense.reshape(h * w, -1)[residual].astype(np.float32), w,
                    0 if ex is None else ex.shape[-1])
