"""Sums over a frame's bright regions without a (normals × pixels) kernel (maths only).

The lights' truth (:class:`~provider.core.lights.extractor.LightExtractor`) needs, every
frame, the brute-force irradiance at its normals of the candidates' excess radiance, and
the pairs of seam pixels where two regions may touch. Both are cheaper by geometry:

* :func:`excess_irradiance`: a region's pixels lie in a cap of radius ρ about its centre,
  so a normal more than 90° + ρ from that centre sees none of them and one less than
  90° − ρ all of them, where ``Σ_i max(0, n·d_i) ω_i e_i`` is linear, ``n · M`` with M the
  region's 3 × 3 moment. Only the normals whose horizon cuts a region take the per-pixel
  sum (about half of them for the lit Theta room's 25° panels, a fifth for a 10° lamp).
* :func:`touching_pairs`: which seam pixels touch does not depend on the pixels' values,
  so it is found once; a frame then only compares the labels of those pairs.
"""
from __future__ import annotations

import math

import cv2
import numpy as np

from ..radiometry.blocks import buffer_view, contiguous


try:
    from ._lights import excess_rows as _excess_kernel
except ImportError:          # no compiler at install: its twin (below) takes its place
    _excess_kernel = None

#: Bytes of a block of the (normals × pixels) kernel that :func:`excess_rows_twin` makes
#: and reads at once: well inside a Cortex-A53's 512 KB last-level cache.
BLOCK_BYTES = 128 << 10


def touching_pairs(dirs: np.ndarray, seam: np.ndarray, touch_cos: float):
    """(a, b): flat pixel indices of the pairs of ``seam`` pixels (a before b in ``seam``)
    whose directions (``dirs`` (P, 3), all pixels) have a cosine of at least
    ``touch_cos``; by blocks of rows, so the build's peak memory stays small."""
    sd = dirs[seam]
    a, b = [np.zeros(0, np.intp)], [np.zeros(0, np.intp)]
    for r0 in range(0, len(seam), 256):
        ii, jj = np.nonzero((sd[r0:r0 + 256] @ sd.T) >= touch_cos)
        upper = jj > ii + r0
        a.append(seam[ii[upper] + r0])
        b.append(seam[jj[upper]])
    return np.concatenate(a), np.concatenate(b)


def excess_irradiance(normals, normals32, dirs, dirs32, flux, pix, region) -> np.ndarray:
    """(N, 3) ``Σ_i max(0, n·d_i) f_i`` at the ``normals`` (N, 3) (``normals32`` the same
    in float32) over the pixels ``pix`` of the mid copy, whose directions are ``dirs`` /
    ``dirs32`` (P, 3, all pixels; 0 where unseen) and whose ``flux`` (n, 3) float32 is
    excess radiance × solid angle, grouped by ``region`` (n,) (compact regions: the
    frame's level-0 groups). The same sum as the full kernel's, in another order: the
    normals that a region's horizon cuts take one call of the C kernel
    (``_lights.excess_rows``; :func:`excess_rows_twin` where no compiler built it)."""
    out = np.zeros((len(normals), 3))
    order = np.argsort(region, kind="stable")
    cuts = np.flatnonzero(np.diff(region[order])) + 1
    for sel in np.split(order, cuts):
        # np.take: a row gather at a tenth of fancy indexing's instructions
        p, f = pix[sel], np.take(flux, sel, axis=0)
        d = np.take(dirs, p, axis=0)
        centre = d.sum(axis=0)
        centre /= max(float(np.linalg.norm(centre)), 1e-300)
        cos_rho = float((d @ centre).min())
        margin = (math.sqrt(max(0.0, 1.0 - cos_rho * cos_rho)) if cos_rho > 0 else 2.0
                  ) + 1e-6                      # the float32 directions below: their rounding
        nc = normals @ centre
        whole = nc > margin
        out[whole] += normals[whole] @ (d.T @ f.astype(np.float64))
        cut = np.flatnonzero(np.abs(nc) <= margin).astype(np.int32)
        if len(cut):
            _excess_kernel(np.take(dirs32, p, axis=0), np.ascontiguousarray(f, np.float32),
                           normals32, cut, out)
    return out


def excess_rows_twin(dirs, flux, normals, rows, out) -> None:
    """The C kernel ``_lights.excess_rows`` in numpy: the same arguments, numbers (to float
    rounding) and errors (``_lights.c`` says what each argument is). A (rows × n) float32
    kernel block at a time, small enough to stay in a 512 KB cache while its three
    channels read it (the whole kernel went to DRAM and back); each normal's row is the
    same products whatever the block."""
    views = [buffer_view(a, name == "out", kind, nd, name) for a, name, kind, nd in zip(
        (dirs, flux, normals, rows, out), ("dirs", "flux", "normals", "rows", "out"),
        "fffid", (2, 2, 2, 1, 2))]
    if not all(map(contiguous, views)):
        raise ValueError("every array: C-contiguous")
    m, N = dirs.shape[0], normals.shape[0]
    if dirs.shape[1] != 3 or flux.shape != (m, 3):
        raise ValueError("dirs, flux: (n, 3) float32")
    if normals.shape[1] != 3 or out.shape != (N, 3):
        raise ValueError("normals (N, 3) float32, out (N, 3) float64")
    if len(rows) and (rows.min() < 0 or rows.max() >= N):
        raise ValueError("rows: normal indices in [0, N)")
    dt, ft = dirs.T, np.ascontiguousarray(flux.T)
    step = max(4, BLOCK_BYTES // (4 * max(1, m)))
    for r0 in range(0, len(rows), step):
        at = rows[r0:r0 + step]
        K = np.take(normals, at, axis=0) @ dt                              # (rows, n)
        # cv2's threshold: numpy's maximum against a scalar costs 4× more here
        cv2.threshold(K, 0.0, 0.0, cv2.THRESH_TOZERO, dst=K)
        # a matrix-vector product a channel (a product with f's 3 columns packs all of K)
        np.add.at(out, at, np.stack([K @ fc for fc in ft], axis=1))


if _excess_kernel is None:
    _excess_kernel = excess_rows_twin
#: Whether the excess's C kernel is built (else its twin, :func:`excess_rows_twin`).
KERNEL = _excess_kernel is not excess_rows_twin
