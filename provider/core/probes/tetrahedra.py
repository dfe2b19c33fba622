"""Light between probes without the room: weights of the probes at a point, as the engines
blend their own probes (no I/O).

Inside the probes' hull, a point takes the barycentric weights of the Delaunay tetrahedron
around it (Unity's light probes); outside, the light at the nearest point of the hull (the
barycentric weights on its nearest outer face: Unity extrapolates from the outer faces
too). With fewer than four probes, or all in one plane, inverse-distance weights. None of
them knows where the light comes from: a point between a window and a probe gets the
probe's light, the cost measured in docs/probes.md.

The Delaunay tetrahedralisation is exact and brute force: every four probes whose
circumsphere holds no other probe, with probes on one sphere (a grid's corners) separated
by a tiny deterministic lift (Edelsbrunner and Mücke's perturbation, simplified), so the
tetrahedra tile the hull once. Its cost grows as n⁵; :data:`MAX_PROBES` bounds it (8
probes: under a millisecond; 27: 0.1 s; 64: 5 s; once per set of positions).
"""
from __future__ import annotations

import itertools

import numpy as np

from ..errors import InputError

#: Most probes one tetrahedralisation takes (64: about 5 s, once).
MAX_PROBES = 64
#: A tetrahedron flatter than this (volume over the cube of the probes' extent) is no cell.
FLAT = 1e-9
#: Barycentric weights down to this count as inside (a point on a shared face).
ON_FACE = 1e-9


def delaunay(positions) -> np.ndarray:
    """The Delaunay tetrahedra (T, 4) of probe indices; empty with fewer than four probes
    or all of them in one plane."""
    p = _normalised(positions)
    n = len(p)
    if n < 4:
        return np.zeros((0, 4), int)
    if n > MAX_PROBES:
        raise InputError(f"{n} probes: at most {MAX_PROBES} are tetrahedralised (give the "
                         "room instead, or fewer probes)")
    # Lifted onto the paraboloid; a lift a millionth of the extent apart breaks the ties of
    # probes on one sphere (their rounding errors are ten orders smaller).
    lift = (p * p).sum(1) + 1e-6 * np.random.default_rng(0).random(n)
    cells = []
    for combos in _chunks(n):
        q = p[combos]                                        # (C, 4, 3)
        edges = q[:, 1:] - q[:, :1]
        volume = np.linalg.det(edges) / 6
        keep = np.abs(volume) > FLAT
        combos, q = combos[keep], q[keep]
        # The sphere |x|² = 2c·x + r through the four lifted points: a 4×4 solve each.
        a = np.concatenate([2 * q, np.ones(q.shape[:2] + (1,))], axis=2)
        sol = np.linalg.solve(a, lift[combos][..., None])[..., 0]    # (C, 4): c, r
        below = lift[None] - (2 * p @ sol[:, :3].T).T - sol[:, 3:4]  # (C, n): < 0 inside
        below[np.arange(len(combos))[:, None], combos] = 0.0         # its own corners
        cells.append(combos[(below >= -1e-12).all(axis=1)])
    return np.concatenate(cells) if cells else np.zeros((0, 4), int)


def _normalised(positions) -> np.ndarray:
    p = np.asarray(positions, np.float64).reshape(-1, 3)
    if not np.all(np.isfinite(p)):
        raise InputError("probe positions must be finite numbers")
    extent = float(np.ptp(p, axis=0).max()) if len(p) else 0.0
    return (p - p.mean(0)) / (extent or 1.0)


def _chunks(n: int, size: int = 20000):
    combos = itertools.combinations(range(n), 4)
    while True:
        block = np.fromiter(itertools.chain.from_iterable(itertools.islice(combos, size)),
                            int).reshape(-1, 4)
        if not len(block):
            return
        yield block


class Tetrahedra:
    """The probes' Delaunay tetrahedra, ready to weigh the probes at any point."""

    def __init__(self, positions):
        self.positions = np.asarray(positions, np.float64).reshape(-1, 3)
        if len(self.positions) < 1:
            raise InputError("no probes")
        self.cells = delaunay(self.positions)
        corners = self.positions[self.cells]                 # (T, 4, 3)
        self._origin = corners[:, 0]
        self._inverse = (np.linalg.inv(np.transpose(corners[:, 1:] - corners[:, :1],
                                                    (0, 2, 1)))
                         if len(self.cells) else np.zeros((0, 3, 3)))
        faces = {}
        for cell in self.cells:     # the hull: the faces of one tetrahedron only
            for face in itertools.combinations(sorted(int(i) for i in cell), 3):
                faces[face] = faces.get(face, 0) + 1
        self.hull = np.array([f for f, k in faces.items() if k == 1], int).reshape(-1, 3)

    def weights(self, point) -> tuple[np.ndarray, bool]:
        """The probes' weights (n,) at ``point`` (summing to 1), and whether the point is in
        the hull (barycentric in its tetrahedron; else on the hull's nearest face)."""
        x = np.asarray(point, np.float64).reshape(3)
        w = np.zeros(len(self.positions))
        if len(self.cells):
            lam = np.einsum("tij,tj->ti", self._inverse, x - self._origin)
            bary = np.concatenate([1 - lam.sum(1, keepdims=True), lam], axis=1)
            inside = np.flatnonzero((bary >= -ON_FACE).all(axis=1))
            if len(inside):
                t = inside[0]
                np.add.at(w, self.cells[t], np.clip(bary[t], 0, None))
                return w / w.sum(), True
            tri = self.positions[self.hull]
            near, bary = closest_on_triangles(x, tri[:, 0], tri[:, 1], tri[:, 2])
            f = int(np.argmin(np.linalg.norm(near - x, axis=1)))
            np.add.at(w, self.hull[f], np.clip(bary[f], 0, None))
            return w / w.sum(), False
        return inverse_distance(self.positions, x), False


def closest_on_triangles(p, a, b, c):
    """The nearest point (F, 3) of each triangle (a, b, c: (F, 3)) to ``p``, and its
    barycentric weights (F, 3) on a, b, c (Ericson, Real-Time Collision Detection, 5.1.5,
    region by region)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(1), (ac * ap).sum(1)
    bp, cp = p - b, p - c
    d3, d4 = (ab * bp).sum(1), (ac * bp).sum(1)
    d5, d6 = (ab * cp).sum(1), (ac * cp).sum(1)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        v, w = vb / denom, vc / denom                         # the face itself
        regions = [                                           # (where, weight of b, of c)
            ((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0),     # edge bc
             1 - (d4 - d3) / ((d4 - d3) + (d5 - d6)), (d4 - d3) / ((d4 - d3) + (d5 - d6))),
            ((vb <= 0) & (d2 >= 0) & (d6 <= 0), 0.0, d2 / (d2 - d6)),            # edge ac
            ((d6 >= 0) & (d5 <= d6), 0.0, 1.0),                                  # corner c
            ((vc <= 0) & (d1 >= 0) & (d3 <= 0), d1 / (d1 - d3), 0.0),            # edge ab
            ((d3 >= 0) & (d4 <= d3), 1.0, 0.0),                                  # corner b
            ((d1 <= 0) & (d2 <= 0), 0.0, 0.0),                                   # corner a
        ]
        for where, wb, wc in regions:        # the last that applies wins: Ericson's order
            v = np.where(where, wb, v)
            w = np.where(where, wc, w)
    v, w = np.nan_to_num(v), np.nan_to_num(w)
    bary = np.stack([1 - v - w, v, w], axis=1)
    return a + v[:, None] * ab + w[:, None] * ac, bary


def inverse_distance(positions, point, power: float = 2.0) -> np.ndarray:
    """Inverse-distance weights (n,), summing to 1 (all on a probe the point is at)."""
    d = np.linalg.norm(np.asarray(positions, np.float64) - np.asarray(point, np.float64),
                       axis=1)
    if d.min() <= 1e-9 * max(1.0, float(d.max())):
        return (d == d.min()).astype(np.float64) / np.count_nonzero(d == d.min())
    w = d ** -power
    return w / w.sum()


def nearest(positions, point) -> np.ndarray:
    """All the weight on the nearest probe (n,)."""
    d = np.linalg.norm(np.asarray(positions, np.float64) - np.asarray(point, np.float64),
                       axis=1)
    w = np.zeros(len(d))
    w[int(np.argmin(d))] = 1.0
    return w


def blend(coefficients, weights) -> np.ndarray:
    """The probes' SH9 (n, 9, 3) blended with ``weights`` (n,): (9, 3)."""
    return np.tensordot(np.asarray(weights, np.float64),
                        np.asarray(coefficients, np.float64), axes=1)


__all__ = ["MAX_PROBES", "Tetrahedra", "blend", "delaunay", "inverse_distance", "nearest"]
