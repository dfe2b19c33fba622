"""Environment cube maps for the shader harness: the layout of docs/contract.md §12, a CPU
sampler that filters as OpenGL does, test cubes, and the upload of every mip to OpenGL.

Layout (the provider's, CUBE_CONTRACT): face order +X −X +Y −Y +Z −Z (face f is
``GL_TEXTURE_CUBE_MAP_POSITIVE_X + f``); texel [f, i, j] of an n×n face sits at
s = (j + ½)/n, t = (i + ½)/n, with the OpenGL cube-map table (sc, tc, ma) applied to the
direction d in our frame (right-handed, +Y up), s = (sc/|ma| + 1)/2, t = (tc/|ma| + 1)/2.

:func:`sample` is the CPU twin of ``textureLod(cube, d, lod)`` with GL_LINEAR_MIPMAP_LINEAR and
GL_TEXTURE_CUBE_MAP_SEAMLESS (OpenGL 4.6 §8.14.1, §8.14.2): the face of the major axis,
bilinear within it on texel centres, a tap that falls off the face's edge taken from the
adjacent face (the texel across the edge), a tap off a corner the mean of the three texels
that meet at the cube's corner, and linear between the mips ⌊lod⌋ and ⌊lod⌋ + 1 (lod clamped
to [0, mip_count − 1]). Direct3D filters cube maps seamlessly too, so the HLSL path is held to
the same reference.
"""
from __future__ import annotations

import ctypes
import ctypes.util

import numpy as np

#: Face names in the contract's order.
FACES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")

#: For each face, the 3×3 matrix taking (a, b, 1) to the direction on the face's plane, with
#: a = sc/|ma| = 2s − 1 and b = tc/|ma| = 2t − 1 (the OpenGL table in our frame).
_FACE_MATRIX = np.array([
    [[0, 0, 1], [0, -1, 0], [-1, 0, 0]],    # +X: sc = -z, tc = -y, ma = x
    [[0, 0, -1], [0, -1, 0], [1, 0, 0]],    # -X: sc = +z, tc = -y
    [[1, 0, 0], [0, 0, 1], [0, 1, 0]],      # +Y: sc = +x, tc = +z, ma = y
    [[1, 0, 0], [0, 0, -1], [0, -1, 0]],    # -Y: sc = +x, tc = -z
    [[1, 0, 0], [0, -1, 0], [0, 0, 1]],     # +Z: sc = +x, tc = -y, ma = z
    [[-1, 0, 0], [0, -1, 0], [0, 0, -1]],   # -Z: sc = -x, tc = -y
], np.float64)            # d = M @ (a, b, 1): rows x, y, z; columns the a, b and ma axes


def face_points(face: int, a, b) -> np.ndarray:
    """Points (…, 3) on the plane of ``face`` at face coordinates a = 2s − 1, b = 2t − 1."""
    a, b = np.broadcast_arrays(np.asarray(a, np.float64), np.asarray(b, np.float64))
    abc = np.stack([a, b, np.ones_like(a)], -1)
    return abc @ _FACE_MATRIX[face].T


def texel_directions(n: int) -> np.ndarray:
    """(6, n, n, 3) float64 unit vectors toward the texel centres of an n×n cube."""
    c = (np.arange(n) + 0.5) / n * 2 - 1
    b, a = np.meshgrid(c, c, indexing="ij")       # row i -> t (b), column j -> s (a)
    d = np.stack([face_points(f, a, b) for f in range(6)])
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def direction_to_face(d) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(face, s, t) of directions (…, 3): the major axis's face (ties: x before y before z)."""
    d = np.asarray(d, np.float64)
    ax = np.abs(d)
    axis = np.where((ax[..., 0] >= ax[..., 1]) & (ax[..., 0] >= ax[..., 2]), 0,
                    np.where(ax[..., 1] >= ax[..., 2], 1, 2))
    major = np.take_along_axis(d, axis[..., None], -1)[..., 0]
    face = 2 * axis + (major < 0)
    m = _FACE_MATRIX[face]                       # (…, 3, 3): columns the a, b, ma axes
    ma = np.abs(major)
    a = np.einsum("...k,...k->...", d, m[..., :, 0]) / ma
    b = np.einsum("...k,...k->...", d, m[..., :, 1]) / ma
    return face, (a + 1) / 2, (b + 1) / 2


def _nearest(face_arrays, d) -> np.ndarray:
    """The texels (…, C) containing directions d (texel centres: exact)."""
    f, s, t = direction_to_face(d)
    n = face_arrays.shape[1]
    i = np.clip(np.floor(t * n).astype(int), 0, n - 1)
    j = np.clip(np.floor(s * n).astype(int), 0, n - 1)
    return face_arrays[f, i, j]


def padded_faces(level: np.ndarray) -> np.ndarray:
    """(6, n+2, n+2, C): each face with a one-texel border from its neighbours (seamless).

    A border texel outside one edge is the texel across that edge on the adjacent face: its
    point on the face's plane, (1 + 1/n) out along the overflowing axis, folds onto the
    neighbour half a texel in (the neighbour's texel centre). A corner of the border is the
    mean of the three texels that meet at that corner of the cube.
    """
    level = np.asarray(level, np.float64)
    n = level.shape[1]
    out = np.zeros((6, n + 2, n + 2, level.shape[-1]))
    out[:, 1:-1, 1:-1] = level
    c = (np.arange(-1, n + 1) + 0.5) / n * 2 - 1          # border and interior centres
    b, a = np.meshgrid(c, c, indexing="ij")
    edge = (np.abs(a) > 1) ^ (np.abs(b) > 1)
    corner = (np.abs(a) > 1) & (np.abs(b) > 1)
    for f in range(6):
        p = face_points(f, a[edge], b[edge])
        over = np.abs(p) > 1
        inner = np.isclose(np.abs(p), 1.0)               # the face's own axis (|p| = 1)
        p = np.where(over, np.sign(p), np.where(inner, np.sign(p) * (1 - 1 / n), p))
        out[f][edge] = _nearest(level, p)
        q = np.sign(face_points(f, a[corner], b[corner]))   # the cube corner (±1, ±1, ±1)
        taps = []
        for axis in range(3):                              # the corner texel of each face there
            r = q * (1 - 1 / n)
            r[:, axis] = q[:, axis]
            taps.append(_nearest(level, r))
        out[f][corner] = np.mean(taps, axis=0)
    return out


def _bilinear(padded: np.ndarray, face, s, t):
    """(values (N, C), largest |tap| (N,)) of bilinear filtering on padded faces."""
    n = padded.shape[1] - 2
    u, v = s * n - 0.5, t * n - 0.5
    j0, i0 = np.floor(u).astype(int), np.floor(v).astype(int)
    fu, fv = (u - j0)[:, None], (v - i0)[:, None]
    j0, i0 = np.clip(j0, -1, n - 1) + 1, np.clip(i0, -1, n - 1) + 1
    taps = [padded[face, i0, j0], padded[face, i0, j0 + 1],
            padded[face, i0 + 1, j0], padded[face, i0 + 1, j0 + 1]]
    value = ((1 - fv) * ((1 - fu) * taps[0] + fu * taps[1])
             + fv * ((1 - fu) * taps[2] + fu * taps[3]))
    return value, np.max([np.abs(x).max(axis=-1) for x in taps], axis=0)


class CubeSampler:
    """CPU twin of ``textureLod`` on a seamless, trilinear cube with these ``mips``
    (a list of (6, n_k, n_k, C) arrays). Pads every level once."""

    def __init__(self, mips):
        self.mips = [np.asarray(m, np.float64) for m in mips]
        self.padded = [padded_faces(m) for m in self.mips]

    def sample(self, directions, lod) -> tuple[np.ndarray, np.ndarray]:
        """(values (N, C), scale (N,)) at directions (N, 3) and lods (N,) or a scalar; scale
        is the largest |texel| among the taps used (the error measure's magnitude)."""
        d = np.asarray(directions, np.float64).reshape(-1, 3)
        lod = np.clip(np.broadcast_to(np.asarray(lod, np.float64), len(d)), 0,
                      len(self.mips) - 1)
        face, s, t = direction_to_face(d)
        lo = np.floor(lod).astype(int)
        frac = (lod - lo)[:, None]
        out = np.zeros((len(d), self.mips[0].shape[-1]))
        scale = np.zeros(len(d))
        for k in range(len(self.mips)):
            for level, weight in ((k, 1 - frac), (min(k + 1, len(self.mips) - 1), frac)):
                sel = lo == k
                if not sel.any():
                    continue
                v, mag = _bilinear(self.padded[level], face[sel], s[sel], t[sel])
                out[sel] += weight[sel] * v
                scale[sel] = np.maximum(scale[sel], mag)
        return out, scale


def sample(mips, directions, lod) -> np.ndarray:
    """``textureLod(cube, d, lod).rgb`` on the CPU (see :class:`CubeSampler`)."""
    return CubeSampler(mips).sample(directions, lod)[0]


# -- test cubes ------------------------------------------------------------------------------------

def cube_from_function(function, size: int, levels: int | None = None) -> list[np.ndarray]:
    """Mips n = size, size/2, … down to 2 (or ``levels`` of them): ``function(directions, k)``
    evaluated at each level's texel centres (directions (6, n, n, 3) -> (6, n, n, C))."""
    mips, n, k = [], size, 0
    while n >= 2 and (levels is None or k < levels):
        mips.append(np.asarray(function(texel_directions(n), k), np.float32))
        n //= 2
        k += 1
    return mips




def cube_from_equirect(image: np.ndarray, size: int = 32) -> list[np.ndarray]:
    """The provider's cube of an equirect panorama (``compute_environment``: mip 0 and the
    GGX-prefiltered mips), as float32 arrays."""
    from ..core.reflections.environment import compute_environment
    return [np.asarray(m, np.float32) for m in compute_environment(image, size=size).mips]


# -- OpenGL upload ------------------------------------------------------------------------------------

GL_TEXTURE_CUBE_MAP = 0x8513
GL_TEXTURE_CUBE_MAP_POSITIVE_X = 0x8515
GL_TEXTURE_CUBE_MAP_SEAMLESS = 0x884F
_GL_FORMATS = {"f4": (0x8814, 0x1406, np.float32),    # GL_RGBA32F, GL_FLOAT
               "f2": (0x881A, 0x140B, np.float16)}    # GL_RGBA16F, GL_HALF_FLOAT
_GL = None


def _gl():
    """The process's OpenGL entry points (libGL dispatches to the current context)."""
    global _GL
    if _GL is None:
        for name in ("libGL.so.1", ctypes.util.find_library("GL"), "libOpenGL.so.0"):
            if not name:
                continue
            try:
                _GL = ctypes.CDLL(name)
                break
            except OSError:
                continue
        else:
            raise RuntimeError("libGL not found: cannot upload cube-map mips")
    return _GL


def as_rgba(mips, dtype: str = "f4") -> list[np.ndarray]:
    """Each mip as (6, n, n, 4) with A = 1, in the upload's precision (float32 or float16)."""
    out = []
    for m in mips:
        m = np.asarray(m, np.float32)
        rgba = np.concatenate([m[..., :3], np.ones(m.shape[:-1] + (1,), np.float32)], -1)
        out.append(np.ascontiguousarray(rgba.astype(_GL_FORMATS[dtype][2])))
    return out


def upload_cube(ctx, mips, dtype: str = "f4", face_order=range(6)):
    """A moderngl cube texture holding every mip (``dtype`` "f4": RGBA32F, "f2": RGBA16F),
    trilinear, GL_TEXTURE_MAX_LEVEL = len(mips) − 1, and seamless filtering enabled in ``ctx``.

    Face ``face_order[f]`` of each mip goes to GL_TEXTURE_CUBE_MAP_POSITIVE_X + f, row 0
    first (the contract is ``range(6)``; anything else is a deliberate slip for the tests).
    """
    internal, gltype, _ = _GL_FORMATS[dtype]
    levels = as_rgba(mips, dtype)
    n0 = levels[0].shape[1]
    tex = ctx.texture_cube((n0, n0), 4, dtype=dtype)
    gl = _gl()
    while gl.glGetError():       # errors left by earlier calls are not this upload's
        pass
    gl.glBindTexture(GL_TEXTURE_CUBE_MAP, tex.glo)
    gl.glPixelStorei(0x0CF5, 1)                                  # GL_UNPACK_ALIGNMENT
    for k, level in enumerate(levels):
        n = level.shape[1]
        for f in range(6):
            data = np.ascontiguousarray(level[face_order[f]])
            gl.glTexImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + f, k, internal, n, n, 0,
                            0x1908, gltype, data.ctypes.data_as(ctypes.c_void_p))  # GL_RGBA
    gl.glTexParameteri(GL_TEXTURE_CUBE_MAP, 0x813C, 0)                    # BASE_LEVEL
    gl.glTexParameteri(GL_TEXTURE_CUBE_MAP, 0x813D, len(levels) - 1)      # MAX_LEVEL
    error = gl.glGetError()
    if error:
        raise RuntimeError(f"OpenGL error 0x{error:04x} uploading the cube map")
    tex.filter = (ctx.LINEAR_MIPMAP_LINEAR, ctx.LINEAR)
    ctx.enable_direct(GL_TEXTURE_CUBE_MAP_SEAMLESS)
    return tex
