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


#: Bytes of a block of the (normals × pixels) kernel that :func:`excess_irradiance` makes
#: and reads at once: well inside a Cortex-A53's 512 KB last-level cache. Smaller blocks
#: move less but cost more BLAS calls (the lit Theta room, one kept buffer, cachegrind /
#: callgrind: 192 KB 20.9 MB and 47.8 M instructions a frame, 128 KB 20.1 MB and 48.6 M,
#: 64 KB 19.2 MB and 50.3 M; issue 44).
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


def excess_irradiance(normals, normals32, dirs, dirs32, flux, pix, region,
                      scratch=None) -> np.ndarray:
    """(N, 3) ``Σ_i max(0, n·d_i) f_i`` at the ``normals`` (N, 3) (``normals32`` the same
    in float32) over the pixels ``pix`` of the mid copy, whose directions are ``dirs`` /
    ``dirs32`` (P, 3, all pixels; 0 where unseen) and whose ``flux`` (n, 3) float32 is
    excess radiance × solid angle, grouped by ``region`` (n,) (compact regions: the
    frame's level-0 groups). The same sum as the full kernel's, in another order.
    ``scratch``: a contiguous float32 array of at least ``BLOCK_BYTES / 4`` elements that
    holds the kernel's blocks (a caller's own, kept from frame to frame; else one is made):
    one buffer written over and over stays in cache, where a new one a region or a frame
    is fresh memory, each of its first writes a miss to DRAM."""
    out = np.zeros((len(normals), 3))
    if scratch is None or scratch.size < BLOCK_BYTES // 4:
        scratch = np.empty(BLOCK_BYTES // 4, np.float32)
    order = np.argsort(region, kind="stable")
    cuts = np.flatnonzero(np.diff(region[order])) + 1
    for sel in np.split(order, cuts):
        # np.take: a row gather at a tenth of fancy indexing's instructions
        p, f = pix[sel], np.take(flux, sel, axis=0)
        ft = np.ascontiguousarray(f.T)
        d = np.take(dirs, p, axis=0)
        centre = d.sum(axis=0)
        centre /= max(float(np.linalg.norm(centre)), 1e-300)
        cos_rho = float((d @ centre).min())
        margin = (math.sqrt(max(0.0, 1.0 - cos_rho * cos_rho)) if cos_rho > 0 else 2.0
                  ) + 1e-6                      # the float32 directions below: their rounding
        nc = normals @ centre
        whole = nc > margin
        out[whole] += normals[whole] @ (d.T @ f.astype(np.float64))
        cut = np.flatnonzero(np.abs(nc) <= margin)
        if len(cut):
            dt = np.take(dirs32, p, axis=0).T
            # K (k, n) a block of normals at a time, small enough to stay in a 512 KB
            # cache while its three channels read it: the whole K went to DRAM and back
            # (the lit Theta room's four regions: 7.7 → 2.3 MB, 6.7 → 7.5 M instructions,
            # cachegrind; tiles of pixels instead, a tenth of the products, took 18 M in
            # numpy's small loops; issue 44). Each normal's row is the same products
            # whatever the block.
            step = max(4, BLOCK_BYTES // (4 * len(p)))
            rows_max = min(step, len(cut))
            block = (scratch[:rows_max * len(p)].reshape(rows_max, len(p))
                     if rows_max * len(p) <= scratch.size
                     else np.empty((rows_max, len(p)), np.float32))   # > BLOCK_BYTES / 16 pixels
            for r0 in range(0, len(cut), step):
                rows = cut[r0:r0 + step]
                K = np.matmul(np.take(normals32, rows, axis=0), dt,
                              out=block[:len(rows)])                       # (rows, n)
                # cv2's threshold: numpy's maximum against a scalar costs 4× more here
                cv2.threshold(K, 0.0, 0.0, cv2.THRESH_TOZERO, dst=K)
                # a matrix-vector product a channel: a product with f's 3 columns packs
                # all of K first (1.6 M instructions a frame for the lit Theta room
                # against 0.45 M, callgrind)
                out[rows] += np.stack([K @ fc for fc in ft], axis=1)
    return out
