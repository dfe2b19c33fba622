"""Cube-map geometry (no pixels, no I/O): texel directions, exact texel solid angles,
direction → texel, and solid-angle-exact pooling between levels (docs/contract.md §12).

Layout, shared by the provider, the KTX2 file, the shaders and every client:

* faces in the OpenGL order ``+X −X +Y −Y +Z −Z`` (index 0..5);
* texel ``[f, i, j]`` of an ``n × n`` face sits at ``s = (j + ½)/n``, ``t = (i + ½)/n``
  (row ``i`` is ``t``, column ``j`` is ``s``);
* ``(s, t)`` come from a direction ``d`` in *our* frame (right-handed, +Y up, docs/contract.md
  §1) by the OpenGL cube-map table (:data:`FACE_TABLE`): ``s = (sc/|ma| + 1)/2``,
  ``t = (tc/|ma| + 1)/2``.

So an array ``cube[f]`` uploaded row by row as ``GL_TEXTURE_CUBE_MAP_POSITIVE_X + f`` makes
``texture(cube, d)`` return the value toward ``d`` in our frame, with no flip anywhere.
"""
from __future__ import annotations

import numpy as np

#: Face names in storage order.
FACE_NAMES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")

#: Per face: (major axis, its sign, (axis, sign) giving sc, (axis, sign) giving tc); the
#: OpenGL 4.6 core profile, table 8.19, read with our (x, y, z).
FACE_TABLE = (
    (0, +1, (2, -1), (1, -1)),   # +X: sc = -z, tc = -y
    (0, -1, (2, +1), (1, -1)),   # -X: sc = +z, tc = -y
    (1, +1, (0, +1), (2, +1)),   # +Y: sc = +x, tc = +z
    (1, -1, (0, +1), (2, -1)),   # -Y: sc = +x, tc = -z
    (2, +1, (0, +1), (1, -1)),   # +Z: sc = +x, tc = -y
    (2, -1, (0, -1), (1, -1)),   # -Z: sc = -x, tc = -y
)

#: Smallest and largest face size the provider makes (powers of two).
MIN_SIZE, MAX_SIZE = 8, 256


def face_directions(face: int, sc: np.ndarray, tc: np.ndarray) -> np.ndarray:
    """Unit directions (..., 3) of face coordinates ``sc, tc`` in [-1, 1] on ``face``."""
    major, sign, (sa, ss), (ta, ts) = FACE_TABLE[face]
    sc, tc = np.broadcast_arrays(np.asarray(sc, np.float64), np.asarray(tc, np.float64))
    d = np.empty(sc.shape + (3,))
    d[..., major] = sign
    d[..., sa] = ss * sc
    d[..., ta] = ts * tc
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def texel_directions(n: int) -> np.ndarray:
    """(6, n, n, 3) float64 unit directions of the texel centres of an ``n × n`` cube."""
    c = (np.arange(n) + 0.5) / n * 2 - 1
    tc, sc = np.meshgrid(c, c, indexing="ij")          # row i -> t, column j -> s
    return np.stack([face_directions(f, sc, tc) for f in range(6)])


def _corner_area(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Solid angle of the face rectangle [0, x] × [0, y] (signed), unit distance."""
    return np.arctan2(x * y, np.sqrt(x * x + y * y + 1))


def texel_solid_angles(n: int) -> np.ndarray:
    """(6, n, n) float64 exact solid angle of each texel in steradians (sums to 4π)."""
    e = np.linspace(-1, 1, n + 1)
    y0, x0 = np.meshgrid(e[:-1], e[:-1], indexing="ij")
    y1, x1 = np.meshgrid(e[1:], e[1:], indexing="ij")
    face = (_corner_area(x1, y1) - _corner_area(x0, y1) - _corner_area(x1, y0)
            + _corner_area(x0, y0))
    return np.broadcast_to(face, (6, n, n)).copy()


def direction_to_face(d: np.ndarray):
    """Face index and face coordinates of directions (..., 3) (need not be unit).

    Returns ``(face, s, t)``: int array and floats in [0, 1] (``s`` → column, ``t`` → row).
    Ties between faces go to the lowest face index, as any consistent rule would.
    """
    d = np.asarray(d, np.float64)
    a = np.abs(d)
    major = np.argmax(a, axis=-1)
    ma = np.take_along_axis(d, major[..., None], axis=-1)[..., 0]
    face = 2 * major + (ma < 0)
    s = np.empty(d.shape[:-1])
    t = np.empty(d.shape[:-1])
    for f, (mj, sign, (sa, ss), (ta, ts)) in enumerate(FACE_TABLE):
        m = face == f
        if not np.any(m):
            continue
        den = np.abs(d[..., mj][m])
        s[m] = (ss * d[..., sa][m] / den + 1) / 2
        t[m] = (ts * d[..., ta][m] / den + 1) / 2
    return face, s, t


def direction_to_texel(d: np.ndarray, n: int):
    """``(face, i, j, s, t)`` of directions (..., 3) on an ``n × n`` cube (``i`` row, ``j``
    column, clamped to the face)."""
    face, s, t = direction_to_face(d)
    j = np.clip((s * n).astype(np.int64), 0, n - 1)
    i = np.clip((t * n).astype(np.int64), 0, n - 1)
    return face, i, j, s, t


def flat_index(face, i, j, n: int) -> np.ndarray:
    """Index of texel ``[face, i, j]`` in the flattened ``(6·n·n)`` cube."""
    return (np.asarray(face) * n + i) * n + j


def pool_shares(omega_fine: np.ndarray, omega_coarse: np.ndarray) -> np.ndarray:
    """(6, 2n, 2n, 1) float32: each fine texel's share of its parent's solid angle, from the
    texels' solid angles (:func:`texel_solid_angles`) of the two levels; computed once."""
    parent = omega_coarse.repeat(2, axis=1).repeat(2, axis=2)
    return (omega_fine / parent).astype(np.float32)[..., None]


def pool(cube: np.ndarray, shares: np.ndarray) -> np.ndarray:
    """Solid-angle-weighted 2×2 mean: (6, 2n, 2n, C) radiance → (6, n, n, C), the exact mean
    over each coarse texel (``shares``: :func:`pool_shares`). Pairs of rows, then pairs of
    columns, as plain adds (numpy's multi-axis sum is several times slower here)."""
    w = cube * shares
    rows = w[:, 0::2] + w[:, 1::2]
    return rows[:, :, 0::2] + rows[:, :, 1::2]


def check_size(size) -> int:
    """The face size as an int, or :class:`ValueError` with one line saying what is allowed."""
    try:
        n = int(size)
    except (TypeError, ValueError):
        raise ValueError(f"cube size must be a power of two from {MIN_SIZE} to {MAX_SIZE}, "
                         f"got {size!r}") from None
    if n != size or n < MIN_SIZE or n > MAX_SIZE or n & (n - 1):
        raise ValueError(f"cube size must be a power of two from {MIN_SIZE} to {MAX_SIZE}, "
                         f"got {size!r}")
    return n


def mip_sizes(size: int) -> list[int]:
    """Face sizes of the mip chain: size, size/2, ..., 2."""
    out = [size]
    while out[-1] > 2:
        out.append(out[-1] // 2)
    return out
