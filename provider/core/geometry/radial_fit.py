"""Radially symmetric images (fisheye lenses, a probe's disc) and their per-pixel weights'
radial profiles (no pixels, no I/O).

:func:`symmetric_images` finds a projection's lenses or disc, :func:`centred_on_grid` whether
their centres fall on the pixel grid (the condition for a mirror fold).

A fisheye lens or a probe's disc is symmetric about its centre, so in its own frame each of
its pixels' SH weights is a function of the pixel's distance r from the centre times a
monomial of its offset (1, dx, dy, dx·dy, dx² − dy²: the SH basis's azimuthal part). A
weight is then a table of that function over r instead of a value a pixel:
:func:`fit_profiles` fits it, piecewise linear in r, to the pixels' exact integrals by least
squares (:mod:`provider.core.sh9.lens_fold` keeps the tables and checks them).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class DiscAxes:
    """A light probe's disc (mirror ball, angular map) as a lens: its centre, and the
    camera's axes (looking along −Z, image right +X, up +Y: the lens frame is the world's)."""

    cx: float
    cy: float
    frame: tuple = ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0))   # (axis, right, up)


def symmetric_images(projection) -> tuple:
    """The radially symmetric images of a projection: its fisheye lenses, or a probe's disc."""
    lenses = getattr(projection, "lenses", None)
    if lenses:
        return tuple(lenses)
    lens = getattr(projection, "lens", None)
    if lens is not None:
        return (lens,)
    if hasattr(projection, "normalised") and hasattr(projection, "cx"):
        return (DiscAxes(projection.cx, projection.cy),)
    return ()


def centred_on_grid(projection) -> bool:
    """True when ``projection`` has radially symmetric images (lenses, a probe's disc)
    whose centres all fall on the pixel grid (a pixel's corner or centre): the condition
    for the fold, checked before any weight is made."""
    lenses = symmetric_images(projection)
    return bool(lenses) and all(on_grid(lens) for lens in lenses)


def on_grid(lens) -> bool:
    """The lens's centre on a pixel's corner or centre (twice it an integer, both axes)."""
    return all(abs(2 * v - round(2 * v)) <= 1e-9 for v in (lens.cx, lens.cy))


def lens_region(projection, i, n):
    """Columns [a, b) whose weights belong to lens ``i`` of ``n``."""
    w = projection.width
    if n == 1:
        return 0, w
    return (0, w // 2) if i == 0 else (w - w // 2, w)


def fit_profiles(t: np.ndarray, weights, monomials: list, outlier: np.ndarray) -> np.ndarray:
    """(N, K) float64: per weight k the values R_k at the nodes 0, 1, …, N − 1 of the
    piecewise-linear function of ``t`` (each pixel's r in bins, (n,)) that best gives
    ``weights(k)`` ((n,) float64, the pixels' weights k) as R_k(t) × ``monomials[k]``
    ((n,)), least squares weighted by the monomial's square. Fitted twice: the second time
    without the pixels the first missed by more than ``outlier[k]`` (the image circle's
    edge, where a pixel is partly outside and no function of r holds). A node no pixel
    reaches is 0."""
    b = t.astype(np.int64)
    f = t - b
    n_nodes, K = int(b.max()) + 2, len(monomials)
    R = np.zeros((n_nodes, K))
    for attempt in range(2):
        # Hat functions on the nodes: a tridiagonal system a weight.
        diag, off = np.zeros((n_nodes, K)), np.zeros((n_nodes - 1, K))
        rhs = np.zeros((n_nodes, K))
        for k in range(K):
            m, w = monomials[k], weights(k)
            if attempt:
                fit = (R[b, k] * (1 - f) + R[b + 1, k] * f) * m
                m = m * (np.abs(fit - w) <= outlier[k])
            m2 = m * m
            diag[:, k] = (np.bincount(b, m2 * (1 - f) ** 2, n_nodes)
                          + np.bincount(b + 1, m2 * f * f, n_nodes))
            off[:, k] = np.bincount(b, m2 * f * (1 - f), n_nodes - 1)
            rhs[:, k] = (np.bincount(b, m * w * (1 - f), n_nodes)
                         + np.bincount(b + 1, m * w * f, n_nodes))
        # a ridge far below the data's own terms: nodes no pixel reaches stay 0
        R = tridiagonal_solve(diag + 1e-12 * diag.max(axis=0) + 1e-300, off, rhs)
    return R


def tridiagonal_solve(diag: np.ndarray, off: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """x of the symmetric tridiagonal systems (diagonal ``diag`` (N, K), off-diagonal
    ``off`` (N − 1, K)) x = ``rhs`` (N, K), one a column: the Thomas algorithm (normal
    equations are positive definite: no pivoting; numpy has no banded solver and the
    project does not depend on SciPy for one)."""
    n = diag.shape[0]
    c, g = np.zeros_like(off), np.empty_like(rhs)
    beta = diag[0]
    g[0] = rhs[0] / beta
    for i in range(1, n):
        c[i - 1] = off[i - 1] / beta
        beta = diag[i] - off[i - 1] * c[i - 1]
        g[i] = (rhs[i] - off[i - 1] * g[i - 1]) / beta
    x = np.empty_like(rhs)
    x[-1] = g[-1]
    for i in range(n - 2, -1, -1):
        x[i] = g[i] - c[i] * x[i + 1]
    return x
