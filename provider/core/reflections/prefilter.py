"""GGX prefiltering of a radiance cube as a fixed sparse linear operator (no pixels, no I/O).

Definition (Karis's split sum with n = v = r, docs/contract.md §12): the prefiltered radiance
toward ``r`` at roughness ``ρ`` (α = ρ²) is

    PF(r) = ∫ L(l) D(h) ⟨r·l⟩ dl / ∫ D(h) ⟨r·l⟩ dl,   h = (r + l)/|r + l|,

D the GGX (Trowbridge-Reitz) distribution. It depends on pixels only through L, so the whole
filter is built once: a sparse matrix from a radiance pyramid (the base cube and its
solid-angle-exact 2×2 pools, :func:`provider.core.geometry.cubemap.pool`) to the texel centres of
every prefiltered mip. Each weight is the exact integral of the kernel over one texel of the
pyramid (sub-texels with exact solid angles), and each output reads a quadtree cut of the
pyramid: a texel is read whole (its mean radiance) where the kernel is nearly constant over
it, else its four children, down to the base level. What reading a texel whole can cost is
∫ (k − k̄)(L − L̄) over it, so a texel is split when the kernel's L1 departure from its mean
over the texel, ∫ |k − k̄|, exceeds a small fraction of the whole lobe's integral
(:func:`mip_tolerance`; measured on the sub-texels of its children, so that a peak at its
centre is seen). This puts the texels where the lobe bends, wherever that is, for every
roughness alike (the fixed rings it replaced, each level from a multiple of its texel size
outward, over-read the far tail and under-read the shoulder of rough lobes). Integrating
instead of sampling keeps a 10⁴ sun exact (importance sampling "falls apart" there,
DESIGN.md §12); the GGX tail is never dropped, only read at a coarser level, so the filter
keeps every source's energy.
"""
from __future__ import annotations

import math

import cv2
import numpy as np

from ..geometry import cubemap

#: Sub-texels per axis used to integrate the kernel over a source texel.
SUBSAMPLES = 4
#: A pyramid texel is split into its four children when ∫ |k − k̄| over it exceeds the mip's
#: tolerance times ∫ k over the sphere (k = D(h)⟨r·l⟩, k̄ its mean over the texel): this
#: value for mip 1, halved for each mip after it (:func:`mip_tolerance`).
TOLERANCE = 7e-4


def mip_tolerance(mip: int, face: int) -> float:
    """The splitting tolerance of prefiltered mip ``mip`` (≥ 1) evaluated on faces of
    ``face``²: :data:`TOLERANCE` halved for each mip after the first (each has a quarter of
    the outputs of the one before, so a tighter tolerance costs it little per frame), but
    at least ``TOLERANCE · face/16``: the mips of cubes above 32², whose narrow lobes are
    limited by the base level's texels rather than by the quadtree.

    Measured against a float64 brute force of PF (``shlight bench --sections environment``
    for the nine shared panoramas; nine other Poly Haven rooms of the same source; the nine
    turned 45° about +Y): the worst mip of a 32² cube errs 0.84 %, 0.93 % and 1.27 %
    (relative RMS), of 8² and 16² cubes at most 0.96 %, 1.03 % and 2.25 %, of 64² 1.64 %,
    1.60 % and 1.94 %; the fixed rings this replaced erred 1.95 %, 3.4 % and 3.3 % at 32²
    with more non-zeros (32²: 1.08 M, now 1.04 M; 16²: 0.36 M, now 0.24 M; 64²: 4.54 M,
    now 2.61 M).
    """
    return TOLERANCE * max(2.0 ** (1 - mip), face / 16)


def ggx_weight(r: np.ndarray, l: np.ndarray, alpha: float) -> np.ndarray:
    """D(h) ⟨r·l⟩ for unit ``r`` (..., 3) and ``l`` (..., 3) (n = v = r), broadcast."""
    rl = np.einsum("...k,...k->...", r, l)
    # |r + l|² = 2 + 2 r·l and r·h = (1 + r·l)/|r + l|, so cos²θ_h = (1 + r·l)/2.
    cos2 = np.clip((1 + rl) / 2, 0.0, 1.0)
    a2 = alpha * alpha
    denom = cos2 * (a2 - 1) + 1
    d = a2 / (math.pi * denom * denom)
    return d * np.maximum(rl, 0.0)


def lobe_integral(alpha: float, steps: int = 20000) -> float:
    """∫ D(h) ⟨r·l⟩ dl over the sphere, 2π ∫₀^{π/2} k(θ) sin θ dθ by the midpoint rule (1 at
    α = 1: the cosine lobe over π)."""
    theta = (np.arange(steps) + 0.5) * (math.pi / 2 / steps)
    l = np.stack([np.sin(theta), np.zeros(steps), np.cos(theta)], axis=-1)
    k = ggx_weight(np.array([0.0, 0.0, 1.0]), l, alpha)
    return float(2 * math.pi * np.sum(k * np.sin(theta)) * (math.pi / 2 / steps))


class PyramidGeometry:
    """What the operator needs of each pyramid level: sub-texel directions, exact sub-texel
    and texel solid angles; level ``k`` has faces of ``sizes[k]`` (finest first, each level
    half the one before)."""

    def __init__(self, sizes: list[int], q: int = SUBSAMPLES):
        self.sizes = list(sizes)
        if any(a != 2 * b for a, b in zip(self.sizes, self.sizes[1:])):
            raise ValueError(f"pyramid levels must halve, finest first: {sizes}")
        self.q = q
        self.offsets = np.cumsum([0] + [6 * n * n for n in sizes])
        self.sub_dirs, self.sub_omega = [], []
        for n in sizes:
            m = n * q
            d = cubemap.texel_directions(m).reshape(6, n, q, n, q, 3)
            w = cubemap.texel_solid_angles(m).reshape(6, n, q, n, q)
            # (texel, q·q sub-texels) ordered by the level's flat texel index.
            self.sub_dirs.append(d.transpose(0, 1, 3, 2, 4, 5).reshape(6 * n * n, q * q, 3))
            self.sub_omega.append(w.transpose(0, 1, 3, 2, 4).reshape(6 * n * n, q * q))
        self.omega = [w.sum(axis=1) for w in self.sub_omega]

    @property
    def total(self) -> int:
        return int(self.offsets[-1])


def children(texels: np.ndarray, n: int) -> np.ndarray:
    """(P, 4) flat indices at level 2n of the four children of flat texels (P,) at level n."""
    face, rem = np.divmod(texels, n * n)
    i, j = np.divmod(rem, n)
    m = 2 * n
    first = (face * m + 2 * i) * m + 2 * j
    return np.stack([first, first + 1, first + m, first + m + 1], axis=1)


def build_operator(outputs: np.ndarray, alpha: float, geom: PyramidGeometry,
                   tolerance: float = TOLERANCE, chunk: int = 8):
    """Sparse prefilter of one mip: ``(rows, cols, vals, norm)`` with ``PF[rows] += vals ·
    pyramid[cols]``, rows normalised to sum to 1 (a constant map stays constant); ``norm``
    (T,) is each row's ``∫ D(h) ⟨r·l⟩ dl`` before normalising.

    ``outputs`` (T, 3): unit directions where PF is evaluated (the mip's texel centres).
    Each output's texels are found top-down from the coarsest level: a texel is kept whole
    unless ∫ |k − k̄| over it (on the q × q sub-texels of each child) exceeds ``tolerance`` ×
    :func:`lobe_integral`, else its children are examined in turn; texels behind the
    horizon (k = 0) are dropped.
    """
    limit = tolerance * lobe_integral(alpha)
    last = len(geom.sizes) - 1
    rows_all, cols_all, vals_all, norms = [], [], [], []
    for t0 in range(0, len(outputs), chunk):
        r = outputs[t0:t0 + chunk]
        k, n = last, geom.sizes[last]
        # (output, texel) pairs to examine at level k
        pt = np.repeat(np.arange(len(r)), 6 * n * n)
        pj = np.tile(np.arange(6 * n * n), len(r))
        acc_rows, acc_cols, acc_vals = [], [], []
        while pt.size:
            if k == 0:                          # the base: read whole
                w = (ggx_weight(r[pt][:, None, :], geom.sub_dirs[0][pj], alpha)
                     * geom.sub_omega[0][pj]).sum(axis=1)
                keep = w > 0
                acc_rows.append(pt[keep])
                acc_cols.append(pj[keep] + geom.offsets[0])
                acc_vals.append(w[keep])
                break
            ch = children(pj, n)                                        # (P, 4)
            sub = (ggx_weight(r[pt][:, None, None, :], geom.sub_dirs[k - 1][ch], alpha)
                   * geom.sub_omega[k - 1][ch])                         # (P, 4, q²)
            w = sub.sum(axis=(1, 2))
            density = (w / geom.omega[k][pj])[:, None, None]
            split = np.abs(sub - density * geom.sub_omega[k - 1][ch]).sum(axis=(1, 2)) > limit
            keep = ~split & (w > 0)
            acc_rows.append(pt[keep])
            acc_cols.append(pj[keep] + geom.offsets[k])
            acc_vals.append(w[keep])
            pt, pj = np.repeat(pt[split], 4), ch[split].reshape(-1)
            k, n = k - 1, geom.sizes[k - 1]
        rows = np.concatenate(acc_rows)
        vals = np.concatenate(acc_vals)
        norm = np.bincount(rows, weights=vals, minlength=len(r))
        norms.append(norm)
        # int32: ~1 M entries a mip, copied several times while the operator is made
        rows_all.append((rows + t0).astype(np.int32))
        cols_all.append(np.concatenate(acc_cols).astype(np.int32))
        vals_all.append(vals / norm[rows])
    return (np.concatenate(rows_all), np.concatenate(cols_all),
            np.concatenate(vals_all), np.concatenate(norms))


class SparseOperator:
    """``y = A x`` for a fixed sparse ``A``, x of shape (M, 3).

    The rows are grouped by their number of entries (each group's rows padded with zero
    entries to the group's longest, the grouping chosen by :func:`length_groups`), and each
    group's entries stored slot-major: entry s of every row of the group, then entry s + 1.
    A group's segment sums are then L − 1 additions of contiguous (rows, 4) blocks, one
    numpy reduction for the group, where ``np.add.reduceat`` paid ~50 instructions a
    segment and channel (callgrind: 16 M of the Theta frame's 32² cube update; issue 34).
    The groups' sums land in group order and are put back in row order by one gather."""

    def __init__(self, rows, cols, vals, shape):
        order = np.lexsort((cols, rows))
        rows, cols, vals = rows[order], cols[order], vals[order]
        self.shape = shape
        counts = np.bincount(rows, minlength=shape[0])
        if np.any(counts == 0):
            raise ValueError("every output needs at least one input")
        self.entries = int(vals.size)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
        cols_g, vals_g, plan = [], [], []
        self._row_of = np.empty(shape[0], np.intp)   # row r's sums are the group sums' [..]
        done, offset = 0, 0
        for lo, hi in length_groups(counts):
            members = np.flatnonzero((counts >= lo) & (counts <= hi))
            slot = np.arange(hi)[:, None]                              # (L, 1)
            real = slot < counts[members][None, :]                     # (L, n)
            at = np.where(real, starts[members][None, :] + slot, 0)
            # each group in its final types at once: one copy fewer of ~1 M entries a mip
            cols_g.append(np.where(real, cols[at], 0).reshape(-1).astype(np.intp))
            vals_g.append(np.where(real, vals[at], 0).reshape(-1).astype(np.float32))
            plan.append((offset, hi, members.size, done))
            self._row_of[members] = done + np.arange(members.size)
            offset += hi * members.size
            done += members.size
        # intp: numpy's gather casts other index types on every call; the columns are in
        # range by construction, so ``take`` needs no per-element bounds check (mode="clip").
        self.cols = np.concatenate(cols_g)
        self.vals = np.concatenate(vals_g)
        del cols_g, vals_g
        self._vals4 = np.repeat(self.vals, 4)     # one weight for each of four lanes
        #: (first stored entry, entries a row L, rows n, first row of the group's sums)
        self._plan = tuple(plan)

    @property
    def nnz(self) -> int:
        """Entries of ``A`` (the groups' zero padding not counted: :attr:`stored`)."""
        return self.entries

    @property
    def stored(self) -> int:
        """Entries gathered per apply, the groups' padding included."""
        return int(self.vals.size)

    def apply(self, x: np.ndarray) -> np.ndarray:
        """(M, 3) float32 → (N, 3) float32. The rows of ``x``, padded to four float32 (by
        OpenCV's RGB → RGBA over one wide row: numpy pads row by row, 20× dearer), are
        gathered as single 16-byte scalars through a complex128 view: one gather for all
        channels, where numpy gathers rows of three several times slower than scalars
        (callgrind: about 20 instructions an entry, 46 with one gather a channel)."""
        rgba = cv2.cvtColor(np.ascontiguousarray(x, np.float32).reshape(1, -1, 3),
                            cv2.COLOR_RGB2RGBA)
        gathered = np.take(rgba.view(np.complex128).reshape(-1), self.cols, mode="clip")
        products = gathered.view(np.float32)
        products *= self._vals4
        sums = np.empty(4 * self.shape[0], np.float32)
        for first, length, n, row in self._plan:
            np.add.reduce(products[4 * first:4 * (first + length * n)].reshape(length, 4 * n),
                          axis=0, out=sums[4 * row:4 * (row + n)])
        rows = np.take(sums.view(np.complex128), self._row_of, mode="clip")
        return cv2.cvtColor(rows.view(np.float32).reshape(1, -1, 4),
                            cv2.COLOR_RGBA2RGB).reshape(-1, 3)


#: Modelled instructions of one group of :class:`SparseOperator` rows (a numpy reduction
#: and its slicing), and of one padding entry (a gather, a multiply and an add).
GROUP_COST, PAD_COST = 15000.0, 20.0


def length_groups(counts: np.ndarray) -> list:
    """Groups of the row lengths ``counts`` (entries a row), as ranges (lo, hi) of lengths
    that cover every row: each group's rows are padded to ``hi`` entries. The ranges are the
    cheapest partition of the sorted distinct lengths under :data:`GROUP_COST` a group and
    :data:`PAD_COST` a padding entry (dynamic programming over the distinct lengths)."""
    lengths, rows = np.unique(counts, return_counts=True)
    m = lengths.size
    # prefix sums: padding of lengths[start:end] to hi is hi·Σrows − Σ(length·rows)
    n_rows = np.concatenate([[0], np.cumsum(rows)]).astype(np.float64)
    n_entries = np.concatenate([[0], np.cumsum(lengths * rows)]).astype(np.float64)
    best = np.zeros(m + 1)
    cut = np.zeros(m + 1, np.int64)
    for end in range(1, m + 1):               # the last group ends with lengths[end - 1]
        hi = float(lengths[end - 1])
        pad = hi * (n_rows[end] - n_rows[:end]) - (n_entries[end] - n_entries[:end])
        cost = best[:end] + GROUP_COST + PAD_COST * pad
        cut[end] = int(np.argmin(cost))
        best[end] = cost[cut[end]]
    groups, end = [], m
    while end:
        start = cut[end]
        groups.append((int(lengths[start]), int(lengths[end - 1])))
        end = start
    return groups[::-1]


class MipOperator:
    """One prefiltered mip's operator, ``y = D x_L + S x``: the entries that read pyramid
    level ``level`` or a coarser one, folded into a dense float32 matrix ``D`` over level
    ``level`` (a coarser texel is the solid-angle-weighted mean of its descendants there,
    which is what the pyramid's pools compute, so the fold is exact to float rounding), and
    the entries that read finer levels, kept sparse (``S``: a :class:`SparseOperator` on
    the whole pyramid, or None). ``level`` None: all sparse.

    Per frame a dense element costs one multiply-add per channel in a BLAS product (0.7
    instructions for three channels, :data:`DENSE_COST`), a sparse entry a gather, a
    multiply and a segment sum (:data:`SPARSE_COST`): :func:`fold_cheapest` picks the level
    at which a mip's outputs read densely enough for the dense part to pay."""

    def __init__(self, rows, cols, vals, n_rows: int, geom: PyramidGeometry, level):
        self.shape = (n_rows, geom.total)
        self.level = level
        #: The operator's entries before folding (all sparse).
        self.entries = int(cols.size)
        if level is None:
            fine = np.ones(cols.size, bool)
            self.dense, self.columns = None, None
        else:
            fine = cols < geom.offsets[level]
            self.dense = _fold(rows[~fine], cols[~fine], vals[~fine], n_rows, geom, level)
            self.columns = (int(geom.offsets[level]), int(geom.offsets[level + 1]))
        rows, cols, vals = rows[fine], cols[fine], vals[fine]
        self.sparse = None
        if rows.size:
            # outputs read only densely get one zero entry (the segment sums need one)
            empty = np.flatnonzero(np.bincount(rows, minlength=n_rows) == 0)
            self.sparse = SparseOperator(np.concatenate([rows, empty]),
                                         np.concatenate([cols, np.zeros_like(empty)]),
                                         np.concatenate([vals, np.zeros(empty.size)]),
                                         self.shape)

    @property
    def nnz(self) -> int:
        """Stored sparse entries."""
        return self.sparse.nnz if self.sparse is not None else 0

    @property
    def dense_elements(self) -> int:
        return int(self.dense.size) if self.dense is not None else 0

    @property
    def cost(self) -> float:
        """Modelled per-frame instructions (:data:`DENSE_COST`, :data:`SPARSE_COST`)."""
        return DENSE_COST * self.dense_elements + SPARSE_COST * self.nnz

    def apply(self, x: np.ndarray) -> np.ndarray:
        """(pyramid texels, 3) float32 → (outputs, 3) float32."""
        if self.sparse is not None:
            out = self.sparse.apply(x)
        else:
            out = np.zeros((self.shape[0], x.shape[1]), np.float32)
        if self.dense is not None:
            a, b = self.columns
            level = np.ascontiguousarray(x[a:b].T)          # (3, texels): one row a channel
            for c in range(x.shape[1]):
                # one matrix-vector product a channel: a (T, n) @ (n, 3) product is five
                # times dearer in OpenBLAS (callgrind: 3.6 against 0.7 instructions an element)
                out[:, c] += self.dense @ level[c]
        return out


#: Instructions (callgrind, x86-64, one thread) per stored element of a mip's dense
#: part for three channels (three float32 matrix-vector products), and per entry of its
#: sparse part (:meth:`SparseOperator.apply`).
DENSE_COST, SPARSE_COST = 0.7, 20.0
#: Most float32 elements of one mip's dense part (16 MiB): bounds the memory of large cubes.
DENSE_MAX = 1 << 22


def fold_cheapest(rows, cols, vals, n_rows: int, geom: PyramidGeometry) -> MipOperator:
    """The :class:`MipOperator` of one mip's entries (rows ``0..n_rows−1``, columns into
    the whole pyramid) with the least modelled cost, its dense part at most
    :data:`DENSE_MAX` elements."""
    best, best_level = SPARSE_COST * cols.size, None
    for level, n in enumerate(geom.sizes):
        elements = n_rows * 6 * n * n
        if elements > DENSE_MAX:
            continue
        cost = DENSE_COST * elements + SPARSE_COST * np.count_nonzero(cols < geom.offsets[level])
        if cost < best:
            best, best_level = cost, level
    return MipOperator(rows, cols, vals, n_rows, geom, best_level)


#: Descendants spread per step of :func:`_fold` (its temporaries: ~30 bytes each).
FOLD_CHUNK = 1 << 18


def _fold(rows, cols, vals, n_rows: int, geom: PyramidGeometry, level: int) -> np.ndarray:
    """(n_rows, 6·n²) float32 over pyramid level ``level`` (faces n²) of entries that read
    that level or coarser ones: an entry on a coarser texel spreads over its descendants at
    ``level`` in proportion to their solid angles."""
    n_level = geom.sizes[level]
    width = 6 * n_level * n_level
    # float32 and in place: an output's texels are a quadtree cut (disjoint), so each element
    # takes one entry's share, rounded once as the float64 sum was; a float64 matrix and a
    # bincount the size of the matrix tripled the build's peak memory
    dense = np.zeros(n_rows * width, np.float32)
    for k in range(level, len(geom.sizes)):
        entries = np.flatnonzero((cols >= geom.offsets[k]) & (cols < geom.offsets[k + 1]))
        # a few entries at a time: each spreads over up to (n_level / n_k)² descendants
        step = max(1, FOLD_CHUNK * geom.sizes[k] ** 2 // n_level ** 2)
        for e0 in range(0, entries.size, step):
            sel = entries[e0:e0 + step]
            texel = cols[sel] - geom.offsets[k]
            desc, n = texel[:, None], geom.sizes[k]
            while n < n_level:
                desc = children(desc.reshape(-1), n).reshape(texel.size, -1)
                n *= 2
            share = geom.omega[level][desc] / geom.omega[k][texel][:, None]
            np.add.at(dense, (rows[sel][:, None] * width + desc).reshape(-1),
                      (vals[sel][:, None] * share).reshape(-1).astype(np.float32))
    return dense.reshape(n_rows, width)


class MipChain:
    """The :class:`MipOperator` of every prefiltered mip, all reading one pyramid."""

    def __init__(self, mips: list):
        self.mips = list(mips)

    @property
    def nnz(self) -> int:
        """Stored sparse entries, all mips."""
        return sum(m.nnz for m in self.mips)

    @property
    def dense_elements(self) -> int:
        return sum(m.dense_elements for m in self.mips)

    @property
    def entries(self) -> int:
        """The entries of the all-sparse operator of the same lobes."""
        return sum(m.entries for m in self.mips)

    @property
    def cost(self) -> float:
        """Modelled per-frame instructions of the prefilter, all mips."""
        return sum(m.cost for m in self.mips)

    def apply(self, x: np.ndarray) -> list:
        """(pyramid texels, 3) float32 → [(outputs of mip k, 3) float32 for each mip]."""
        return [m.apply(x) for m in self.mips]
