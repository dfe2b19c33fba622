"""Spherical-harmonic maths for SH9 lighting (no I/O).

Conventions are fixed by docs/contract.md §1-2 and shared with the GLSL, HLSL and C#:

* frame: right-handed, +Y up;
* real SH basis, order ``L00, L1-1, L10, L11, L2-2, L2-1, L20, L21, L22``;
* coefficients ``L_lm = ∫ L(ω) Y_lm(ω) dω`` (radiance projections), shape ``(9, 3)``
  (coefficient, RGB channel);
* irradiance ``E(n) = Σ Â_l L_lm Y_lm(n)`` = ``ñᵀ M ñ`` with ``ñ = (x, y, z, 1)``.
"""
from __future__ import annotations

import math

import numpy as np

#: Names of the nine coefficients, in storage order.
SH_NAMES = ("L00", "L1-1", "L10", "L11", "L2-2", "L2-1", "L20", "L21", "L22")
#: Band (l) of each coefficient.
SH_BAND = np.array([0, 1, 1, 1, 2, 2, 2, 2, 2])

# Normalisation constants of the real SH basis (docs/contract.md §1).
C0 = 0.282095
C1 = 0.488603
C2 = 1.092548
C20 = 0.315392
C22 = 0.546274

#: Cosine-lobe convolution factors Â_l (docs/contract.md §2).
A_HAT = np.array([math.pi, 2 * math.pi / 3, math.pi / 4])
A_HAT_PER_COEFF = A_HAT[SH_BAND]

# Matrix constants (Ramamoorthi & Hanrahan 2001, eq. 12).
_c1, _c2, _c3, _c4, _c5 = 0.429043, 0.511664, 0.743125, 0.886227, 0.247708


def sh_basis(directions: np.ndarray) -> np.ndarray:
    """Evaluate the nine real SH basis functions.

    Parameters
    ----------
    directions : array_like, shape (..., 3)
        Unit vectors (x, y, z) in the right-handed, +Y-up world frame.

    Returns
    -------
    ndarray, shape (..., 9), float64
    """
    d = np.asarray(directions, dtype=np.float64)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    out = np.empty(d.shape[:-1] + (9,), dtype=np.float64)
    out[..., 0] = C0
    out[..., 1] = C1 * y
    out[..., 2] = C1 * z
    out[..., 3] = C1 * x
    out[..., 4] = C2 * x * y
    out[..., 5] = C2 * y * z
    out[..., 6] = C20 * (3 * z * z - 1)
    out[..., 7] = C2 * x * z
    out[..., 8] = C22 * (x * x - y * y)
    return out


def irradiance(coefficients: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Irradiance E(n) from radiance SH coefficients (not clamped).

    ``coefficients`` is (9, C); ``normals`` (..., 3) unit vectors. Returns (..., C) in the
    units of the coefficients times steradians (a white Lambertian surface shows E/π).
    """
    coeffs = np.asarray(coefficients, dtype=np.float64)
    return sh_basis(normals) @ (A_HAT_PER_COEFF[:, None] * coeffs)


def irradiance_matrices(coefficients: np.ndarray) -> np.ndarray:
    """The symmetric 4×4 irradiance matrix per channel: ``E(n) = ñᵀ M ñ``.

    ``coefficients`` is (9, C) (C channels, normally RGB); returns (C, 4, 4) float64.
    """
    L = np.asarray(coefficients, dtype=np.float64)
    if L.ndim != 2 or L.shape[0] != 9:
        raise ValueError(f"coefficients must have shape (9, C), got {L.shape}")
    L00, L1m1, L10, L11, L2m2, L2m1, L20, L21, L22 = L
    M = np.empty((L.shape[1], 4, 4))
    M[:, 0] = np.stack([_c1 * L22, _c1 * L2m2, _c1 * L21, _c2 * L11], axis=-1)
    M[:, 1] = np.stack([_c1 * L2m2, -_c1 * L22, _c1 * L2m1, _c2 * L1m1], axis=-1)
    M[:, 2] = np.stack([_c1 * L21, _c1 * L2m1, _c3 * L20, _c2 * L10], axis=-1)
    M[:, 3] = np.stack([_c2 * L11, _c2 * L1m1, _c2 * L10, _c4 * L00 - _c5 * L20], axis=-1)
    return M


def irradiance_from_matrices(matrices: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Evaluate ``E(n) = ñᵀ M ñ``; ``matrices`` (C, 4, 4), normals (..., 3) -> (..., C)."""
    n = np.asarray(normals, dtype=np.float64)
    nh = np.concatenate([n, np.ones(n.shape[:-1] + (1,))], axis=-1)
    return np.einsum("...i,cij,...j->...c", nh, np.asarray(matrices, np.float64), nh)


def rotate_matrices(matrices: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """Re-orient irradiance matrices: ``M' = R̃ M R̃ᵀ`` with ``R̃ = diag(R, 1)``.

    ``rotation`` (3×3) maps old world directions to new ones (the environment is rotated by R).
    """
    Rt = np.eye(4)
    Rt[:3, :3] = rotation
    return Rt @ np.asarray(matrices, np.float64) @ Rt.T


def sh_rotation(rotation: np.ndarray) -> np.ndarray:
    """9×9 matrix D such that ``D @ coefficients`` is the environment rotated by ``rotation``.

    The rotated environment is ``L'(ω) = L(Rᵀ ω)``. Band 0 is invariant; band 1 transforms
    like the vector (x, y, z); band 2 is solved exactly from basis values at a fixed set of
    directions (the 5×5 block is determined by any 5 generic directions).
    """
    R = np.asarray(rotation, dtype=np.float64)
    if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-6):
        raise ValueError("rotation must be a 3×3 orthonormal matrix")
    D = np.zeros((9, 9))
    D[0, 0] = 1.0
    # Y(R^T ω) = Y(ω) @ D_blockᵀ ; solve from sample directions.
    samples = _REFERENCE_DIRECTIONS
    Y = sh_basis(samples)
    Yr = sh_basis(samples @ R)  # rows: R^T ω_i
    for sl in (slice(1, 4), slice(4, 9)):
        B, *_ = np.linalg.lstsq(Y[:, sl], Yr[:, sl], rcond=None)  # Yr = Y @ B
        # L'_k = Σ_m L_m B[k, m]: coefficients of the rotated function.
        D[sl, sl] = B
    return D


def rotate_coefficients(coefficients: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """Rotate radiance SH coefficients (9, C) by a 3×3 rotation (see :func:`sh_rotation`)."""
    return sh_rotation(rotation) @ np.asarray(coefficients, np.float64)


def rotation_from_euler(yaw_deg: float = 0.0, pitch_deg: float = 0.0,
                        roll_deg: float = 0.0) -> np.ndarray:
    """Rotation matrix from yaw (about +Y), pitch (about +X), roll (about -Z, the view axis).

    Applied in the order roll, pitch, yaw (R = R_yaw R_pitch R_roll), degrees,
    right-handed, counter-clockwise when looking down the axis toward the origin.
    """
    def axis_angle(axis, deg):
        a = math.radians(deg)
        x, y, z = axis
        c, s, t = math.cos(a), math.sin(a), 1 - math.cos(a)
        return np.array([[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
                         [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
                         [t * x * z - s * y, t * y * z + s * x, t * z * z + c]])
    return (axis_angle((0, 1, 0), yaw_deg) @ axis_angle((1, 0, 0), pitch_deg)
            @ axis_angle((0, 0, -1), roll_deg))


def fibonacci_sphere(n: int) -> np.ndarray:
    """``n`` nearly uniform unit vectors (golden-spiral lattice), shape (n, 3)."""
    i = np.arange(n) + 0.5
    y = 1 - 2 * i / n
    r = np.sqrt(np.maximum(0.0, 1 - y * y))
    phi = math.pi * (3 - math.sqrt(5)) * i
    return np.stack([r * np.cos(phi), y, r * np.sin(phi)], axis=-1)


_REFERENCE_DIRECTIONS = fibonacci_sphere(64)

#: Normals used to measure irradiance over the whole sphere (statistics, windowing, order).
SPHERE_NORMALS = fibonacci_sphere(2048)
_SPHERE_IRRADIANCE_BASIS = sh_basis(SPHERE_NORMALS) * A_HAT_PER_COEFF  # (N, 9)


def sphere_irradiance(coefficients: np.ndarray) -> np.ndarray:
    """Irradiance at :data:`SPHERE_NORMALS`, shape (2048, C)."""
    return _SPHERE_IRRADIANCE_BASIS @ np.asarray(coefficients, np.float64)


def relative_rms(estimate: np.ndarray, reference: np.ndarray) -> float:
    """RMS of (estimate - reference) over RMS of reference, all channels together.

    Returns 0 for a zero reference and a zero estimate (an all-black frame).
    """
    e = np.asarray(estimate, np.float64)
    r = np.asarray(reference, np.float64)
    den = math.sqrt(float(np.mean(r * r)))
    num = math.sqrt(float(np.mean((e - r) ** 2)))
    if den == 0.0:
        return 0.0 if num == 0.0 else math.inf
    return num / den


def irradiance_error(coefficients: np.ndarray, reference: np.ndarray) -> float:
    """Relative RMS irradiance error over the sphere of normals between two SH9 sets."""
    return relative_rms(sphere_irradiance(coefficients), sphere_irradiance(reference))


def truncate_order(coefficients: np.ndarray, order: int) -> np.ndarray:
    """Zero every band above ``order`` (0, 1 or 2)."""
    out = np.array(coefficients, np.float64, copy=True)
    out[SH_BAND > order] = 0.0
    return out


def sinc4_window(cutoff: float) -> np.ndarray:
    """Per-band window weights (bands 0, 1, 2) of Sloan's sinc⁴ deringing window.

    Same window as Filament's cmgen: w_0 = 1, w_l = (sin(πl/c)/(πl/c))⁴ for l < c, else 0.
    A larger cutoff is a weaker window.
    """
    w = np.ones(3)
    for band in (1, 2):
        if band >= cutoff:
            w[band] = 0.0
        else:
            x = math.pi * band / cutoff
            w[band] = (math.sin(x) / x) ** 4
    return w


def apply_window(coefficients: np.ndarray, band_weights: np.ndarray) -> np.ndarray:
    return np.asarray(coefficients, np.float64) * np.asarray(band_weights)[SH_BAND][:, None]


def dering(coefficients: np.ndarray, margin: float = 1e-4) -> tuple[np.ndarray, float | None]:
    """Window the coefficients just enough that irradiance is non-negative on the sphere.

    Bisects the sinc⁴ cutoff (as Filament's cmgen does) for the weakest window whose minimum
    irradiance over :data:`SPHERE_NORMALS`, in every channel, is at least ``margin`` times the
    channel's mean irradiance. Returns ``(coefficients, cutoff)``; ``cutoff`` is None when
    the input already satisfies it (returned unchanged). A negative mean (invalid input)
    leaves only band 0.
    """
    L = np.asarray(coefficients, np.float64)

    def ok(c):
        E = sphere_irradiance(c)
        floor = margin * np.maximum(E.mean(axis=0), 0.0)
        return bool(np.all(E.min(axis=0) >= floor))

    if ok(L):
        return L.copy(), None
    lo, hi = 1.0, 64.0  # cutoff <= 2 keeps band 0 only: always ok for a non-negative mean
    if not ok(apply_window(L, sinc4_window(hi))):
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            if ok(apply_window(L, sinc4_window(mid))):
                lo = mid
            else:
                hi = mid
        cutoff = lo
    else:
        cutoff = hi
    return apply_window(L, sinc4_window(cutoff)), cutoff
